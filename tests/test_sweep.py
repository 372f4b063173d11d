"""`shoulder-bench sweep`: the grid, a tiny sweep on the local pool and on a local Ray instance, resume, failures."""
import json

import pytest

from shoulder_bench.cli import main
from shoulder_bench.sweep import grid, read_configs, sweep

PPO = {"num_envs": 16, "steps_per_env": 8, "checkpoint_every": 1}


def _cfg(tmp_path, name, obj):
    path = tmp_path / name
    path.write_text(json.dumps(obj))
    return path


def test_grid_pairs_fitting_tasks_and_algorithms():
    jobs, skipped = grid(["abduction_4m", "abduction_4m_discrete"], ["ppo", "bdq"], [0, 1], frames=100)
    assert [j.name for j in jobs] == ["abduction_4m/ppo/0", "abduction_4m/ppo/1", "abduction_4m_discrete/bdq/0",
                                      "abduction_4m_discrete/bdq/1"]
    assert skipped == ["abduction_4m x bdq", "abduction_4m_discrete x ppo"]
    assert grid(["abduction_ssp"], ["ppo"], [3])[0][0].frames == 1_600_000  # the algorithm's default budget


def test_bad_grids_and_configs_fail_before_any_run(tmp_path, capsys):
    with pytest.raises(KeyError, match="unknown task"):
        grid(["abduction_9m"], ["ppo"], [0])
    with pytest.raises(ValueError, match="unknown algorithm"):
        grid(["abduction_4m"], ["sac"], [0])
    with pytest.raises(ValueError, match="fits"):
        grid(["abduction_ssp"], ["dqn"], [0])
    with pytest.raises(ValueError, match="distinct"):
        grid(["abduction_ssp"], ["ppo"], [0, 0])
    with pytest.raises(ValueError, match="unknown field"):
        read_configs([f"ppo={_cfg(tmp_path, 'bad.json', {'bogus': 1})}"])
    with pytest.raises(ValueError, match="ALGO=FILE"):
        read_configs(["ppo.json"])
    out = tmp_path / "runs"
    assert main(["sweep", "--tasks", "abduction_ssp", "--algos", "ppo", "--out", str(out), "--config",
                 f"dqn={_cfg(tmp_path, 'd.json', {})}"]) == 2
    assert "not in --algos" in capsys.readouterr().err and not out.exists()


@pytest.mark.slow
def test_local_sweep_resumes_and_reports_a_failed_run(tmp_path, capsys):
    out = tmp_path / "runs"
    ppo = _cfg(tmp_path, "ppo.json", PPO)
    broken = _cfg(tmp_path, "bdq.json", {"num_envs": 0})  # valid fields, fails when the run starts
    args = ["sweep", "--tasks", "abduction_ssp", "abduction_4m_discrete", "--algos", "ppo", "bdq", "--seeds", "0", "1",
            "--frames", "256", "--eval-every", "1000000", "--config", f"ppo={ppo}", "--config", f"bdq={broken}",
            "--out", str(out), "--workers", "2"]
    assert main(args) == 1  # a failed run makes the sweep fail ...
    text = capsys.readouterr().out
    assert "abduction_4m_discrete/bdq/0 failed (exit 2)" in text and "num_envs must be at least 1" in text
    summary = {r["run"]: r for r in json.loads((out / "sweep.json").read_text())}
    assert [summary[f"abduction_ssp/ppo/{s}"]["status"] for s in (0, 1)] == ["done", "done"]  # ... not the others
    assert summary["abduction_4m_discrete/bdq/1"]["status"] == "failed"
    first = json.loads((out / "abduction_ssp/ppo/1/metrics.json").read_text())

    (out / "abduction_ssp/ppo/1/metrics.json").unlink()  # interrupted after its last checkpoint
    jobs, _ = grid(["abduction_ssp"], ["ppo"], [0, 1], frames=256, eval_every=10**6,
                   configs=read_configs([f"ppo={ppo}"]))
    records = sweep(jobs, out, workers=1, progress=False)
    assert [r["status"] for r in records] == ["skipped (finished)", "done"]
    again = json.loads((out / "abduction_ssp/ppo/1/metrics.json").read_text())
    assert again["frames"] == 256 and again["mae_deg"] == pytest.approx(first["mae_deg"])

    from shoulder_bench.eval.leaderboard import collect

    rows = collect(out)
    ppo_row = next(r for r in rows if r["algo"] == "ppo")
    assert ppo_row["seeds"] == 2 and ppo_row["test_mae"][0] == pytest.approx(
        (first["mae_deg"] + json.loads((out / "abduction_ssp/ppo/0/metrics.json").read_text())["mae_deg"]) / 2)


@pytest.mark.slow
def test_sweep_on_a_local_ray_instance(tmp_path):
    pytest.importorskip("ray")
    out = tmp_path / "runs"
    jobs, _ = grid(["abduction_ssp"], ["ppo"], [0, 1], frames=256, eval_every=10**6,
                   configs=read_configs([f"ppo={_cfg(tmp_path, 'ppo.json', PPO)}"]))
    records = sweep(jobs, out, ray_address="local", cpus_per_run=1, progress=False)
    assert [r["status"] for r in records] == ["done", "done"] and all("host" in r for r in records)
    for seed in (0, 1):  # the run folders came back from the workers
        folder = out / f"abduction_ssp/ppo/{seed}"
        assert {"metrics.json", "policy.pt", "checkpoint.pt", "train.log"} <= {p.name for p in folder.iterdir()}
    assert [r["status"] for r in sweep(jobs, out, ray_address="local", progress=False)] == ["skipped (finished)"] * 2
