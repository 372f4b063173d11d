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


def test_the_fibre_build_takes_the_fibres_the_band_build_solved(tmp_path, monkeypatch, capsys):
    """`fem build --bands` keeps each pose's fibre lengths in the band table, and `fem build --fibres` into the same
    folder takes them from it, solving only what it lacks (here the anchor, off this grid): the table is the one built
    by solving every pose. A band table from before the tables kept their fibres lends nothing."""
    small = [np.array([30.0, 45.0]), np.array([40.0, 50.0]), np.array([0.0, 15.0])]
    monkeypatch.setattr(bands, "axes", lambda tendon=None: [a.copy() for a in small])
    bands.build(("pec2",), out=tmp_path / "bands", quiet=True)
    with np.load(bands.table_path("pec2", tmp_path / "bands")) as z:
        band = {k: z[k] for k in z.files}
    assert band["fibre_m"].shape == (2, 2, 2, 9) and np.isfinite(band["fibre_m"]).all() and not band["unsolved"].any()
    solved, real = [], bands.solve_poses
    monkeypatch.setattr(bands, "solve_poses", lambda t, poses, *a, **k: solved.append(len(poses)) or real(
        t, poses, *a, **k))
    assert main(["fem", "build", "--fibres", "--tendon", "pec2", "--out", str(tmp_path / "bands")]) == 0
    assert "solved but 8 poses taken from its band table" in capsys.readouterr().out
    assert solved == [1]  # the anchor (30, 45, 0) alone
    assert not F.build(("pec2",), out=tmp_path / "alone", quiet=True)["pec2"]["band_poses"]  # no band table there
    assert solved == [1, 9]
    (tmp_path / "old").mkdir()
    np.savez(bands.table_path("pec2", tmp_path / "old"), **{k: v for k, v in band.items() if k != "fibre_m"})
    assert F.band_poses("pec2", tmp_path / "old") is None
    F.build(("pec2",), out=tmp_path / "old", quiet=True)
    assert solved == [1, 9, 9]
    taken, alone, old = (F.FibreTable.load("pec2", tmp_path / d) for d in ("bands", "alone", "old"))
    assert taken.meta["input_hash"] == alone.meta["input_hash"]
    poses = bands.mesh_poses(small)
    np.testing.assert_allclose(taken.departure(poses), alone.departure(poses), rtol=0, atol=1e-12)
    np.testing.assert_allclose(old.departure(poses), alone.departure(poses), rtol=0, atol=1e-12)


def test_the_fibre_commands_refuse_what_does_not_go_with_them(capsys):
    with pytest.raises(SystemExit, match="--fibres builds"):
        main(["fem", "build", "--fibres", "--bands"])
    with pytest.raises(SystemExit, match="must be >= 1"):
        main(["fem", "verify", "--fibres", "--held-out", "0"])
    with pytest.raises(SystemExit, match="no band for cor"):
        main(["fem", "build", "--fibres", "--tendon", "cor", "--out", "/tmp/unused_fibres"])
    with pytest.raises(SystemExit, match="no band for dmi; tendons with one: ssp"):  # not "build it": it has none
        main(["fem", "verify", "--fibres", "--tendon", "dmi"])


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


def test_the_applied_check_covers_the_fibres():
    """`fem verify --bands`'s applied section with line_of_action="band_fibres": MuJoCo's generalised force equals
    the fibres' force times the band's arms at every grid pose and level (tmi's 840 x 6)."""
    from shoulder_bench.authoring.fem.verify_full import applied_vs_fem

    checks = applied_vs_fem(line_of_action="band_fibres", muscles=("tmi",))
    assert len(checks) == 3 and all(ok for _, ok, _ in checks)
