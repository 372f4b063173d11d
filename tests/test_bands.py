"""The footprint sheets' line-of-action tables (shoulder_bench/authoring/fem/bands.py, docs/fem.md "Taut bands"):
built on a small piece of the pose grid with coarse sheets, cached, interpolated, verified against re-solved bands,
and the verify fails when a table is off."""
import json

import numpy as np
import pytest

from shoulder_bench.authoring.fem import band_verify, bands, footprint_compare
from shoulder_bench.authoring.fem.footprint import FootprintSheet
from shoulder_bench.authoring.fem.solver import NoConvergence
from shoulder_bench.cli.fem import main as fem_main

# one cell of the tasks' grid (its steps: plane 15, elevation 10, rotation 15 deg) and its centre
AXES = [np.array([30.0, 45.0]), np.array([40.0, 50.0]), np.array([0.0, 15.0])]
CENTRE = [(37.5, 45.0, 7.5)]


@pytest.fixture
def cell(monkeypatch):
    monkeypatch.setattr(bands, "axes", lambda tendon=None: [a.copy() for a in AXES])


def test_a_band_table_is_built_cached_and_verified(cell, monkeypatch, tmp_path, capsys):
    metas = bands.build(("tmi",), coarse=True, out=tmp_path, quiet=True)
    assert metas["tmi"]["cached"] is False and metas["tmi"]["resolution"] == "coarse"
    table = bands.BandTable(bands.table_path("tmi", tmp_path))
    assert table.arrays["moment_arm_m"].shape == (2, 2, 2, 3) and (table.arrays["tension_N"] > 0).all()
    # at a grid pose the correction is the stored difference; between them it is trilinear (the mean at the centre)
    diff = table.arrays["moment_arm_m"] - table.arrays["mjcf_moment_arm_m"]
    np.testing.assert_allclose(table.correction([45.0, 40.0, 15.0])[0], diff[1, 0, 1], atol=1e-15)
    np.testing.assert_allclose(table.correction(CENTRE)[0], diff.reshape(-1, 3).mean(axis=0), atol=1e-15)
    assert bands.build(("tmi",), coarse=True, out=tmp_path, quiet=True)["tmi"]["cached"] is True
    assert band_verify.verify(tmp_path, ("tmi",), poses=CENTRE, quiet=True) == 0
    assert "pass" in capsys.readouterr().out
    # below a = 1 the band continued on its branch: its line moves a little, within the bound here
    assert band_verify.verify(tmp_path, ("tmi",), poses=CENTRE, quiet=True, activations=(0.5, 1.0)) == 0
    out = capsys.readouterr().out
    assert "a = 1 " in out and "a = 0.5 " in out and "FAIL" not in out
    band = bands.solve_poses("tmi", np.array(CENTRE), "coarse", activations=(0.5,))
    moved = np.abs(band["fem_m_at"][0, 0] - band["fem_m"][0])
    assert band["fem_m_at"].shape == (1, 1, 3) and 0 < moved.max() < 0.002
    with pytest.raises(ValueError, match=r"\(0, 1\]"):
        band_verify.verify(tmp_path, ("tmi",), poses=CENTRE, quiet=True, activations=(0.0,))
    # a pose whose band finds no equilibrium on its way down is unsolved at that level, listed, and fails
    real = FootprintSheet.solve_from

    def stuck_below_1_at_the_centre(sheet, pose_deg, start, activation=1.0):
        if activation < 1 and np.allclose(pose_deg, CENTRE[0]):
            raise NoConvergence("stuck")
        return real(sheet, pose_deg, start, activation)
    monkeypatch.setattr(FootprintSheet, "solve_from", stuck_below_1_at_the_centre)
    two = CENTRE + [(32.5, 42.5, 2.5)]
    assert band_verify.verify(tmp_path, ("tmi",), poses=two, quiet=True, activations=(0.5,)) == 1
    out = capsys.readouterr().out
    assert "a = 0.5  1/2 solved" in out and f"unsolved at {CENTRE[0]} deg" in out and "a = 1    2/2 solved" in out
    monkeypatch.setattr(FootprintSheet, "solve_from", real)
    # a table 1 mm off its band in the rotation arm (tmi's peak rotation arm is ~20 mm: ~5 %) fails
    path = bands.table_path("tmi", tmp_path)
    with np.load(path) as z:
        arrays = {k: z[k] for k in z.files}
    arrays["moment_arm_m"][..., 2] += 0.001
    np.savez(path, **arrays)
    assert band_verify.verify(tmp_path, ("tmi",), poses=CENTRE, quiet=True, activations=(0.5,)) == 1
    out = capsys.readouterr().out
    assert "FAIL" in out and f"over at {CENTRE[0]} deg" in out  # the poses over, listed
    assert "over the bound or unsolved: tmi, tmi at a = 0.5" in out  # half the force: still ~2.5 % of the peak
    meta = json.loads(str(np.load(path)["meta"]))
    assert meta["input_hash"] == bands.input_hash("tmi", "coarse", bands.Material())


def test_bad_requests_are_refused_before_any_solve(tmp_path, capsys):
    with pytest.raises(ValueError, match="no band table for dmi"):
        bands.build(("dmi",), coarse=True, out=tmp_path)
    with pytest.raises(ValueError, match="--coarse without --out"):
        bands.build(("tmi",), coarse=True)
    with pytest.raises(SystemExit, match="no band table for dmi"):
        fem_main(["build", "--bands", "--tendon", "dmi", "--coarse", "--out", str(tmp_path)])
    with pytest.raises(SystemExit, match="go with --bands"):
        fem_main(["verify", "--held-out", "3"])
    assert band_verify.verify(tmp_path, quiet=True) == 1  # an empty folder
    assert "no band tables" in capsys.readouterr().out
    with pytest.raises(SystemExit, match="must be >= 0"):
        fem_main(["verify", "--bands", "--held-out", "-1"])
    with pytest.raises(SystemExit, match="must be >= 1"):
        fem_main(["verify", "--bands", "--jobs", "0"])
    with pytest.raises(SystemExit, match="go with --bands"):
        fem_main(["verify", "--jobs", "2"])
    with pytest.raises(SystemExit, match=r"activation levels lie in \(0, 1\]; got 1.5"):
        fem_main(["verify", "--bands", "--activation", "1.5", "--held-out", "0"])
    with pytest.raises(SystemExit, match="go with --bands"):
        fem_main(["verify", "--activation", "0.5"])


def test_held_out_n_beyond_the_tasks_cells_draws_from_the_refined_grids_held_out_poses(monkeypatch):
    """--held-out N on a refined grid: up to the tasks' 588 cells one sub-cell of each; beyond that (ssp's grid twice
    as fine has 4,704 held-out poses) N distinct ones of all, not a sampling error."""
    drawn = []

    def solve(tendon, poses, *a, **k):
        drawn.append(poses)
        raise KeyboardInterrupt  # stop before any solve
    monkeypatch.setattr(band_verify, "solve_poses", solve)
    for n in (5, 600):
        with pytest.raises(KeyboardInterrupt):
            band_verify.verify(tendons=("ssp",), count=n, quiet=True)
    every = {tuple(p) for p in np.round(bands.held_out("ssp"), 6)}
    assert [len(d) for d in drawn] == [5, 600]
    assert all({tuple(p) for p in np.round(d, 6)} <= every and len(np.unique(d, axis=0)) == len(d) for d in drawn)


def test_held_out_0_checks_only_what_mujoco_applies(capsys):
    """The shipped tmi table: no re-solve, the applied-vs-FEM section over its whole grid (840 poses x 6 levels)."""
    assert fem_main(["verify", "--bands", "--tendon", "tmi", "--held-out", "0"]) == 0
    out = capsys.readouterr().out
    assert "0 held-out poses" in out and "tmi rotation: MuJoCo-applied vs FEM at all 840 grid poses x 6 levels" in out


def test_every_shipped_band_table_is_up_to_date_with_its_inputs(monkeypatch):
    """The build's own cache rule (its stored input hash equals the one the current inputs give: model file, footprint
    width, sheet, material, solver, grid, code version) for every shipped table; a changed footprint is found stale."""
    from shoulder_bench.band_lines import BAND_TENDONS

    stored = {t: bands.BandTable(bands.table_path(t)).meta["input_hash"] for t in BAND_TENDONS}
    assert stored == {t: bands.input_hash(t, "full", bands.Material()) for t in BAND_TENDONS}
    monkeypatch.setitem(bands.FOOTPRINT_M, "pec2", 0.0421)  # the whole sternal head for one bundle
    assert bands.input_hash("pec2", "full", bands.Material()) != stored["pec2"]


def test_an_unsolved_grid_pose_takes_its_solved_neighbours_correction(cell, monkeypatch, tmp_path):
    """The neighbours' mean, one step along each coordinate; more than MAX_UNSOLVED of the grid unsolved fails. (tmi
    solved by the ramp alone here: with `least_energy` the other starts would find the pose's equilibrium.)"""
    monkeypatch.setattr(bands, "LEAST_ENERGY", ())
    field = np.arange(2 * 3 * 2 * 3, dtype=float).reshape(2, 3, 2, 3)
    unsolved = np.zeros((2, 3, 2), bool)
    unsolved[1, 1, 0] = True
    got = bands.neighbours_mean(field, unsolved)
    np.testing.assert_array_equal(got[1, 1, 0], np.mean([field[0, 1, 0], field[1, 0, 0], field[1, 2, 0],
                                                         field[1, 1, 1]], axis=0))
    np.testing.assert_array_equal(got[~unsolved], field[~unsolved])
    cluster = unsolved.copy()  # the pose and all its neighbours: they first, from theirs, then it from them
    for j in ((0, 1, 0), (1, 0, 0), (1, 2, 0), (1, 1, 1)):
        cluster[j] = True
    got = bands.neighbours_mean(field, cluster)
    np.testing.assert_array_equal(got[0, 1, 0], np.mean([field[0, 0, 0], field[0, 2, 0], field[0, 1, 1]], axis=0))
    np.testing.assert_allclose(got[1, 1, 0], np.mean([got[j] for j in ((0, 1, 0), (1, 0, 0), (1, 2, 0), (1, 1, 1))],
                                                     axis=0), rtol=1e-15)
    np.testing.assert_array_equal(got[~cluster], field[~cluster])
    with pytest.raises(RuntimeError, match="no solved grid pose"):
        bands.neighbours_mean(field, np.ones_like(unsolved))
    from shoulder_bench.authoring.fem.footprint import FootprintSheet
    from shoulder_bench.authoring.fem.solver import NoConvergence

    solve = FootprintSheet.solve

    def one_fails(self, pose, activation=1.0):
        if tuple(pose) == (45.0, 50.0, 15.0):
            raise NoConvergence("no")
        return solve(self, pose, activation)

    monkeypatch.setattr(FootprintSheet, "solve", one_fails)
    with pytest.raises(RuntimeError, match="no equilibrium of the taut band at 1 grid pose"):
        bands.solve_grid("tmi", "coarse")  # 1 of 8 poses is over MAX_UNSOLVED
    monkeypatch.setattr(bands, "MAX_UNSOLVED", 0.2)
    grid = bands.solve_grid("tmi", "coarse")
    assert grid["unsolved"].sum() == 1 and grid["unsolved"][1, 1, 1]
    c = grid["moment_arm_m"] - grid["mjcf_moment_arm_m"]
    np.testing.assert_allclose(c[1, 1, 1], np.mean([c[0, 1, 1], c[1, 0, 1], c[1, 1, 0]], axis=0))


def test_the_tables_read_trilinearly_or_by_a_tricubic_spline(tmp_path):
    """A correction cubic in every coordinate: the spline gives it back (to 1e-4) between the grid's poses, trilinear
    does not; at the grid's poses both give the stored values; an unknown interpolation is refused."""
    axes = [np.arange(0.0, 91.0, 15.0), np.arange(0.0, 141.0, 10.0), np.arange(-45.0, 61.0, 15.0)]
    P, E, R = np.meshgrid(*axes, indexing="ij")
    field = np.stack([(P / 90) ** 3, (E / 140) ** 3 - E / 140, (R / 60) ** 2 * (P / 90)], axis=-1) * 1e-3
    meta = {"tendon": "tmi", "resolution": "coarse"}
    np.savez(tmp_path / "tmi_band.npz", plane_deg=axes[0], elevation_deg=axes[1], rotation_deg=axes[2],
             moment_arm_m=field + 0.01, mjcf_moment_arm_m=np.full(field.shape, 0.01), meta=np.array(json.dumps(meta)))
    q = np.array([[37.5, 45.0, 7.5], [82.5, 135.0, -37.5]])
    exact = np.stack([(q[:, 0] / 90) ** 3, (q[:, 1] / 140) ** 3 - q[:, 1] / 140,
                      (q[:, 2] / 60) ** 2 * (q[:, 0] / 90)], axis=-1) * 1e-3
    cubic = bands.BandTable(tmp_path / "tmi_band.npz", "cubic")
    linear = bands.BandTable(tmp_path / "tmi_band.npz")
    np.testing.assert_allclose(cubic.correction(q), exact, atol=1e-7)  # 1e-4 of the field: scipy's spline
    assert np.abs(linear.correction(q) - exact).max() > 1e-5
    np.testing.assert_allclose(linear.correction([[45.0, 70.0, 15.0]])[0], field[3, 7, 4], atol=1e-15)
    with pytest.raises(ValueError, match="unknown interpolation"):
        bands.BandTable(tmp_path / "tmi_band.npz", "nearest")


def test_tendons_build_in_parallel_processes(cell, tmp_path):
    metas = bands.build(("tmi", "pec1"), coarse=True, out=tmp_path, jobs=2, quiet=True)
    assert [m["cached"] for m in metas.values()] == [False, False]
    for t in ("tmi", "pec1"):
        table = bands.BandTable(bands.table_path(t, tmp_path))
        assert table.tendon == t and np.isfinite(table.arrays["moment_arm_m"]).all()


def test_least_energy_takes_tmis_lower_equilibrium_where_the_ramp_lands_on_the_higher():
    """At (37.5, 45, -22.5) deg tmi's activated sheet has two equilibria (docs/fem.md "What each miss is"): the ramp
    from rest lands on the one 3 mJ higher (rotation arm -20.70 mm); least_energy finds the other (-21.30 mm)."""
    from shoulder_bench.authoring.fem.footprint_compare import compare

    p = np.array([[37.5, 45.0, -22.5]])
    ramp = compare("tmi", p, "full", rest="pose")
    low = bands.least_energy("tmi", p, "full")
    assert low["converged"].all() and bands.solve_poses("tmi", p, "full")["fem_m"] == pytest.approx(low["fem_m"])
    assert ramp["fem_m"][0, 2] == pytest.approx(-20.70e-3, abs=0.05e-3)
    assert low["fem_m"][0, 2] == pytest.approx(-21.30e-3, abs=0.05e-3)
    np.testing.assert_allclose(low["mjcf_m"], ramp["mjcf_m"])


def test_refined_grids_nest_the_tasks_grid_and_read_as_their_own_tables(tmp_path):
    """ssp's and pec1's tables are on the tasks' grid with its step halved (REFINE), tma's with its plane and rotation
    steps divided by 3 and its elevation step by 2; BandLines reads tables on different grids on the coarsest that
    nests them all (steps divided by 6, 2, 6), each as its own BandTable reads it; a grid over another range is
    refused."""
    from shoulder_bench.band_lines import BandLines

    coarse, fine = bands.axes(), bands.axes("ssp")
    assert [len(a) for a in fine] == [2 * len(a) - 1 for a in coarse]
    np.testing.assert_array_equal(fine[0][::2], coarse[0])
    assert len(bands.held_out("pec1")) == np.prod([len(a) - 1 for a in fine]) and len(bands.held_out()) == 588
    from shoulder_bench.authoring.fem.footprint_grid import cells  # `fem verify --bands --held-out N`'s draw

    third = bands.axes("tma")
    assert [len(a) for a in third] == [3 * len(coarse[0]) - 2, 2 * len(coarse[1]) - 1, 3 * len(coarse[2]) - 2]
    assert len(bands.held_out("tma")) == np.prod([len(a) - 1 for a in third])
    for t in ("ssp", "tma"):
        drawn = cells(5, refine=bands.refinement(t))[0]
        assert (np.abs(drawn[:, None] - bands.held_out(t)[None]).max(axis=2).min(axis=1) < 1e-9).all()
    rng = np.random.default_rng(0)
    meta = {"tendon": "x", "resolution": "full"}
    for t, axes in (("tmi", coarse), ("ssp", fine), ("tma", third)):
        shape = tuple(len(a) for a in axes) + (3,)
        np.savez(tmp_path / f"{t}_band.npz", plane_deg=axes[0], elevation_deg=axes[1], rotation_deg=axes[2],
                 moment_arm_m=rng.normal(0, 1e-3, shape), mjcf_moment_arm_m=np.zeros(shape),
                 meta=np.array(json.dumps(dict(meta, tendon=t))))
    lines = BandLines.load(("tmi", "ssp", "tma"), tmp_path)
    assert lines.table.shape[1:5] == (1, 6 * 6 + 1, 2 * 14 + 1, 6 * 7 + 1)  # one activation level: no level tables
    q = np.column_stack([rng.uniform(0, 90, 50), rng.uniform(0, 140, 50), rng.uniform(-45, 60, 50)])
    got = lines.correction(q)
    for b, t in enumerate(("tmi", "ssp", "tma")):
        np.testing.assert_allclose(got[:, b], bands.BandTable(tmp_path / f"{t}_band.npz").correction(q), atol=1e-15)
    shifted, shape = [fine[0] + 1.0, fine[1], fine[2]], tuple(len(a) for a in fine) + (3,)
    np.savez(tmp_path / "ssp_band.npz", plane_deg=shifted[0], elevation_deg=shifted[1], rotation_deg=shifted[2],
             moment_arm_m=np.zeros(shape), mjcf_moment_arm_m=np.zeros(shape), meta=np.array(json.dumps(meta)))
    with pytest.raises(ValueError, match="other ranges"):
        BandLines.load(("tmi", "ssp"), tmp_path)


def test_poses_solved_in_processes_equal_those_solved_in_one(monkeypatch):
    """`solve_poses(jobs=2)` (the band build's and verify's --jobs) splits the poses into chunks solved in two worker
    processes and puts them back in order: the same arrays as one process, the progress counted per pose."""
    monkeypatch.setattr(bands, "CHUNK", 2)
    poses = bands.held_out()[::97]  # 7 poses: chunks of 2, 2, 2, 1
    one = bands.solve_poses("pec1", poses, "coarse")
    counted = []
    two = bands.solve_poses("pec1", poses, "coarse", progress=counted.append, jobs=2)
    assert sum(counted) == len(poses) and len(counted) == 4
    for k in ("fem_m", "mjcf_m", "tension_N", "converged", "stretch"):
        np.testing.assert_allclose(two[k], one[k], rtol=1e-12, atol=1e-15)
    np.testing.assert_array_equal(two["poses_deg"], poses)


def test_a_parallel_build_keeps_one_pool_and_saves_the_chunks_it_has_finished(monkeypatch, tmp_path):
    """`fem build --bands --jobs 2`: one pool of processes for the tendon's poses, saving the chunks finished so far
    each time SAVE_EVERY more poses are done (in whatever order they finish), and the table a single process builds."""
    monkeypatch.setattr(bands, "LEAST_ENERGY", ())  # the ramp alone on the tasks' grid: quick
    monkeypatch.setattr(bands, "REFINE", {})
    monkeypatch.setattr(bands, "CHUNK", 100)
    monkeypatch.setattr(bands, "SAVE_EVERY", 300)
    saved, real = [], bands.save_partial
    monkeypatch.setattr(bands, "save_partial", lambda path, digest, known, *a: saved.append(known["poses"].copy())
                        or real(path, digest, known, *a))
    bands.build(("pec1",), coarse=True, out=tmp_path / "two", jobs=2, quiet=True)
    grid = {tuple(p) for p in bands.grid_poses("pec1")}  # 840 poses: chunks of 100, the last of 40
    assert [len(p) for p in saved] == [300, 600]
    first, second = ({tuple(p) for p in poses} for poses in saved)
    assert len(second) == 600 and first < second < grid
    assert not bands.partial_path("pec1", tmp_path / "two").exists()
    bands.build(("pec1",), coarse=True, out=tmp_path / "one", quiet=True)
    two, one = (bands.BandTable(bands.table_path("pec1", tmp_path / d)).arrays for d in ("two", "one"))
    for k in ("moment_arm_m", "mjcf_moment_arm_m", "tension_N", "contact_N", "unsolved"):
        np.testing.assert_allclose(two[k], one[k], rtol=1e-9, atol=1e-12)


def test_a_refined_grid_reuses_the_poses_its_previous_table_solved(cell, monkeypatch, tmp_path, capsys):
    """A build onto a finer grid takes the poses the stale table already holds (built from the same inputs on its own
    grid, so each pose's equilibrium is the same) and solves only the new ones: the table equals one built from
    nothing, the poses solved are counted, and a table built by another rule is not reused."""
    monkeypatch.setattr(bands, "LEAST_ENERGY", ())  # the ramp alone: quick
    bands.build(("pec1",), coarse=True, out=tmp_path, quiet=True)
    finer = [AXES[0], np.array([40.0, 45.0, 50.0]), AXES[2]]
    monkeypatch.setattr(bands, "axes", lambda tendon=None: [a.copy() for a in finer])
    solved = []
    real = bands.solve_poses
    monkeypatch.setattr(bands, "solve_poses", lambda t, poses, *a, **k: solved.append(len(poses)) or real(
        t, poses, *a, **k))
    assert fem_main(["build", "--bands", "--tendon", "pec1", "--coarse", "--out", str(tmp_path)]) == 0
    assert "solved but 8 poses taken from the table it replaces" in capsys.readouterr().out
    meta = bands.BandTable(bands.table_path("pec1", tmp_path)).meta
    assert solved == [4] and meta["reused_poses"] == 8
    again = bands.build(("pec1",), coarse=True, out=tmp_path / "fresh", quiet=True)["pec1"]
    assert solved == [4, 12] and again["reused_poses"] == 0 and again["input_hash"] == meta["input_hash"]
    reused, fresh = (bands.BandTable(bands.table_path("pec1", d)).arrays for d in (tmp_path, tmp_path / "fresh"))
    for k in ("moment_arm_m", "mjcf_moment_arm_m", "tension_N", "contact_N", "unsolved"):
        np.testing.assert_allclose(reused[k], fresh[k], rtol=1e-9, atol=1e-12)
    monkeypatch.setattr(bands, "LEAST_ENERGY", {"pec1": 1})  # another rule: its hash differs, nothing is reused
    assert bands.reusable(bands.table_path("pec1", tmp_path), "pec1", "coarse", bands.Material()) is None


def test_an_interrupted_build_resumes_from_the_poses_it_saved(cell, monkeypatch, tmp_path, interrupt_after_one_block):
    """A build interrupted after its first block of poses keeps them (the partial file, with its input hash); the
    rerun solves only the rest, counts the resumed poses, removes the file and writes the table a build from nothing
    writes; a partial file from other inputs is not used."""
    monkeypatch.setattr(bands, "LEAST_ENERGY", ())  # the ramp alone: quick
    solved, real = interrupt_after_one_block()
    with pytest.raises(KeyboardInterrupt):
        bands.build(("pec1",), coarse=True, out=tmp_path, quiet=True)
    partial = bands.partial_path("pec1", tmp_path)
    assert partial.exists() and not bands.table_path("pec1", tmp_path).exists()
    assert bands.resumed(partial, "another input hash") is None
    monkeypatch.setattr(bands, "solve_poses", lambda t, poses, *a, **k: solved.append(len(poses)) or real(
        t, poses, *a, **k))
    meta = bands.build(("pec1",), coarse=True, out=tmp_path, quiet=True)["pec1"]
    assert solved == [3, 3, 2] and meta["resumed_poses"] == 3 and meta["reused_poses"] == 0
    assert not partial.exists()
    monkeypatch.setattr(bands, "SAVE_EVERY", 200)
    bands.build(("pec1",), coarse=True, out=tmp_path / "fresh", quiet=True)
    resumed, fresh = (bands.BandTable(bands.table_path("pec1", d)).arrays for d in (tmp_path, tmp_path / "fresh"))
    for k in ("moment_arm_m", "mjcf_moment_arm_m", "tension_N", "contact_N", "unsolved"):
        np.testing.assert_allclose(resumed[k], fresh[k], rtol=1e-9, atol=1e-12)


def test_the_continuation_down_in_activation_halves_a_step_newton_cannot_take():
    """`footprint_compare.continued`: a step Newton fails on is taken in halves (at most HALVINGS times); beyond that
    the level is NaN unless the ramp from rest or (with `offsets_deg`) a start beside the pose reaches it, and the next
    level goes on from the last one kept. A stand-in sheet whose Newton converges only over steps of at most 0.1, whose
    ramp from rest converges only at a <= 0.05 and whose starts beside the pose only at a = 0.08."""
    class Sheet:
        def solve_from(self, pose_deg, start, activation):
            if abs(activation - start) > 0.1 + 1e-12:
                raise NoConvergence("step too long")
            return {"moment_arm_m": np.full(3, activation), "nodes": activation, "energy_J": 0.0}

        def solve(self, pose_deg, activation):
            if activation > 0.05:
                raise NoConvergence("no ramp")
            return {"nodes": activation}

        def solve_least_energy(self, pose_deg, offsets_deg, activation, ramp):
            assert not ramp and len(offsets_deg) == 1  # the ramp was tried already
            if activation != 0.08:
                raise NoConvergence("no start")
            return {"moment_arm_m": np.full(3, -activation), "nodes": activation, "energy_J": 0.0}

    arms = footprint_compare.continued(Sheet(), (0, 0, 0), 1.0, (0.75, 0.5))  # steps of 0.25: halved twice (0.0625)
    np.testing.assert_allclose(arms, [[0.75] * 3, [0.5] * 3])
    arms = footprint_compare.continued(Sheet(), (0, 0, 0), 1.0, (0.9, 0.06))  # 0.06 at 1/8 of the step: 0.105, too long
    assert np.allclose(arms[0], 0.9) and np.isnan(arms[1]).all()
    arms = footprint_compare.continued(Sheet(), (0, 0, 0), 1.0, (0.08, 0.04))  # neither reaches 0.08; the ramp 0.04
    assert np.isnan(arms[0]).all() and np.allclose(arms[1], 0.04)
    arms = footprint_compare.continued(Sheet(), (0, 0, 0), 1.0, (0.08, 0.0), offsets_deg=[(7.5, 0.0, 0.0)])
    np.testing.assert_allclose(arms, [[-0.08] * 3, [0.0] * 3])  # 0.08 from the start beside; 0.0 continued from it


def test_below_a_1_the_band_keeps_the_lower_energy_of_the_continued_and_the_ramped_equilibrium():
    """`footprint_compare.continued`: at each level the least-energy of the equilibrium continued from the level above
    and the ramp's from rest; the next level continues from the one kept. A stand-in sheet with two branches: the
    continuation stays on the branch it starts on ("high" from a = 1), the ramp lands on "low", which has less energy
    at a = 0.5 only."""
    class Sheet:
        def solve_from(self, pose_deg, start, activation):
            branch = start if start in ("high", "low") else "low"  # from the ramp's nodes: its branch
            energy = {"high": 1.0, "low": 2.0 if activation > 0.6 else 0.0}[branch]
            return {"moment_arm_m": np.full(3, {"high": 1.0, "low": -1.0}[branch]), "nodes": branch,
                    "energy_J": energy}

        def solve(self, pose_deg, activation):
            return {"nodes": "ramp"}

    arms = footprint_compare.continued(Sheet(), (0, 0, 0), "high", (0.75, 0.5, 0.25))
    np.testing.assert_allclose(arms[:, 0], [1.0, -1.0, -1.0])  # a = 0.75: "high" is lower; then "low", kept below


def test_isps_band_presses_on_the_humeral_head_and_the_others_on_their_wrap_objects(monkeypatch):
    """bands.SURFACE: isp's band is solved against the humeral head sphere (its table's hash says so); the other
    tendons keep the MJCF's wrap object, so their tables' hashes are as they were before SURFACE."""
    pose = np.array([[30.0, 40.0, 0.0]])
    isp = bands.solve_poses("isp", pose, "coarse")
    assert isp["surface"] == "head" and isp["converged"][0] and isp["contact_N"][0] > 0
    assert bands.solve_poses("tma", pose, "coarse")["surface"] == "wrap"
    material = bands.Material()
    now = {t: bands.input_hash(t, "coarse", material) for t in ("isp", "ssp")}
    monkeypatch.setattr(bands, "SURFACE", {})  # every band on its wrap object
    assert now["isp"] != bands.input_hash("isp", "coarse", material)
    assert now["ssp"] == bands.input_hash("ssp", "coarse", material)


def test_the_verify_lists_ten_poses_over_the_bound_and_the_box_that_holds_them_all(capsys):
    held = np.array([(7.5 + 15 * i, 5.0 + 10 * i, -37.5 + 15 * (i % 8)) for i in range(12)])
    pct = np.full((12, 3), 0.5)
    pct[:11, 1] = 3.0  # eleven over the 2 % bound, the last one within it
    assert not band_verify.check("ssc", 1.0, held, pct)
    out = capsys.readouterr().out
    assert out.count("over at") == band_verify.SHOW_OVER == 10 and "11 poses over the bound" in out
    lo, hi = held[:11].min(axis=0), held[:11].max(axis=0)
    assert (f"all 11 over the bound within plane {lo[0]:g}-{hi[0]:g}, elevation {lo[1]:g}-{hi[1]:g}, rotation "
            f"{lo[2]:g}-{hi[2]:g} deg") in out


def test_a_fallback_tendons_band_is_the_ramps_and_the_starts_only_where_the_ramp_finds_none(monkeypatch):
    """bands.FALLBACK (pec2): `solve_poses` keeps the ramp's equilibrium where it converges; where it does not (made
    to fail here at one pose), the least-energy of the six starts beside the pose, the ramp not tried again. Without
    the rule that pose is unsolved; the rule is in the table's input hash."""
    poses, calls = np.array([[30.0, 40.0, 0.0], [45.0, 60.0, 15.0]]), []
    ramp, least = FootprintSheet.solve, FootprintSheet.solve_least_energy

    def failing(self, pose_deg, activation=1.0):
        if np.allclose(pose_deg, poses[1]):
            raise NoConvergence("made to fail")
        return ramp(self, pose_deg, activation)

    def spied(self, pose_deg, offsets_deg, activation=1.0, ramp=True):
        calls.append((tuple(pose_deg), len(offsets_deg), ramp))
        return least(self, pose_deg, offsets_deg, activation, ramp)

    monkeypatch.setattr(FootprintSheet, "solve", failing)
    monkeypatch.setattr(FootprintSheet, "solve_least_energy", spied)
    assert bands.solve_poses("pec2", poses, "coarse")["converged"].all()
    assert calls == [(tuple(poses[1]), 6, False)]
    digest = bands.input_hash("pec2", "coarse", bands.Material())
    monkeypatch.setattr(bands, "FALLBACK", ())
    assert bands.solve_poses("pec2", poses, "coarse")["converged"].tolist() == [True, False]
    assert bands.input_hash("pec2", "coarse", bands.Material()) != digest
