"""A run's identity, budget, lock and resume: killed-and-resumed runs equal their uninterrupted twins, metric for
metric; a resume that would change what defines the run is refused; one writer per folder; nothing half-written."""
import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
import torch

from shoulder_bench.cli import main
from shoulder_bench.eval.experiment import train
from shoulder_bench.eval.plots import scalars
from shoulder_bench.train.run import FolderLock

PPO = {"num_envs": 16, "steps_per_env": 8, "checkpoint_every": 2}  # 128 frames an iteration
DQN = {"num_envs": 8, "learning_starts": 400, "batch_size": 64, "log_every": 400, "checkpoint_every": 800}


def _file(tmp_path, obj, name="cfg.json"):
    p = tmp_path / name
    p.write_text(json.dumps(obj))
    return p


def _cli(task, algo, frames, out, cfg, eval_every, *extra):
    return [sys.executable, "-m", "shoulder_bench.cli", "train", "--task", task, "--algo", algo, "--frames",
            str(frames), "--out", str(out), "--config", str(cfg), "--eval-every", str(eval_every), *extra]


def _kill_after_first_checkpoint(cmd, out, after_s=0.3):
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.time() + 120
    while not (out / "checkpoint.pt").exists() and time.time() < deadline and proc.poll() is None:
        time.sleep(0.02)
    time.sleep(after_s)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    assert (out / "checkpoint.pt").exists() and not (out / "metrics.json").exists(), "killed too late: tune after_s"
    return torch.load(out / "checkpoint.pt", weights_only=False)["frames"]


@pytest.mark.slow
@pytest.mark.parametrize("task,algo,frames,cfg,eval_every", [
    ("abduction_ssp", "ppo", 2048, PPO, 512),
    ("abduction_4m", "ppo", 2048, {**PPO, "overlap_env": True}, 512),  # the rollout collected beside the update
    ("abduction_4m_discrete", "bdq", 4000, DQN, 1600),
    ("track_3dof", "ppo", 768, PPO, 256),  # the 3-DOF batched env's state restored too
])
def test_killed_and_resumed_run_equals_the_uninterrupted_one(tmp_path, task, algo, frames, cfg, eval_every):
    cfg = _file(tmp_path, cfg)
    full, killed = tmp_path / "full", tmp_path / "killed"
    assert subprocess.run(_cli(task, algo, frames, full, cfg, eval_every), capture_output=True).returncode == 0
    at = _kill_after_first_checkpoint(_cli(task, algo, frames, killed, cfg, eval_every), killed)
    assert 0 < at < frames
    assert main(["train", "--task", task, "--algo", algo, "--frames", str(frames), "--out", str(killed), "--config",
                 str(cfg), "--eval-every", str(eval_every), "--resume"]) == 0
    a, b = (json.loads((d / "metrics.json").read_text()) for d in (full, killed))
    assert a["frames"] == b["frames"] == frames
    for key in ("mae_deg", "rmse_deg", "crashes"):
        assert b[key] == pytest.approx(a[key], rel=1e-9, abs=1e-9), key
    for key, values in a["per_trajectory"].items():
        np.testing.assert_allclose(b["per_trajectory"][key], values, rtol=1e-9, atol=1e-9)
    steps_a, mae_a = scalars(full, "test/mae_deg")
    steps_b, mae_b = scalars(killed, "test/mae_deg")
    assert steps_a == steps_b and len(steps_a) >= 2  # no duplicate or missing evaluation points
    np.testing.assert_allclose(mae_b, mae_a, rtol=1e-6)
    assert ({k: r and r["frames"] for k, r in b["to_accuracy"].items()}
            == {k: r and r["frames"] for k, r in a["to_accuracy"].items()})  # wall times differ, frames may not


def test_resume_refuses_a_change_of_what_defines_the_run(tmp_path):
    cfg = _file(tmp_path, PPO)
    out = tmp_path / "run"
    train("abduction_ssp", "ppo", frames=256, out=out, config=cfg, eval_every=10**9)
    (out / "metrics.json").unlink()  # as if killed after its last checkpoint
    recorded = (out / "config.json").read_text()
    cases = [({"seed": 1}, r"seed = 0.*asks for 1"),
             ({"muscle_model": "hill"}, r"muscle_model = 'fem'.*asks for 'hill'"),
             ({"config": _file(tmp_path, {**PPO, "hidden_dims": [8]}, "h.json")}, r"hidden_dims = \[\].*\[8\]"),
             ({"task": "abduction_4m"}, r"task = 'abduction_ssp'"),
             ({"frames": 128}, r"budget of 256 frames.*shrink it to 128")]
    for change, message in cases:
        kw = {"task": "abduction_ssp", "frames": 256, "config": cfg, "out": out, "resume": True} | change
        with pytest.raises(ValueError, match=message):
            train(algo="ppo", eval_every=10**9, **kw)
        assert (out / "config.json").read_text() == recorded
    m = train("abduction_ssp", "ppo", frames=512, out=out, config=cfg, resume=True, eval_every=10**9)
    assert m["frames"] == 512  # the budget may grow


def test_resume_of_a_finished_run_checks_its_identity_too(tmp_path):
    cfg = _file(tmp_path, PPO)
    out = tmp_path / "run"
    first = train("abduction_ssp", "ppo", frames=128, out=out, config=cfg, eval_every=10**9)
    assert train("abduction_ssp", "ppo", frames=128, out=out, config=cfg, resume=True) == first
    with pytest.raises(ValueError, match="seed = 0"):
        train("abduction_ssp", "ppo", frames=128, seed=3, out=out, config=cfg, resume=True)


def test_a_run_recorded_before_a_config_field_existed_is_the_run_with_its_old_value(tmp_path):
    """`run.ADDED_FIELDS`: a PPO run whose config.json predates `update_threads` ran with 1 thread in the update, so it
    resumes as the run asking for 1 and refuses one asking for 2; one that predates `fused_adam` ran rsl-rl's Adam, so
    it refuses today's default (fused) and resumes as the run asking for the old optimiser."""
    import json

    cfg = _file(tmp_path, PPO)
    out = tmp_path / "run"
    first = train("abduction_ssp", "ppo", frames=128, out=out, config=cfg, eval_every=10**9)
    recorded = json.loads((out / "config.json").read_text())
    del recorded["config"]["update_threads"]  # as written before the field existed
    (out / "config.json").write_text(json.dumps(recorded))
    assert train("abduction_ssp", "ppo", frames=128, out=out, config=cfg, resume=True) == first
    with pytest.raises(ValueError, match=r"update_threads = 1; this command asks for 2"):
        train("abduction_ssp", "ppo", frames=128, out=out, resume=True,
              config=_file(tmp_path, {**PPO, "update_threads": 2}, "t2.json"))
    del recorded["config"]["fused_adam"]
    (out / "config.json").write_text(json.dumps(recorded))
    with pytest.raises(ValueError, match=r"fused_adam = False; this command asks for True"):
        train("abduction_ssp", "ppo", frames=128, out=out, config=cfg, resume=True)
    old = _file(tmp_path, {**PPO, "fused_adam": False}, "foreach.json")
    assert train("abduction_ssp", "ppo", frames=128, out=out, config=old, resume=True) == first


def test_a_dqn_run_recorded_before_n_step_is_the_one_step_run():
    from shoulder_bench.train.run import identity_of

    old = {"task": "abduction_4m_discrete", "algo": "bdq", "seed": 0, "config": {"lr": 5e-4, "frames": 500_000}}
    assert identity_of(old) == identity_of({**old, "config": {"lr": 5e-4, "n_step": 1}})
    assert identity_of(old) != identity_of({**old, "config": {"lr": 5e-4, "n_step": 3}})
    assert "n_step" not in identity_of({**old, "algo": "ppo"})["config"]


@pytest.mark.parametrize("kw,message", [
    ({"frames": 0}, r"--frames must be an integer >= 1, got 0"),
    ({"frames": -5}, r"--frames must be an integer >= 1, got -5"),
    ({"eval_every": 0}, r"--eval-every must be an integer >= 1, got 0"),
    ({"seed": -1}, r"--seed must be an integer >= 0"),
    ({"muscle_model": "spring"}, r"unknown muscle model 'spring'"),
    ({"config": {"num_envs": "abc"}}, r"num_envs must be an integer, got 'abc'"),
    ({"config": {"steps_per_env": 0}}, r"steps_per_env = 0 is out of range: it must be >= 1"),
    ({"config": {"learning_rate": -1.0}}, r"learning_rate = -1.0 is out of range: it must be > 0"),
    ({"config": {"hidden_dims": [64, 0]}}, r"hidden_dims .* a list of positive integers"),
    ({"config": {"error_features": "yes"}}, r"error_features must be true or false"),
    ({"config": [1, 2]}, r"expected a JSON object"),
])
def test_bad_budgets_and_config_values_are_clear_errors_before_any_work(tmp_path, kw, message):
    if "config" in kw:
        kw = kw | {"config": _file(tmp_path, kw["config"])}
    out = tmp_path / "run"
    with pytest.raises(ValueError, match=message):
        train("abduction_ssp", "ppo", **{"frames": 128, "out": out} | kw)
    assert not out.exists()


def test_dqn_config_values_and_seed_are_checked(tmp_path):
    with pytest.raises(ValueError, match=r"target_tau = 1.5 is out of range: it must be in \(0, 1\]"):
        train("abduction_ssp_discrete", "dqn", frames=64, out=tmp_path / "a",
              config=_file(tmp_path, {"target_tau": 1.5}))
    with pytest.raises(ValueError, match="set seed with --seed"):
        train("abduction_ssp_discrete", "dqn", frames=64, out=tmp_path / "b", config=_file(tmp_path, {"seed": 4}))


def test_budget_is_rounded_up_to_whole_iterations_and_said(tmp_path, capsys):
    out = tmp_path / "run"
    m = train("abduction_ssp", "ppo", frames=200, out=out, config=_file(tmp_path, PPO), eval_every=10**9)
    assert m["frames"] == 256
    assert "200 frames rounded up to 256 (2 iterations of 128)" in capsys.readouterr().out
    saved = json.loads((out / "config.json").read_text())
    assert (saved["frames"], saved["frames_asked"]) == (256, 200)


def test_the_run_seed_seeds_the_dqn_agent(tmp_path):
    cfg = _file(tmp_path, {**DQN, "learning_starts": 8, "batch_size": 8})
    for seed in (0, 1):
        train("abduction_ssp_discrete", "dqn", frames=16, seed=seed, out=tmp_path / str(seed), config=cfg,
              eval_every=10**9)
    a, b = (json.loads((tmp_path / s / "config.json").read_text())["config"] for s in "01")
    assert (a["seed"], b["seed"]) == (0, 1) and a["frames"] == 16


def test_second_writer_is_refused_naming_the_holder(tmp_path):
    out = tmp_path / "run"
    out.mkdir()
    lock = FolderLock(out)
    try:
        with pytest.raises(ValueError, match=rf"in use by pid {os.getpid()}"):
            train("abduction_ssp", "ppo", frames=128, out=out, config=_file(tmp_path, PPO))
    finally:
        lock.release()
    train("abduction_ssp", "ppo", frames=128, out=out, config=_file(tmp_path, PPO), eval_every=10**9)


def test_a_killed_holder_leaves_no_stale_lock(tmp_path):
    out = tmp_path / "run"
    out.mkdir()
    code = f"from shoulder_bench.train.run import FolderLock; from pathlib import Path; import time; " \
           f"FolderLock(Path({str(out)!r})); print('held', flush=True); time.sleep(60)"
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
    assert proc.stdout.readline().strip() == "held"
    with pytest.raises(ValueError, match=f"in use by pid {proc.pid}"):
        FolderLock(out)
    proc.kill()
    proc.wait()
    FolderLock(out).release()


def test_a_failed_fresh_run_leaves_nothing_behind(tmp_path, monkeypatch):
    from shoulder_bench.train import ppo

    def boom(*args, **kwargs):
        raise RuntimeError("simulated failure")

    monkeypatch.setattr(ppo, "train", boom)
    out = tmp_path / "run"
    with pytest.raises(RuntimeError, match="simulated"):
        train("abduction_ssp", "ppo", frames=128, out=out, config=_file(tmp_path, PPO))
    assert not out.exists()
    existing = tmp_path / "kept"
    existing.mkdir()
    (existing / "notes.txt").write_text("mine")
    with pytest.raises(RuntimeError):
        train("abduction_ssp", "ppo", frames=128, out=existing, config=_file(tmp_path, PPO))
    assert sorted(p.name for p in existing.iterdir()) == [".lock", "notes.txt"]


def test_resume_without_a_checkpoint_starts_clean(tmp_path):
    """Killed before its first checkpoint: --resume starts over and never mixes the lost attempt's events in."""
    from torch.utils.tensorboard import SummaryWriter

    cfg = _file(tmp_path, PPO)
    out = tmp_path / "run"
    train("abduction_ssp", "ppo", frames=128, out=out, config=cfg, eval_every=10**9)
    for name in ("metrics.json", "checkpoint.pt", "policy.pt"):
        (out / name).unlink()
    w = SummaryWriter(str(out / "tb"))  # the lost attempt's events, at steps the new run will log again
    for step in (128, 256):
        w.add_scalar("policy/std", -1e6, step)
    w.close()
    train("abduction_ssp", "ppo", frames=256, out=out, config=cfg, resume=True, eval_every=10**9)
    steps, values = scalars(out, "policy/std")
    assert steps == [128, 256] and min(values) > -1e5


def test_train_with_out_naming_a_file(tmp_path):
    f = tmp_path / "file.txt"
    f.write_text("x")
    with pytest.raises(ValueError, match="is a file"):
        train("abduction_ssp", "ppo", frames=128, out=f)
    assert f.read_text() == "x"


def test_demo_rejects_empty_budgets_before_training(tmp_path, capsys):
    assert main(["demo", "--seconds", "0", "--out", str(tmp_path / "d")]) == 2
    assert "--seconds" in capsys.readouterr().err and not (tmp_path / "d").exists()


def test_train_help_states_the_default_budgets(capsys):
    with pytest.raises(SystemExit):
        main(["train", "--help"])
    assert "default: ppo 1,600,000, dqn 200,000, bdq 500,000" in " ".join(capsys.readouterr().out.split())


def test_a_checkpoint_without_the_algorithm_state_is_a_clear_error(tmp_path, capsys):
    cfg = _file(tmp_path, PPO)
    out = tmp_path / "run"
    train("abduction_ssp", "ppo", frames=128, out=out, config=cfg, eval_every=10**9)
    (out / "metrics.json").unlink()
    ckpt = torch.load(out / "checkpoint.pt", weights_only=False)
    ckpt["state"]["alg"] = {"critic_state_dict": {}}
    torch.save(ckpt, out / "checkpoint.pt")
    assert main(["train", "--task", "abduction_ssp", "--algo", "ppo", "--frames", "256", "--out", str(out),
                 "--config", str(cfg), "--resume"]) == 2
    assert "checkpoint.pt holds no PPO state" in capsys.readouterr().err


def test_task_options_of_a_run_are_its_identity(tmp_path, capsys):
    """`train --option` trains and evaluates with the task option, records it (config.json, policy.pt), refuses a
    resume that changes it, and refuses a bad value before any folder exists."""
    from shoulder_bench.train.policy import load_policy

    cfg = _file(tmp_path, PPO)
    out = tmp_path / "run"
    m = train("abduction_ssp", "ppo", frames=128, out=out, config=cfg, eval_every=10**9,
              options={"delay_frames": 1})
    recorded = json.loads((out / "config.json").read_text())
    assert recorded["options"] == {"delay_frames": 1} and m["frames"] == 128
    assert load_policy(str(out / "policy.pt"))[1]["options"] == {"delay_frames": 1}
    with pytest.raises(ValueError, match="options"):
        train("abduction_ssp", "ppo", frames=128, out=out, config=cfg, resume=True, options={"delay_frames": 2})
    bad = tmp_path / "bad"
    assert main(["train", "--task", "abduction_ssp", "--algo", "ppo", "--frames", "128", "--out", str(bad),
                 "--option", "delay_frames=99"]) == 2
    assert "delay_frames" in capsys.readouterr().err and not bad.exists()
    assert main(["train", "--task", "abduction_ssp", "--algo", "ppo", "--frames", "128", "--out", str(bad),
                 "--option", "muscle_model=hill"]) == 2
    assert not bad.exists()


def test_accuracy_reached_before_a_kill_survives_the_resume(tmp_path, monkeypatch):
    """Thresholds reached before the last checkpoint keep their frames and wall time across a resume (as
    frames_to_paper_accuracy does); the evaluation wall time carries on from the checkpoint's."""
    from shoulder_bench.eval import experiment

    monkeypatch.setattr(experiment, "ACCURACY_DEG", (1000.0, 1e-6))
    cfg = _file(tmp_path, PPO)
    out = tmp_path / "run"
    first = train("abduction_ssp", "ppo", frames=512, out=out, config=cfg, eval_every=128)
    assert first["to_accuracy"]["1000.0"]["frames"] == 128 and first["to_accuracy"]["1e-06"] is None
    (out / "metrics.json").unlink()  # as if killed after its last checkpoint (512 frames)
    ckpt = torch.load(out / "checkpoint.pt", weights_only=False)
    assert ckpt["to_accuracy"]["1000.0"] == first["to_accuracy"]["1000.0"] and ckpt["eval_s"] > 0
    again = train("abduction_ssp", "ppo", frames=768, out=out, config=cfg, resume=True, eval_every=128)
    assert again["to_accuracy"]["1000.0"] == first["to_accuracy"]["1000.0"]  # not re-recorded at 640
    assert again["to_accuracy"]["1e-06"] is None and again["eval_s"] > ckpt["eval_s"]
    steps, _ = scalars(out, "test/wall_s_to_1000deg")
    assert steps == [128]
