"""The re-learning experiment (issue 13 §3): `shoulder-bench surgery` end to end on a tiny budget, its errors before
any work, and training initialised from a policy (a fine-tune is a run of its own whose identity records it)."""
import json
import re
import shutil

import numpy as np
import pytest
import torch

from shoulder_bench.cli import main
from shoulder_bench.eval import surgery, surgery_checks
from shoulder_bench.train.policy import pretrained_dir

TINY = {"num_envs": 16, "steps_per_env": 8, "checkpoint_every": 1}  # 128 frames per PPO iteration


def _config(tmp_path):
    p = tmp_path / "tiny.json"
    p.write_text(json.dumps(TINY))
    return p


def test_surgery_runs_end_to_end_on_a_tiny_budget(tmp_path, monkeypatch):
    out = tmp_path / "surgery"
    assert main(["surgery", "--task", "abduction_4m", "--condition", "ssp_tear", "--pretrained", "--seeds", "0",
                 "--finetune-frames", "128", "--scratch-frames", "128", "--eval-every", "128", "--config",
                 str(_config(tmp_path)), "--out", str(out)]) == 0
    s = json.loads((out / "summary.json").read_text())
    r = s["scenarios"][0]
    assert (r["task"], r["algo"], r["condition"], r["removed_muscles"]) == ("abduction_4m", "ppo", "ssp_tear", ["ssp"])
    seed = r["seeds"][0]
    assert seed["preop"]["agent"] == "pretrained:ppo_4m"
    assert seed["zero_shot"]["mae_deg"] > seed["preop"]["mae_deg"]  # the tear costs the pre-op agent accuracy
    assert seed["zero_shot"]["accuracy"] == pytest.approx(seed["preop"]["mae_deg"] / seed["zero_shot"]["mae_deg"])
    ft, sc = seed["finetune"], seed["scratch"]
    assert ft["frames"] == 128 and sc["frames"] == 128
    assert [p["frames"] for p in ft["curve"]] == [0, 128]  # the zero-shot point, then each evaluation
    assert ft["curve"][0]["mae_deg"] == seed["zero_shot"]["mae_deg"]
    assert set(ft["recovery"]) >= {"reached", "frames", "training_s", "best_accuracy", "best_at_frames"}
    for kind in ("preop", "zero_shot", "finetune", "scratch"):
        shares = seed[kind]["shares"]["all"]
        assert set(shares) == {"ssp", "isp", "dmi", "ld"} and sum(shares.values()) == pytest.approx(1.0)
    assert set(r["share_shift_finetune_minus_preop"]) == {"ssp", "isp", "dmi", "ld"}
    assert r["feasibility"]["post_op"]["holds_task_range"] and r["feasibility"]["post_op"]["static_reach_deg"] < 20
    assert [t["folder"] for t in s["tables"]] == ["muscles_v2"] and s["tables"][0]["sha256"]
    assert "accuracy = MAE_pre / MAE" in s["definition"]
    # the fine-tune is a run of its own: its identity records the policy it started from
    run = out / "abduction_4m" / "ppo" / "ssp_tear" / "finetune" / "0"
    cfg = json.loads((run / "config.json").read_text())
    assert cfg["init_from"]["from"] == "pretrained:ppo_4m" and cfg["init_from"]["loads"] == "policy"
    assert len(cfg["init_from"]["sha256"]) == 64 and cfg["options"] == {"condition": "ssp_tear"}
    assert "init_from" not in json.loads((out / "abduction_4m" / "ppo" / "ssp_tear" / "scratch" / "0"
                                          / "config.json").read_text())
    metrics = json.loads((run / "metrics.json").read_text())
    assert [e["frames"] for e in metrics["evaluations"]] == [128, 128]  # periodic, then the final one
    section = (out / "leaderboard_section.md").read_text()
    assert section.startswith("## surgery") and "| abduction_4m | ppo | ssp_tear | pretrained:ppo_4m |" in section
    report = (out / "report.md").read_text()
    for fig in ("tracking", "activations", "recovery"):
        path = out / "figures" / f"abduction_4m_ppo_ssp_tear_{fig}.png"
        assert path.stat().st_size > 10_000 and f"figures/{path.name}" in report
    # the leaderboard shows the scenario in its "surgery" section (md and html), next to a run's row
    from test_leaderboard import _still_run

    from shoulder_bench.eval import leaderboard
    few = leaderboard.trajectories_for
    monkeypatch.setattr(leaderboard, "trajectories_for", lambda spec: few(spec)[:2])  # tiny inputs
    _still_run(tmp_path / "runs", 0)
    board = tmp_path / "board"
    assert main(["leaderboard", "--runs", str(tmp_path / "runs"), "--surgery", str(out), "--out", str(board)]) == 0
    assert "\n" + section in (board / "leaderboard.md").read_text()
    page = (board / "leaderboard.html").read_text()
    assert "<h2>Surgery</h2>" in page and "<td>ssp_tear</td>" in page


@pytest.fixture
def no_work(monkeypatch):
    def forbidden(*a, **k):
        raise AssertionError("work started before the inputs were checked")

    for target in ("shoulder_bench.eval.evaluate.evaluate", "shoulder_bench.eval.experiment.train"):
        monkeypatch.setattr(target, forbidden)


def _error(capsys, argv) -> str:
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("shoulder-bench surgery: error: ") and "\n" not in err
    return err


@pytest.mark.parametrize("argv, match", [
    (["--condition", "acl_tear"], r"unknown condition 'acl_tear'.*available: ssp_tear, ssp_partial_tear"),
    (["--condition", "ld_transfr"], r"unknown condition 'ld_transfr'.*available: .*ld_transfer"),
    (["--task", "abduction_ssp", "--condition", "ssp_tear"], r"removes ssp, which the task needs"),
    (["--condition", "posterosuperior_tear+deltoid_weakness"],
     r"cannot hold the arm still at 20-21.1 deg of the task's 20-100 deg test range \(static reach from "
     r"hanging 11\.6 deg.*cannot physically do the task.*--allow-unreachable"),
    (["--condition", "deltoid_weakness", "--option", "weakness_fraction=0.9"],
     r"cannot hold the arm still at [\d.]+-100 deg.*static reach from hanging [\d.]+ deg"),
    (["--condition", "ssp_tear", "--option", "tear_fraction=0.3"], r"tear_fraction applies to none of the conditions"),
    (["--condition", "ssp_tear", "--option", "alpha=2"], r"--option alpha: surgery takes only the conditions' fract"),
    (["--condition", "ssp_tear", "--algo", "bdq"], r"--algo bdq needs a discrete task"),
    (["--condition", "ssp_tear", "--frames", "1000"], r"--frames is the budget of a pre-op agent trained here"),
    (["--condition", "ssp_tear", "--finetune-frames", "0"], r"--finetune-frames must be an integer >= 1"),
    (["--task", "abduction_ssp_discrete", "--condition", "ssp_partial_tear", "--algo", "dqn", "--allow-unreachable",
      "--seeds", "1", "1"], r"--seeds: give one or more distinct seeds"),
])
def test_bad_inputs_are_clear_errors_before_any_work(tmp_path, capsys, no_work, argv, match):
    base = ["surgery", "--task", "abduction_4m", "--pretrained", "--out", str(tmp_path / "out")]
    if "--task" in argv:
        base = base[:1] + base[3:]
    if "--frames" in argv:
        base.remove("--pretrained")
        base += ["--preop-run", str(tmp_path)]
    err = _error(capsys, base + argv)
    assert re.search(match, err), err
    assert not (tmp_path / "out").exists()


def test_a_missing_preop_run_or_a_mismatched_agent_is_an_error(tmp_path, capsys, no_work):
    def err(task, where):
        return _error(capsys, ["surgery", "--task", task, "--condition", "ssp_partial_tear", "--preop-run", str(where),
                               "--out", str(tmp_path / "out")])

    assert "no such folder" in err("abduction_4m", tmp_path / "nowhere")
    assert "is a file; give a finished run folder" in err("abduction_4m", pretrained_dir() / "ppo_4m.pt")
    (tmp_path / "empty").mkdir()
    assert "neither a finished run" in err("abduction_4m", tmp_path / "empty")
    (tmp_path / "run").mkdir()
    shutil.copy(pretrained_dir() / "ppo_4m.pt", tmp_path / "run" / "policy.pt")
    assert "is ppo on abduction_4m, not ppo on abduction_ssp" in err("abduction_ssp", tmp_path / "run")
    assert not (tmp_path / "out").exists()


def test_feasibility_names_what_the_post_op_muscles_cannot_hold():
    intact = surgery_checks.feasibility("abduction_4m", None, "fem")
    tear = surgery_checks.feasibility("abduction_4m", {"condition": "ssp_tear"}, "fem")
    assert intact["holds_task_range"] and intact["not_held_deg"] == []
    assert tear["holds_task_range"] and tear["static_reach_deg"] == pytest.approx(11.6)
    assert tear["not_held_deg"][0][0] == pytest.approx(11.7) and tear["not_held_deg"][0][1] < 20
    assert "below the range" in surgery_checks.feasibility_text(tear)


def test_recovery_is_the_first_evaluation_at_90_percent_of_the_pre_op_accuracy():
    points = surgery.curve([{"frames": 10, "mae_deg": 2.0}, {"frames": 20, "mae_deg": 1.05},
                            {"frames": 30, "mae_deg": 1.2}, {"frames": 30, "mae_deg": 1.2}], preop_mae=1.0,
                           start={"frames": 0, "mae_deg": 8.0})
    assert [p["frames"] for p in points] == [0, 10, 20, 30]
    rec = surgery.recovery(points)
    assert rec["reached"] and rec["frames"] == 20 and rec["best_accuracy"] == pytest.approx(1 / 1.05)
    miss = surgery.recovery(points[:2])
    assert not miss["reached"] and miss["frames"] is None and miss["best_at_frames"] == 10


def test_a_fine_tune_starts_from_the_initial_policy(tmp_path):
    """The PPO actor loaded from an exported policy acts as that policy; a run folder with its checkpoint gives the
    whole PPO state; a resume that changes the initial state is refused, naming init_from."""
    import contextlib
    import io

    from rsl_rl.runners import OnPolicyRunner

    import shoulder_bench
    from shoulder_bench.eval.experiment import train
    from shoulder_bench.train import ppo
    from shoulder_bench.train.plan import init_source
    from shoulder_bench.train.policy import load_policy

    record, init = init_source("pretrained:ppo_4m", "abduction_4m", "ppo", "fem")
    assert record["loads"] == "policy" and record["frames"] == 804_864 and "checkpoint" not in init
    venv = shoulder_bench.make_vec("abduction_4m", 4, seed=0)
    cfg = ppo.PPOConfig(num_envs=4)
    with contextlib.redirect_stdout(io.StringIO()):
        alg = OnPolicyRunner(ppo.ScaledActions(venv), ppo.rsl_config(cfg, 4), log_dir=None, device="cpu").alg
    venv.close()
    ppo.load_init(alg, init)
    shipped, _ = load_policy("pretrained:ppo_4m")
    obs = torch.tensor(np.random.default_rng(0).uniform([0, -20, 0, -20, 0, 0, 0, 0], [100, 20, 100, 20, 1, 1, 1, 1],
                                                        (64, 8)), dtype=torch.float32)
    with torch.no_grad():
        torch.testing.assert_close(ppo.export(alg)(obs), shipped(obs))
    with pytest.raises(ValueError, match=r"a policy of task 'abduction_4m'.*needs one of task 'abduction_ssp'"):
        init_source("pretrained:ppo_4m", "abduction_ssp", "ppo", "fem")

    src, ft = tmp_path / "src", tmp_path / "ft"
    cfg_file = _config(tmp_path)
    train("abduction_ssp", "ppo", frames=128, out=src, config=cfg_file, eval_every=10**9)
    record, init = init_source(str(src), "abduction_ssp", "ppo", "fem")
    assert record["loads"] == "checkpoint" and "checkpoint" in init and record["frames"] == 128
    m = train("abduction_ssp", "ppo", frames=128, out=ft, config=cfg_file, eval_every=10**9, init_from=str(src),
              options={"condition": "ssp_partial_tear"})
    assert m["frames"] == 128  # a fine-tune's frames count from 0
    assert load_policy(str(ft))[1]["init_from"]["checkpoint_sha256"] == record["checkpoint_sha256"]
    (ft / "metrics.json").unlink()  # as if killed after its last checkpoint
    with pytest.raises(ValueError, match=r"is a run with init_from = "):
        train("abduction_ssp", "ppo", frames=256, out=ft, config=cfg_file, eval_every=10**9, resume=True,
              options={"condition": "ssp_partial_tear"})
