"""`shoulder-bench train` and `shoulder-bench eval`."""
from __future__ import annotations

import dataclasses
import json
import time
from pathlib import Path

import numpy as np
import torch

PAPER_PPO4_MAE = 5.15  # deg: "the paper's accuracy" for frames-to-accuracy (PPO-4, their model)
ALGOS = ("ppo", "dqn", "bdq")


def add_parser(sub) -> None:
    p = sub.add_parser("train", help="train an agent; writes runs/<task>/<algo>/<seed>/")
    p.add_argument("--task", required=True)
    p.add_argument("--algo", required=True, choices=ALGOS)
    p.add_argument("--frames", type=int, default=None, help="frame budget (a frame = one 0.1 s step of one copy)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--out", type=Path, default=None)
    p.add_argument("--resume", action="store_true", help="continue the run in --out from its last checkpoint")
    p.add_argument("--config", type=Path, default=None, help="JSON file overriding the algorithm's config fields")
    p.add_argument("--muscle-model", default=None, help="fem or hill (default: the package default)")
    p.add_argument("--eval-every", type=int, default=100_000, help="frames between test-set evaluations")
    p.set_defaults(func=_train)
    p = sub.add_parser("eval", help="evaluate a policy on the test set or a trajectory CSV")
    p.add_argument("--policy", required=True,
                   help="policy.pt, a run folder, pretrained:NAME, or reference (the model-based controller)")
    p.add_argument("--task", default=None, help="default: the task the policy was trained on")
    p.add_argument("--trajectories", default="test", help="test (the fixed 100), combing, or a CSV file")
    p.add_argument("--json", action="store_true", help="one JSON object on the last line")
    p.set_defaults(func=_eval)


def algo_module(algo: str):
    if algo == "ppo":
        from shoulder_bench.train import ppo

        return ppo, ppo.PPOConfig
    from shoulder_bench.train import dqn

    return dqn, dqn.DQNConfig


def load_config(cls, path: Path | None, **defaults):
    cfg = cls(**defaults)
    if path is None:
        return cfg
    try:
        overrides = json.loads(Path(path).read_text())
    except (OSError, json.JSONDecodeError) as exc:
        raise ValueError(f"config file {path}: {exc}") from exc
    names = {f.name for f in dataclasses.fields(cls)}
    unknown = sorted(set(overrides) - names)
    if unknown:
        raise ValueError(f"config file {path}: unknown field(s) {unknown}; valid: {sorted(names)}")
    return dataclasses.replace(cfg, **overrides)


def _dqn_config(task: str, path: Path | None):
    from shoulder_bench.train.dqn import DQNConfig, config_for

    base = config_for(task)
    if path is None:
        return base
    over = load_config(DQNConfig, path)  # validates the field names
    changed = {f.name: getattr(over, f.name) for f in dataclasses.fields(DQNConfig)
               if getattr(over, f.name) != getattr(DQNConfig(), f.name)}
    return dataclasses.replace(base, **changed)


def check_task(task: str, algo: str) -> None:
    from shoulder_bench.tasks import TASKS, _check

    muscles, discrete, _ = TASKS[_check(task)]
    want = {"ppo": "a continuous task", "dqn": "a discrete single-muscle task", "bdq": "a discrete task"}[algo]
    ok = {"ppo": not discrete, "dqn": discrete and len(muscles) == 1, "bdq": discrete}[algo]
    if not ok:
        valid = [n for n, (m, d, _) in TASKS.items() if {"ppo": not d, "dqn": d and len(m) == 1, "bdq": d}[algo]]
        raise ValueError(f"--algo {algo} needs {want}; {task} is not. Valid: {', '.join(valid)}")


DEFAULT_FRAMES = {"ppo": 1_600_000, "dqn": 200_000, "bdq": 500_000}


def finished_metrics(out: Path, task: str, algo: str, frames: int) -> dict | None:
    """metrics.json of a finished run of `algo` on `task` in `out` with at least `frames`, else None."""
    try:
        metrics = json.loads((out / "metrics.json").read_text())
        config = json.loads((out / "config.json").read_text())
    except (OSError, json.JSONDecodeError):
        return None
    same = (config.get("task"), config.get("algo")) == (task, algo)
    return metrics if same and metrics.get("frames", 0) >= frames and (out / "policy.pt").exists() else None


def train(task: str, algo: str, frames: int | None = None, seed: int = 0, out: Path | None = None,
          resume: bool = False, config: Path | None = None, muscle_model: str | None = None,
          eval_every: int = 100_000) -> dict:
    """Train, evaluate on the fixed test set, write the run folder; returns metrics.json's content."""
    import shoulder_bench
    from shoulder_bench.eval.evaluate import evaluate
    from shoulder_bench.model import DEFAULT_MUSCLE_MODEL
    from shoulder_bench.train.policy import save_policy
    from shoulder_bench.train.run import Run
    from shoulder_bench.trajectory import load_test_set

    check_task(task, algo)
    module, cls = algo_module(algo)
    cfg = load_config(cls, config) if algo == "ppo" else _dqn_config(task, config)
    frames = frames or DEFAULT_FRAMES[algo]
    muscle_model = muscle_model or DEFAULT_MUSCLE_MODEL
    out = Path(out or Path("runs") / task / algo / str(seed))
    done = finished_metrics(out, task, algo, frames) if resume else None
    if done is not None:  # nothing to do; opening the run again would start a new TensorBoard file
        return done
    run = Run(out, {"task": task, "algo": algo, "seed": seed, "frames": frames, "muscle_model": muscle_model,
                    "config": dataclasses.asdict(cfg)}, resume)
    # the simulator's rollout threads own the cores while stepping; torch's small matrices gain nothing from more
    # threads and OpenMP threads spinning against them cost 10x (measured: 34 s -> 3 s per PPO iteration)
    torch.set_num_threads(1)
    torch.manual_seed(seed)
    np.random.seed(seed)
    venv = shoulder_bench.make_vec(task, cfg.num_envs, seed=seed * 100_000, muscle_model=muscle_model)
    test = load_test_set()

    def on_eval(policy) -> None:
        m = evaluate(policy, task, test, muscle_model=muscle_model)
        run.writer.add_scalar("test/mae_deg", m["mae_deg"], run.frames)
        run.writer.add_scalar("test/rmse_deg", m["rmse_deg"], run.frames)
        run.writer.add_scalar("test/crashes", m["crashes"], run.frames)
        if run.paper_frames is None and m["mae_deg"] <= PAPER_PPO4_MAE:
            run.paper_frames = run.frames
            run.writer.add_scalar("test/wall_s_to_paper_accuracy", run.elapsed(), run.frames)

    def evaluate_every(now: int) -> int:
        return (now // eval_every + 1) * eval_every

    run.start_progress(frames)
    policy = module.train(run, venv, cfg, frames, evaluate_every, on_eval)
    venv.close()
    final = evaluate(policy, task, test, muscle_model=muscle_model)
    metrics = {k: final[k] for k in ("mae_deg", "rmse_deg", "crashes", "n_trajectories")}
    metrics["per_trajectory"] = final["per_trajectory"]
    save_policy(policy, run.dir / "policy.pt", {"task": task, "algo": algo, "seed": seed, "frames": run.frames,
                                                 "muscle_model": muscle_model,
                                                 "test": {k: metrics[k] for k in ("mae_deg", "rmse_deg", "crashes")}})
    return run.finish(metrics)


def _train(args) -> int:
    m = train(args.task, args.algo, args.frames, args.seed, args.out, args.resume, args.config, args.muscle_model,
              args.eval_every)
    print(f"test set: MAE {m['mae_deg']:.2f} deg, RMSE {m['rmse_deg']:.2f} deg, crashes {m['crashes']}/"
          f"{m['n_trajectories']}; {m['frames']:,} frames in {m['wall_s']:.0f} s")
    return 0


def inference_latency_ms(policy, obs_dim: int, repeats: int = 2000) -> float:
    x = torch.zeros(1, obs_dim)
    with torch.inference_mode():
        for _ in range(50):
            policy(x)
        t = time.perf_counter()
        for _ in range(repeats):
            policy(x)
    return (time.perf_counter() - t) / repeats * 1000


def _eval(args) -> int:
    from shoulder_bench.eval.evaluate import evaluate, policy_for, trajectories_for
    from shoulder_bench.tasks import TASKS

    policy, meta, task = policy_for(args.policy, args.task)
    trajs = trajectories_for(args.trajectories)
    m = evaluate(policy, task, trajs, muscle_model=meta.get("muscle_model"))
    for i, (mae, rmse, crashed) in enumerate(zip(*m["per_trajectory"].values())):
        print(f"trajectory {i:3d}: MAE {mae:6.2f} deg  RMSE {rmse:6.2f} deg{'  CRASHED' if crashed else ''}")
    m["latency_ms"] = inference_latency_ms(policy, 4 + len(TASKS[task][0]))
    print(f"overall on {m['n_trajectories']} trajectories ({args.trajectories}): MAE {m['mae_deg']:.2f} deg, "
          f"RMSE {m['rmse_deg']:.2f} deg, crashes {m['crashes']}; inference {m['latency_ms']:.3f} ms per step "
          f"(batch 1, CPU)")
    if args.json:
        print(json.dumps({k: v for k, v in m.items() if k != "per_trajectory"} | {"task": task,
                                                                                  "policy": args.policy}))
    return 0
