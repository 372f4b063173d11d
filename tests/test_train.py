"""Training on tiny budgets: runs write their folder, resume after a kill, reject bad checkpoints; eval works."""
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
from shoulder_bench.train.policy import load_policy

TINY = {"num_envs": 16, "steps_per_env": 8, "checkpoint_every": 1}


def _config(tmp_path, **extra):
    p = tmp_path / "cfg.json"
    p.write_text(json.dumps({**TINY, **extra}))
    return p


def test_ppo_tiny_run_writes_its_folder(tmp_path):
    out = tmp_path / "run"
    m = train("abduction_4m", "ppo", frames=512, out=out, config=_config(tmp_path), eval_every=256)
    for name in ("config.json", "checkpoint.pt", "policy.pt", "metrics.json"):
        assert (out / name).exists(), name
    assert any((out / "tb").iterdir())
    saved = json.loads((out / "metrics.json").read_text())
    assert saved["frames"] == 512 and np.isfinite(saved["mae_deg"]) and np.isfinite(saved["rmse_deg"])
    assert saved["n_trajectories"] == 100 and m["crashes"] == saved["crashes"]
    assert main(["plot", "curves", str(out), "--out", str(tmp_path / "curves.png")]) == 0
    assert (tmp_path / "curves.png").stat().st_size > 10_000
    policy, meta = load_policy(str(out))
    a = policy(torch.zeros(3, 8))
    assert a.shape == (3, 4) and float(a.detach().abs().max()) <= 0.01 and meta["task"] == "abduction_4m"


def test_existing_run_is_not_overwritten(tmp_path):
    out = tmp_path / "run"
    train("abduction_ssp", "ppo", frames=128, out=out, config=_config(tmp_path), eval_every=10**9)
    with pytest.raises(ValueError, match="finished run"):
        train("abduction_ssp", "ppo", frames=128, out=out, config=_config(tmp_path))


def test_kill_and_resume_ends_with_the_same_frames(tmp_path):
    cfg = _config(tmp_path)
    full = tmp_path / "full"
    train("abduction_ssp", "ppo", frames=2048, out=full, config=cfg, eval_every=10**9)
    killed = tmp_path / "killed"
    cmd = [sys.executable, "-m", "shoulder_bench.cli", "train", "--task", "abduction_ssp", "--algo", "ppo",
           "--frames", "2048", "--out", str(killed), "--config", str(cfg), "--eval-every", "1000000000"]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.time() + 120
    while not (killed / "checkpoint.pt").exists() and time.time() < deadline:
        time.sleep(0.05)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    before = torch.load(killed / "checkpoint.pt", weights_only=False)["frames"]
    assert 0 < before <= 2048 and not (killed / "metrics.json").exists()
    assert main(["train", "--task", "abduction_ssp", "--algo", "ppo", "--frames", "2048", "--out", str(killed),
                 "--config", str(cfg), "--resume", "--eval-every", "1000000000"]) == 0
    a, b = json.loads((full / "metrics.json").read_text()), json.loads((killed / "metrics.json").read_text())
    assert a["frames"] == b["frames"] == 2048


def test_corrupt_or_mismatched_checkpoint_names_the_file(tmp_path, capsys):
    out = tmp_path / "run"
    out.mkdir()
    (out / "checkpoint.pt").write_bytes(b"garbage")
    with pytest.raises(ValueError, match=r"checkpoint.pt.*corrupt"):
        train("abduction_ssp", "ppo", frames=128, out=out, config=_config(tmp_path), resume=True)
    other = tmp_path / "other"
    train("abduction_ssp", "ppo", frames=128, out=other, config=_config(tmp_path), eval_every=10**9)
    (other / "metrics.json").unlink()
    with pytest.raises(ValueError, match=r"other is a run with task = 'abduction_ssp'.*'abduction_4m'"):
        train("abduction_4m", "ppo", frames=256, out=other, config=_config(tmp_path), resume=True)
    bad_policy = tmp_path / "p.pt"
    bad_policy.write_bytes(b"nope")
    assert main(["eval", "--policy", str(bad_policy)]) == 2
    assert "p.pt" in capsys.readouterr().err


def test_wrong_algo_for_task_and_unknown_config_field(tmp_path):
    with pytest.raises(ValueError, match="abduction_4m"):
        train("abduction_ssp_discrete", "ppo", frames=10)
    with pytest.raises(ValueError, match="unknown field"):
        train("abduction_ssp", "ppo", frames=10, out=tmp_path / "x", config=_config(tmp_path, lr=1))


def test_eval_command_json(tmp_path, capsys):
    out = tmp_path / "run"
    train("abduction_ssp", "ppo", frames=128, out=out, config=_config(tmp_path), eval_every=10**9)
    csv = tmp_path / "t.csv"
    csv.write_text("time_s,angle_deg\n0,40\n2,60\n")
    assert main(["eval", "--policy", str(out / "policy.pt"), "--trajectories", str(csv), "--json"]) == 0
    last = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert last["n_trajectories"] == 1 and {"mae_deg", "rmse_deg", "crashes", "latency_ms"} <= set(last)


@pytest.mark.parametrize("task,algo", [("abduction_ssp_discrete", "dqn"), ("abduction_4m_discrete", "bdq")])
def test_value_based_tiny_run_and_resume(tmp_path, task, algo):
    cfg = tmp_path / "dqn.json"
    cfg.write_text(json.dumps({"num_envs": 8, "learning_starts": 400, "batch_size": 64, "log_every": 400,
                               "checkpoint_every": 800}))
    out = tmp_path / "run"
    m = train(task, algo, frames=1600, out=out, config=cfg, eval_every=800)
    assert m["frames"] == 1600 and np.isfinite(m["mae_deg"])
    policy, meta = load_policy(str(out))
    levels = policy(torch.zeros(2, 4 + (4 if "4m" in task else 1)))
    assert levels.dtype == torch.int64 and int(levels.min()) >= 0 and int(levels.max()) <= 20
    (out / "metrics.json").unlink()  # as if killed after the last checkpoint: resume to a larger budget
    m2 = train(task, algo, frames=2400, out=out, config=cfg, resume=True, eval_every=10**9)
    assert m2["frames"] == 2400


def test_ppo_error_features_and_reward_scale_export_a_policy_on_raw_observations(tmp_path):
    out = tmp_path / "run"
    train("abduction_ssp", "ppo", frames=256, out=out, config=_config(tmp_path, error_features=True, reward_scale=0.1),
          eval_every=10**9)
    policy, _ = load_policy(str(out))
    assert policy(torch.zeros(2, 5)).shape == (2, 1)  # the task's 5 observations; the features are inside


def test_a_smaller_value_network_trains_and_the_policy_keeps_the_papers(tmp_path):
    out = tmp_path / "run"
    train("abduction_4m", "ppo", frames=256, out=out, config=_config(tmp_path, critic_hidden_dims=[32]),
          eval_every=10**9)
    state = torch.load(out / "checkpoint.pt", weights_only=False)["state"]["alg"]
    shapes = {part: [tuple(v.shape) for k, v in state[f"{part}_state_dict"].items() if k.endswith("weight")]
              for part in ("actor", "critic")}
    assert shapes == {"actor": [(250, 8), (250, 250), (250, 250), (4, 250)], "critic": [(32, 8), (1, 32)]}, shapes


def test_wall_time_to_accuracy_is_recorded_logged_and_printed(tmp_path, monkeypatch, capsys):
    """The first evaluation at or below each threshold gives frames and training wall time (evaluations excluded);
    a threshold never reached is null. 1000 deg is reached at the first evaluation, 1e-6 deg never, and 512 frames
    are far from 2 deg."""
    from shoulder_bench.eval import experiment
    from shoulder_bench.eval.plots import scalars

    monkeypatch.setattr(experiment, "ACCURACY_DEG", (1000.0, 2.0, 1e-6))
    out = tmp_path / "run"
    assert main(["train", "--task", "abduction_4m", "--algo", "ppo", "--frames", "512", "--out", str(out),
                 "--config", str(_config(tmp_path)), "--eval-every", "256"]) == 0
    m = json.loads((out / "metrics.json").read_text())
    reached = m["to_accuracy"]["1000.0"]
    assert reached["frames"] == 256 and m["to_accuracy"]["2.0"] is None and m["to_accuracy"]["1e-06"] is None
    assert 0 < m["eval_s"] < m["wall_s"] and 0 < reached["wall_s"] <= m["wall_s"] - m["eval_s"]
    assert scalars(out, "test/wall_s_to_1000deg") == ([256], [pytest.approx(reached["wall_s"], abs=1e-3)])
    assert scalars(out, "test/frames_to_1000deg")[1] == [256]
    assert scalars(out, "test/wall_s_to_2deg")[0] == []
    printed = capsys.readouterr().out.splitlines()[-1]
    assert "evaluations excluded" in printed and f"1000 deg {reached['wall_s']:.1f} s (256 frames)" in printed
    assert "2 deg not reached" in printed and "1e-06 deg not reached" in printed


def test_fused_adam_takes_the_same_steps_as_rsl_rls_adam_and_is_what_training_uses(tmp_path, monkeypatch):
    """`ppo.fuse_optimizer` swaps rsl-rl's Adam for torch's fused one over the same parameters and learning rate: the
    same updates up to rounding; `train` installs it by default (`fused_adam`) and not with `fused_adam: false`."""
    from types import SimpleNamespace

    from shoulder_bench.train import ppo

    torch.manual_seed(0)
    nets = [torch.nn.Sequential(torch.nn.Linear(5, 32), torch.nn.ReLU(), torch.nn.Linear(32, 2)) for _ in range(2)]
    nets[1].load_state_dict(nets[0].state_dict())
    algs = [SimpleNamespace(optimizer=torch.optim.Adam(net.parameters(), lr=3e-3)) for net in nets]
    ppo.fuse_optimizer(algs[1])
    assert algs[1].optimizer.defaults["fused"] and not algs[0].optimizer.defaults["fused"]
    assert algs[1].optimizer.param_groups[0]["lr"] == 3e-3
    x = torch.randn(64, 5)
    start = nets[0][0].weight.detach().clone()
    for _ in range(50):
        for net, alg in zip(nets, algs):
            alg.optimizer.zero_grad()
            net(x).pow(2).sum().backward()
            alg.optimizer.step()
    assert (nets[0][0].weight - start).abs().max() > 1e-2  # the steps did move the weights
    assert (nets[0][0].weight - nets[1][0].weight).abs().max() < 1e-5
    seen = []
    monkeypatch.setattr(ppo, "fuse_optimizer", lambda alg: seen.append(alg))
    train("abduction_ssp", "ppo", frames=128, out=tmp_path / "fused", config=_config(tmp_path), eval_every=10**9)
    assert len(seen) == 1
    train("abduction_ssp", "ppo", frames=128, out=tmp_path / "foreach", config=_config(tmp_path, fused_adam=False),
          eval_every=10**9)
    assert len(seen) == 1


def test_anneal_kl_lowers_the_kl_target_linearly_over_the_budget(tmp_path, monkeypatch):
    """anneal_kl: each update's KL target is desired_kl x (1 - frames so far / budget); without it, fixed."""
    from rsl_rl.algorithms import PPO

    seen, update = [], PPO.update

    def spy(self):
        seen.append(self.desired_kl)
        return update(self)
    monkeypatch.setattr(PPO, "update", spy)
    train("abduction_ssp", "ppo", frames=512, out=tmp_path / "a", config=_config(tmp_path, anneal_kl=True,
                                                                                    desired_kl=0.02),
          eval_every=10**9)
    np.testing.assert_allclose(seen, [0.02, 0.015, 0.01, 0.005])
    seen.clear()
    train("abduction_ssp", "ppo", frames=256, out=tmp_path / "b", config=_config(tmp_path), eval_every=10**9)
    assert seen == [0.01, 0.01]


@pytest.mark.parametrize("overlap,lag", [(False, 0), (True, 1)])
def test_each_update_learns_from_the_policy_that_collected_its_rollout(tmp_path, monkeypatch, overlap, lag):
    """The rollout an update learns from was acted by the policy as it was before that update (overlap_env off), or
    before the update before it (on: the next rollout is collected during the update); checked by re-running those
    saved policies on the stored observations: their means are the stored ones."""
    import copy

    from rsl_rl.algorithms import PPO

    seen, update, actor = [], PPO.update, []

    def spy(self):
        if not actor:  # a module to run the saved parameters (copied before any update's forward)
            actor.append(copy.deepcopy(self.actor))
        seen.append(({k: v.clone() for k, v in self.actor.state_dict().items()}, self.storage.observations.clone(),
                     self.storage.distribution_params[0].clone()))
        return update(self)
    monkeypatch.setattr(PPO, "update", spy)
    train("abduction_4m", "ppo", frames=640, out=tmp_path / "run", config=_config(tmp_path, overlap_env=overlap),
          eval_every=10**9)
    assert len(seen) == 5

    def means(k, obs):
        actor[0].load_state_dict(seen[k][0])
        with torch.inference_mode():
            return actor[0](obs).numpy()
    for k in range(len(seen)):
        obs, stored = seen[k][1], seen[k][2].numpy()
        np.testing.assert_allclose(means(max(k - lag, 0), obs), stored, rtol=1e-5, atol=1e-6)  # the first rollout
        # is collected before any update either way
        if k >= 2 and lag:  # and not by the policy of its own update
            assert not np.allclose(means(k, obs), stored, atol=1e-6)


def test_collecting_beside_the_update_is_deterministic_and_resumes_exactly(tmp_path):
    """overlap_env: runs repeat, and a run stopped at a checkpoint and resumed to a larger budget (the checkpoint
    carries the rollout collected but not yet learned from) ends where the uninterrupted one does."""
    cfg = _config(tmp_path, overlap_env=True)
    ends = []
    for name in ("a", "b"):
        ends.append(train("abduction_4m", "ppo", frames=768, out=tmp_path / name, config=cfg, eval_every=10**9))
    out = tmp_path / "c"
    train("abduction_4m", "ppo", frames=384, out=out, config=cfg, eval_every=10**9)
    (out / "metrics.json").unlink()  # as if killed after the last checkpoint
    ends.append(train("abduction_4m", "ppo", frames=768, out=out, config=cfg, resume=True, eval_every=10**9))
    plain = train("abduction_4m", "ppo", frames=768, out=tmp_path / "plain", config=_config(tmp_path),
                  eval_every=10**9)
    x = torch.randn(5, 8, generator=torch.Generator().manual_seed(1))
    actions = [load_policy(str(tmp_path / name))[0](x) for name in ("a", "b", "c", "plain")]
    for end, act in zip(ends[1:], actions[1:3]):
        assert end["mae_deg"] == pytest.approx(ends[0]["mae_deg"], rel=1e-9)
        torch.testing.assert_close(act, actions[0], rtol=1e-6, atol=1e-9)
    assert not torch.allclose(actions[3], actions[0])
    assert plain["frames"] == ends[0]["frames"] == 768
