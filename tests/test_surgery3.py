"""The re-learning experiment on the full shoulder (`shoulder-bench surgery --task track_3dof`): the feasibility check
over the 3-DOF test box, and the experiment end to end on a tiny budget (three test trajectories)."""
import json
import re

import numpy as np
import pytest

from shoulder_bench import tasks
from shoulder_bench.cli import main
from shoulder_bench.eval import surgery_checks
from shoulder_bench.tasks import TASKS_3DOF

TINY = {"num_envs": 16, "steps_per_env": 8, "checkpoint_every": 1}  # 128 frames per PPO iteration


def test_the_target_poses_are_the_test_box_or_the_scapular_plane():
    poses, box = surgery_checks.target_poses("track_3dof")
    assert box == [[20.0, 80.0], [20.0, 100.0], [-30.0, 40.0]] and poses.shape == (7 * 9 * 8, 3)
    assert np.allclose(poses.min(0), [20, 20, -30]) and np.allclose(poses.max(0), [80, 100, 40])
    poses, box = surgery_checks.target_poses("elevate_scapular_plane_12m")
    assert poses.shape == (81, 3) and np.allclose(poses[:, 0], 30.0) and np.allclose(poses[:, 2], 0.0)
    assert poses[0, 1] == 20.0 and poses[-1, 1] == 100.0


def test_surgery_on_the_full_shoulder_end_to_end(tmp_path, monkeypatch, capsys):
    full = tasks.fixed_test_set
    monkeypatch.setattr(tasks, "fixed_test_set", lambda name: full(name)[:3])  # tiny inputs
    cfg = tmp_path / "tiny.json"
    cfg.write_text(json.dumps(TINY))
    out = tmp_path / "surgery"
    argv = ["surgery", "--task", "track_3dof", "--condition", "posterosuperior_tear", "--pretrained",
            "--finetune-frames", "128", "--scratch-frames", "128", "--eval-every", "128", "--config", str(cfg),
            "--out", str(out)]
    # the torn cuff cannot hold 27 of the test box's 504 grid poses: an error before any work, naming them
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert re.search(r"cannot hold the arm still at 27 of the 504 poses of the task's test box \(plane 20-80, "
                     r"elevation 20-100, rotation -30-40 deg.*--allow-unreachable", err), err
    assert not out.exists()
    assert main(argv + ["--allow-unreachable"]) == 0
    s = json.loads((out / "summary.json").read_text())
    assert [t["folder"] for t in s["tables"]] == ["muscles_full"]
    r = s["scenarios"][0]
    assert (r["task"], r["algo"], r["removed_muscles"]) == ("track_3dof", "ppo", ["ssp", "isp"])
    f = r["feasibility"]
    assert (f["intact"]["held"], f["post_op"]["held"], f["post_op"]["poses"]) == (504, 477, 504)
    assert all(p[1] <= 40 for p in f["post_op"]["not_held_poses_deg"])  # the torn cuff loses the low poses
    seed = r["seeds"][0]
    assert seed["preop"]["agent"] == "pretrained:ppo_track_3dof" and seed["preop"]["n_trajectories"] == 3
    assert seed["zero_shot"]["mae_deg"] > 2 * seed["preop"]["mae_deg"]  # the tear costs the pre-op agent accuracy
    for kind in ("preop", "zero_shot", "finetune", "scratch"):
        assert set(seed[kind]["coordinate_mae_deg"]) == {"plane", "elevation", "rotation"}
        shares = seed[kind]["shares"]
        assert set(shares["all"]) == set(TASKS_3DOF["track_3dof"][0])
        assert sum(shares["all"].values()) == pytest.approx(1.0)
        assert 0 < shares["early"]["dpo"] < 1  # below 45 deg of elevation
    assert [p["frames"] for p in seed["finetune"]["curve"]] == [0, 128]
    run = json.loads((out / "track_3dof" / "ppo" / "posterosuperior_tear" / "finetune" / "0" / "config.json")
                     .read_text())
    assert run["init_from"]["from"] == "pretrained:ppo_track_3dof"
    assert run["options"] == {"condition": "posterosuperior_tear"}
    section = (out / "leaderboard_section.md").read_text()
    assert "| track_3dof | ppo | posterosuperior_tear | pretrained:ppo_track_3dof |" in section
    assert "477/504 test-box poses held (cannot hold the task range)" in section
    report = (out / "report.md").read_text()
    assert "Each coordinate's MAE" in report and "muscles_full" in report
    for fig in ("tracking", "activations", "recovery"):
        assert (out / "figures" / f"track_3dof_ppo_posterosuperior_tear_{fig}.png").stat().st_size > 10_000


def test_the_provenance_names_a_rerouting_conditions_own_tables():
    folders = [f.name for f in surgery_checks.table_folders("track_3dof", "posterosuperior_tear+ld_transfer")]
    assert folders == ["muscles_full", "muscles_full_ld_transfer"]
    assert [f.name for f in surgery_checks.table_folders("abduction_4m", "ld_transfer")] == [
        "muscles_v2", "muscles_v2_ld_transfer"]
    assert [f.name for f in surgery_checks.table_folders("track_3dof", "ssp_tear")] == ["muscles_full"]
    t = surgery_checks.tables_provenance(surgery_checks.table_folders("track_3dof", "ld_transfer")[1], "fem")
    assert t["files"] == ["ld1_fem.npz", "ld2_fem.npz", "ld3_fem.npz"] and len(t["sha256"]) == 64
