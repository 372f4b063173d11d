"""The glenoid as a second contact of the footprint sheets on the humeral head (a study option:
shoulder_bench/authoring/fem/footprint_glenoid.py, docs/fem.md "Where isp's and ssc's bands roll")."""
import numpy as np
import pytest

from shoulder_bench.authoring.fem import footprint_glenoid as G
from shoulder_bench.authoring.fem.footprint import HUMERAL_HEAD, FootprintSheet

ROLL_IN = (75.0, 100.0, -30.0)  # where ssc's band on the head alone lies partly inside the glenoid's outline


def _inside(sheet, nodes):
    """The nodes touching the head (within 1 mm) inside the glenoid's outline: how far inside (deg)."""
    centre, axis = G.GlenoidSheet.glenoid(sheet)  # the same geometry for a sheet without the contact
    rel = nodes - centre
    r = np.linalg.norm(rel, axis=1)
    angle = np.degrees(np.arccos(np.clip(rel @ axis / r, -1.0, 1.0)))
    near = r < HUMERAL_HEAD["radius_m"] + 0.001
    return G.HALF_ARC_DEG - angle[near & (angle < G.HALF_ARC_DEG)]


def test_the_glenoid_penalty_has_the_gradient_and_hessian_of_its_energy():
    """cap_pass against central differences at nodes on, inside and outside the socket."""
    rng = np.random.default_rng(0)
    radius, axis = HUMERAL_HEAD["radius_m"], np.array([0.0, 0.0, -1.0])
    x = rng.normal(size=(60, 3))
    x[:, 2] = -np.abs(x[:, 2])
    x *= (radius + rng.uniform(-0.002, 0.006, (60, 1))) / np.linalg.norm(x, axis=1, keepdims=True)
    half = np.radians(G.HALF_ARC_DEG)
    args = (np.zeros(3), axis, float(np.cos(half)), radius / np.sin(half), radius, G.SOCKET_M, np.full(60, 1e3),
            G.SMOOTHING_M)

    def run(points, blocks):
        g, b = np.zeros(180), np.zeros((60 if blocks else 0, 3, 3))
        return G.cap_pass(points, *args, g, b), g, b

    _, grad, hess = run(x, True)
    assert np.count_nonzero(grad) > 30  # some nodes inside the socket, some outside
    h = 1e-8
    for i in range(60):
        for a in range(3):
            xp, xm = x.copy(), x.copy()
            xp[i, a] += h
            xm[i, a] -= h
            (ep, gp, _), (em, gm, _) = run(xp, False), run(xm, False)
            assert (ep - em) / (2 * h) == pytest.approx(grad[3 * i + a], abs=1e-6 * np.abs(grad).max())
            column = (gp - gm).reshape(-1, 3)[i] / (2 * h)
            np.testing.assert_allclose(column, hess[i, a], atol=1e-6 * np.abs(hess).max())


def test_the_glenoid_keeps_the_band_out_of_its_place_on_the_head_and_pushes_the_scapula():
    """At a pose where ssc's band on the head alone lies partly where the glenoid is, the band with the glenoid as a
    contact stays out of it (but for the penalty's penetration), and the glenoid's reaction is a load on the
    scapula."""
    plain = FootprintSheet("ssc", "full", surface="head", rest="pose")
    deficit = _inside(plain, plain.solve(ROLL_IN)["nodes"])
    assert len(deficit) >= 5 and deficit.max() > 2.0
    sheet = G.GlenoidSheet("ssc", "full", surface="head", rest="pose")
    sol = sheet.solve(ROLL_IN)
    deficit = _inside(sheet, sol["nodes"])
    assert len(deficit) == 0 or deficit.max() < 1.0
    loads = sheet._contact_loads(sol["nodes"], None)
    assert any(which == "scapula" for which, _, _ in loads)
    # the two contacts' forces apart: the head's and the glenoid's, which together make the sum the solve balances
    head = sum(f for which, _, f in loads if which != "scapula")
    socket = sum(f for which, _, f in loads if which == "scapula")
    assert sol["glenoid_N"] == pytest.approx(np.linalg.norm(socket), rel=1e-9) and sol["glenoid_N"] > 1.0
    assert sol["contact_N"] == pytest.approx(np.linalg.norm(head), rel=1e-9)
    assert sol["contact_N"] != pytest.approx(np.linalg.norm(head + socket), rel=1e-3)


def test_the_glenoid_is_a_contact_beside_the_head_only():
    with pytest.raises(ValueError, match="surface=\"head\""):
        G.GlenoidSheet("ssc", "coarse", surface="wrap", rest="pose")
