"""The taut bands' fibre tables (`band_fibres`): each fibre's length change less the mean fibre's, the table built,
read and cached, and the force of the fibres each at its own length."""
import numpy as np
import pytest

from shoulder_bench.authoring.fem import band_fibres as F
from shoulder_bench.authoring.fem import bands
from shoulder_bench.authoring.fem.footprint import FootprintSheet
from shoulder_bench.authoring.fem.footprint_compare import fibre_lengths
from shoulder_bench.band_lines import LENGTH_ANCHOR_DEG
from shoulder_bench.cli import main
from shoulder_bench.tendon_law import TendonLaw


def test_departures_are_each_fibres_change_less_the_mean_fibres():
    lengths = np.array([[0.10, 0.11, 0.12], [0.10, 0.12, 0.15], [0.09, 0.10, 0.11]])
    d = F.departures(lengths)
    assert d == pytest.approx(np.array([[-0.0133333, -0.0033333, 0.0166667], [0.0, 0.0, 0.0]]), abs=1e-7)


def test_the_solved_bands_fibres_give_the_departures():
    """At the anchor every departure is 0; elsewhere they are the solved band's own fibre lengths' changes (a solve
    of the sheet at the pose, as the tables solve it), less their mean, and pec1's spread across its width."""
    poses = np.array([LENGTH_ANCHOR_DEG, (60.0, 120.0, 30.0)])
    got = F.solve("pec1", poses)
    assert got["converged"].all()
    assert got["departure_m"][0] == pytest.approx(np.zeros(9), abs=1e-12)
    sheet = FootprintSheet("pec1", "full", surface=bands.surface("pec1"), rest="pose")  # the ramp: its rule
    own = np.array([fibre_lengths(sheet, sheet.solve(tuple(p))["nodes"]) for p in poses])
    assert got["departure_m"][1] == pytest.approx(F.departures(own)[0], abs=1e-6)
    assert np.ptp(got["departure_m"][1]) > 0.02  # 42 mm between its edges there


def test_the_fibre_force_is_the_mean_of_the_fibres_each_at_its_own_length():
    law = TendonLaw.load("fem", ("ssp",))
    length = np.array([0.11, 0.12])
    d = np.array([[-0.004, 0.0, 0.004], [0.0, 0.0, 0.0]])
    got = F.fibre_force(law, length, d, np.array([1.0, 0.5]), np.array([0.0, 0.01]))
    one = law.force(np.array([[0.106], [0.11], [0.114]]), np.zeros((3, 1)), np.ones((3, 1)))[:, 0]
    assert got[0] == pytest.approx(one.mean(), rel=1e-12)
    assert got[1] == pytest.approx(law.force([[0.12]], [[0.01]], [[0.5]])[0, 0], rel=1e-12)
    assert abs(got[0] - law.force([[0.11]], [[0.0]], [[1.0]])[0, 0]) > 1e-3  # the spread changes the force


def test_a_fibre_table_is_built_read_and_reused(tmp_path, monkeypatch):
    """On a grid of 2 x 2 x 2 poses (the tasks' grid is 840): the table holds the solved departures, reads them
    back at its poses, is reused while its inputs stand, and is refused for another tendon or when missing."""
    small = [np.array([30.0, 45.0]), np.array([40.0, 50.0]), np.array([0.0, 15.0])]
    monkeypatch.setattr(bands, "axes", lambda tendon=None: small)
    first = F.build(("pec2",), out=tmp_path, quiet=True)["pec2"]
    assert not first["cached"] and first["input_hash"] == F.input_hash("pec2")
    table = F.FibreTable.load("pec2", tmp_path)
    poses = bands.mesh_poses(small)
    want = F.solve("pec2", poses)
    assert want["converged"].all()
    assert table.departure(poses) == pytest.approx(want["departure_m"], abs=1e-9)
    mid = table.departure([[37.5, 45.0, 7.5]])[0]
    assert mid == pytest.approx(want["departure_m"].mean(axis=0), abs=1e-9)  # trilinear at the cell's centre
    assert F.build(("pec2",), out=tmp_path, quiet=True)["pec2"]["cached"]
    with pytest.raises(ValueError, match="is for 'pec2', not 'ssp'"):
        (tmp_path / "ssp_fibres.npz").write_bytes(F.table_path("pec2", tmp_path).read_bytes())
        F.FibreTable.load("ssp", tmp_path)
    with pytest.raises(ValueError, match="shoulder-bench fem build --fibres --tendon tmi"):
        F.FibreTable.load("tmi", tmp_path)


def test_the_fibre_commands_refuse_what_does_not_go_with_them(capsys):
    with pytest.raises(SystemExit, match="--fibres builds"):
        main(["fem", "build", "--fibres", "--bands"])
    with pytest.raises(SystemExit, match="must be >= 1"):
        main(["fem", "verify", "--fibres", "--held-out", "0"])
    with pytest.raises(SystemExit, match="no band for cor"):
        main(["fem", "build", "--fibres", "--tendon", "cor", "--out", "/tmp/unused_fibres"])


def test_the_verify_fails_a_table_without_the_spread(tmp_path, monkeypatch, capsys):
    """At a held-out pose where pec1's fibres spread over 4 % of F0 of force (the shipped table's), the verify passes
    the shipped table and fails one whose departures are all 0 (the one-length law)."""
    monkeypatch.setattr(bands, "held_out", lambda tendon=None: np.array([[7.5, 135.0, 22.5]]))
    assert F.verify(("pec1",)) == 0
    with np.load(F.table_path("pec1")) as z:
        arrays = {k: z[k] for k in z.files}
    arrays["departure_m"] = np.zeros_like(arrays["departure_m"])
    np.savez(tmp_path / "pec1_fibres.npz", **arrays)
    assert F.verify(("pec1",), tmp_path) == 1
    assert "1 over: FAIL" in capsys.readouterr().out


def test_mujoco_applies_the_fibres_force_with_either_callback():
    """line_of_action="band_fibres": each band tendon's force MuJoCo applies is the mean of its fibres' law, each at
    the band's length plus its departure read from the fibre table (`fibre_force`), with the compiled and the Python
    callbacks alike; the bands' line as with "band"; the other tendons as before."""
    import mujoco

    from shoulder_bench import full_arm
    from shoulder_bench.model import attach_law, install_callbacks

    pose_deg, rates = np.array([52.0, 118.0, 27.0]), np.array([0.3, -0.5, 0.8])
    out = {}
    for line, native in (("band_fibres", True), ("band_fibres", False), ("band", True)):
        law = TendonLaw.load("fem", groups=full_arm.ACTUATORS, line_of_action=line)
        m = full_arm.compile_full()
        attach_law(m, law)
        install_callbacks(native=native)
        try:
            pose, d = full_arm.Pose(m), mujoco.MjData(m)
            d.qpos[:] = pose.qpos(pose_deg)[0]
            d.qvel[pose.dadr] = rates
            d.ctrl[:] = 0.7
            mujoco.mj_forward(m, d)
            out[line, native] = (law, m, d)
        finally:
            install_callbacks()
    law, m, d = out["band_fibres", True]
    np.testing.assert_allclose(out["band_fibres", False][2].actuator_force, d.actuator_force, rtol=1e-12, atol=1e-9)
    ids = [m.actuator(t).id for t in law.actuators]
    cols = [law.actuators.index(t) for t in law.lines.tendons]
    dl, dv = law.lines.lengthening(pose_deg, rates, 0.7)
    length, speed = d.actuator_length[ids].copy(), d.actuator_velocity[ids].copy()
    length[cols] += dl[0]
    speed[cols] += dv[0]
    departures = law.lines.departures(pose_deg)[0]
    for b, t in enumerate(law.lines.tendons):
        one = TendonLaw.load("fem", (t,))
        want = F.fibre_force(one, length[cols[b]], departures[b][None], 0.7, speed[cols[b]])[0]
        assert -d.actuator_force[ids[cols[b]]] == pytest.approx(want, rel=1e-9)
        np.testing.assert_allclose(departures[b], F.FibreTable.load(t).departure([pose_deg])[0], atol=1e-12)
    # what the planners read (TendonLaw.force with TendonLaw.departures) is what MuJoCo applies, every tendon
    act = np.full((1, len(law.muscles)), 0.7)
    np.testing.assert_allclose(law.force(length[None], speed[None], act, law.departures(pose_deg)),
                               -d.actuator_force[ids][None], rtol=1e-9)
    assert not law.departures(pose_deg)[0][:, [k for k in range(len(ids)) if k not in cols]].any()
    np.testing.assert_allclose(law.force(length[None], speed[None], act, np.zeros((1, 9, len(ids)))),
                               law.force(length[None], speed[None], act), rtol=1e-12)
    band = out["band", True][2]
    others = [ids[k] for k in range(len(ids)) if k not in cols]
    np.testing.assert_allclose(band.actuator_force[others], d.actuator_force[others], rtol=1e-12)
    gap = np.abs(band.actuator_force[ids] - d.actuator_force[ids])[cols]
    assert gap.max() > 1.0  # N: the fibres change some band tendon's force here


def test_the_applied_check_covers_the_fibres():
    """`fem verify --bands`'s applied section with line_of_action="band_fibres": MuJoCo's generalised force equals
    the fibres' force times the band's arms at every grid pose and level (tmi's 840 x 6)."""
    from shoulder_bench.authoring.fem.verify_full import applied_vs_fem

    checks = applied_vs_fem(line_of_action="band_fibres", muscles=("tmi",))
    assert len(checks) == 3 and all(ok for _, ok, _ in checks)
