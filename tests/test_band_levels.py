"""The band's line below a = 1, tabled (shoulder_bench/authoring/fem/band_levels.py; docs/fem.md "The activation
tabled"): built on one cell of the pose grid with coarse sheets, cached, resumed, read by `BandLines` linearly in the
activation, verified, and applied by MuJoCo's passive callback."""
import json

import numpy as np
import pytest

from shoulder_bench import full_arm
from shoulder_bench.authoring.fem import band_levels, band_verify, bands
from shoulder_bench.band_lines import BandLines, levels_path, read_table, table_path
from shoulder_bench.cli.fem import main as fem_main

AXES = [np.array([30.0, 45.0]), np.array([40.0, 50.0]), np.array([0.0, 15.0])]  # one cell of the tasks' grid
CENTRE = [(37.5, 45.0, 7.5)]


@pytest.fixture
def cell(monkeypatch):
    monkeypatch.setattr(bands, "axes", lambda tendon=None: [a.copy() for a in AXES])
    monkeypatch.setattr(bands, "LEAST_ENERGY", ())  # the ramp alone: quick
    monkeypatch.setattr(band_levels, "LEVEL_TENDONS", ("tmi",))
    monkeypatch.setattr(band_levels, "LEVELS", (0.75, 0.5))


def test_a_level_table_is_built_cached_read_and_verified(cell, tmp_path, capsys):
    assert fem_main(["build", "--bands", "--tendon", "tmi", "--coarse", "--out", str(tmp_path)]) == 0
    assert "tmi: its band below a = 1 on the tasks' grid, solved" in capsys.readouterr().out
    assert band_levels.build(("tmi", "pec1"), coarse=True, out=tmp_path, quiet=True).keys() == {"tmi"}
    assert band_levels.build(("tmi",), coarse=True, out=tmp_path, quiet=True)["tmi"]["cached"] is True
    with np.load(levels_path("tmi", tmp_path)) as z:
        arms, levels = z["moment_arm_m"], z["activation"]
    band = read_table(table_path("tmi", tmp_path))[0]
    assert levels.tolist() == [1.0, 0.75, 0.5] and arms.shape == (3, 2, 2, 2, 3)
    np.testing.assert_allclose(arms[0], band["moment_arm_m"], atol=1e-12)  # a = 1: the band table's rule and poses
    moved = np.abs(arms[2] - arms[0]).max()
    assert 1e-6 < moved < 0.002  # m: the line moves a little below a = 1
    direct = bands.solve_poses("tmi", np.array([[45.0, 40.0, 15.0]]), "coarse", activations=(0.75, 0.5))
    np.testing.assert_allclose(arms[1:, 1, 0, 1], direct["fem_m_at"][0], atol=1e-12)
    # read: the band table's correction at a = 1, plus each level's move, linear between levels, the lowest below it
    lines = BandLines.load(("tmi",), tmp_path)
    c = band["moment_arm_m"] - band["mjcf_moment_arm_m"]
    at = [45.0, 40.0, 15.0]
    edge = 1e-9  # m: the grid's top edge read at a weight of 1 - 1e-6, as the band tables are
    np.testing.assert_allclose(lines.correction(at, 1.0)[0, 0], c[1, 0, 1], atol=edge)
    np.testing.assert_allclose(lines.correction(at, 0.75)[0, 0], c[1, 0, 1] + arms[1, 1, 0, 1] - arms[0, 1, 0, 1],
                               atol=edge)
    np.testing.assert_allclose(lines.correction(at, 0.625), (lines.correction(at, 0.75) + lines.correction(at, 0.5))
                               / 2, atol=1e-15)
    np.testing.assert_allclose(lines.correction(at, 0.1), lines.correction(at, 0.5), atol=1e-15)
    np.testing.assert_allclose(lines.correction(CENTRE, 0.5)[0, 0], (c + arms[2] - arms[0]).reshape(-1, 3).mean(0),
                               atol=1e-15)
    assert band_verify.verify(tmp_path, ("tmi",), poses=CENTRE, quiet=True, activations=(0.75, 0.5)) == 0
    assert "FAIL" not in capsys.readouterr().out
    # a level table 1 mm off in the rotation arm at a = 0.5 fails the verify there, not at a = 1
    with np.load(levels_path("tmi", tmp_path)) as z:
        saved = {k: z[k] for k in z.files}
    off = dict(saved, moment_arm_m=saved["moment_arm_m"].copy())
    off["moment_arm_m"][2, ..., 2] += 0.001
    np.savez(levels_path("tmi", tmp_path), **off)
    assert band_verify.verify(tmp_path, ("tmi",), poses=CENTRE, quiet=True, activations=(0.5,)) == 1
    out = capsys.readouterr().out
    assert "over the bound or unsolved: tmi at a = 0.5" in out and "a = 1    1/1 solved" in out
    # made for another band table: refused where it is read, rebuilt by the build
    np.savez(levels_path("tmi", tmp_path), **dict(saved, meta=np.array(json.dumps(
        dict(json.loads(str(saved["meta"])), band_table_hash="another")))))
    with pytest.raises(ValueError, match="made for another band table"):
        BandLines.load(("tmi",), tmp_path)
    assert band_levels.build(("tmi",), coarse=True, out=tmp_path, quiet=True)["tmi"]["cached"] is False


def test_an_interrupted_level_build_resumes_and_unsolved_levels_take_their_neighbours(cell, monkeypatch, tmp_path,
                                                                                     interrupt_after_one_block):
    bands.build(("tmi",), coarse=True, out=tmp_path, quiet=True)
    solved, real = interrupt_after_one_block()
    with pytest.raises(KeyboardInterrupt):
        band_levels.build(("tmi",), coarse=True, out=tmp_path, quiet=True)
    assert band_levels.partial_path("tmi", tmp_path).exists() and not levels_path("tmi", tmp_path).exists()

    def one_unsolved_at_half(t, poses, *a, **k):  # the continuation fails at (45, 50, 15) at a = 0.5
        solved.append(len(poses))
        out = real(t, poses, *a, **k)
        out["fem_m_at"][np.all(poses == (45.0, 50.0, 15.0), axis=1), 1] = np.nan
        return out
    monkeypatch.setattr(bands, "solve_poses", one_unsolved_at_half)
    with pytest.raises(RuntimeError, match="no equilibrium at"):  # 1 of 8 poses at a = 0.5: over MAX_UNSOLVED
        band_levels.build(("tmi",), coarse=True, out=tmp_path, quiet=True)
    assert solved == [3, 3, 2]  # the first block resumed; all eight kept though no table was written
    monkeypatch.setattr(bands, "MAX_UNSOLVED", 0.2)
    meta = band_levels.build(("tmi",), coarse=True, out=tmp_path, quiet=True)["tmi"]
    assert solved == [3, 3, 2] and meta["resumed_poses"] == 8
    assert meta["unsolved_poses_deg"]["0.5"] == [[45.0, 50.0, 15.0]] and meta["unsolved_poses_deg"]["0.75"] == []
    assert not band_levels.partial_path("tmi", tmp_path).exists()
    with np.load(levels_path("tmi", tmp_path)) as z:
        arms = z["moment_arm_m"]
    move = arms[2] - arms[0]
    np.testing.assert_allclose(move[1, 1, 1], np.mean([move[0, 1, 1], move[1, 0, 1], move[1, 1, 0]], axis=0))


def test_mujoco_applies_the_levels_and_the_applied_check_fails_without_them(tmp_path):
    """tmi's shipped band table with a made-up level table (its arms moved by 2 mm in rotation at a = 0.5): the
    applied check passes (MuJoCo reads the level at the actuator's ctrl) and fails against the a = 1 arms alone."""
    from shoulder_bench.authoring.fem.verify_full import applied_checks, applied_vs_fem
    from shoulder_bench.tendon_law import TendonLaw

    with np.load(table_path("tmi")) as z:
        band = {k: z[k] for k in z.files}
    np.savez(table_path("tmi", tmp_path), **band)
    arms = np.stack([band["moment_arm_m"]] * 3)
    arms[2, ..., 2] += 0.002
    meta = {"tendon": "tmi", "band_table_hash": json.loads(str(band["meta"]))["input_hash"]}
    np.savez(levels_path("tmi", tmp_path), plane_deg=band["plane_deg"], elevation_deg=band["elevation_deg"],
             rotation_deg=band["rotation_deg"], activation=np.array([1.0, 0.75, 0.5]), moment_arm_m=arms,
             meta=np.array(json.dumps(meta)))
    assert all(ok for _, ok, _ in applied_vs_fem(tmp_path, "band", ("tmi",)))
    law = TendonLaw.load("fem", ("tmi",))
    law.lines = BandLines.load(("tmi",), tmp_path)
    assert law.lines.levels.tolist() == [0.5, 0.75, 1.0]
    checks = applied_checks(law, "tmi", full_arm.pose_grid(), band["moment_arm_m"].reshape(-1, 1, 3))
    assert [ok for _, ok, _ in checks] == [True, True, False]  # rotation: the level's 2 mm are missing
