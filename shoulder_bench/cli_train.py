"""`shoulder-bench train` and `shoulder-bench eval`."""
from __future__ import annotations

import dataclasses
import json
import sys
import time
from pathlib import Path

import numpy as np
import torch

PAPER_PPO4_MAE = 5.15  # deg: "the paper's accuracy" for frames-to-accuracy (PPO-4, their model)
ALGOS = ("ppo", "dqn", "bdq")
DEFAULT_FRAMES = {"ppo": 1_600_000, "dqn": 200_000, "bdq": 500_000}


def add_parser(sub) -> None:
    p = sub.add_parser("train", help="train an agent; writes runs/<task>/<algo>/<seed>/")
    p.add_argument("--task", required=True)
    p.add_argument("--algo", required=True, choices=ALGOS)
    defaults = ", ".join(f"{a} {n:,}" for a, n in DEFAULT_FRAMES.items())
    p.add_argument("--frames", type=int, default=None,
                   help=f"frame budget (a frame = one 0.1 s step of one copy), rounded up to whole iterations; "
                        f"default: {defaults}")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--out", type=Path, default=None, help="run folder (default: runs/<task>/<algo>/<seed>)")
    p.add_argument("--resume", action="store_true",
                   help="continue the run in --out from its last checkpoint (same task, algo, seed, muscle model "
                        "and config; only --frames may grow)")
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


def check_task(task: str, algo: str) -> None:
    from shoulder_bench.tasks import TASKS, check_name

    muscles, discrete, _ = TASKS[check_name(task)]
    want = {"ppo": "a continuous task", "dqn": "a discrete single-muscle task", "bdq": "a discrete task"}[algo]
    ok = {"ppo": not discrete, "dqn": discrete and len(muscles) == 1, "bdq": discrete}[algo]
    if not ok:
        valid = [n for n, (m, d, _) in TASKS.items() if {"ppo": not d, "dqn": d and len(m) == 1, "bdq": d}[algo]]
        raise ValueError(f"--algo {algo} needs {want}; {task} is not. Valid: {', '.join(valid)}")


def _count(name: str, value, low: int = 1) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
        raise ValueError(f"{name} must be an integer >= {low}, got {value!r}")
    return int(value)


def plan(task: str, algo: str, frames: int | None = None, seed: int = 0, overrides: dict | None = None,
         muscle_model: str | None = None, source: str = "config"):
    """Check everything that defines a run, before any work: (algorithm module, its config, the run's config.json).

    The budget is rounded up to whole iterations (PPO: num_envs x steps_per_env frames; DQN/BDQ: num_envs)."""
    from shoulder_bench.arm import MODEL_VERSION
    from shoulder_bench.model import DEFAULT_MUSCLE_MODEL
    from shoulder_bench.muscle import MUSCLE_MODELS
    from shoulder_bench.train.config import build

    if algo not in ALGOS:
        raise ValueError(f"unknown algorithm {algo!r}; choose from {', '.join(ALGOS)}")
    check_task(task, algo)
    asked = _count("--frames", DEFAULT_FRAMES[algo] if frames is None else frames)
    seed = _count("--seed", seed, low=0)
    muscle_model = muscle_model or DEFAULT_MUSCLE_MODEL
    if muscle_model not in MUSCLE_MODELS:
        raise ValueError(f"unknown muscle model {muscle_model!r}; choose one of {', '.join(MUSCLE_MODELS)}")
    module, cls = algo_module(algo)
    overrides = dict(overrides or {})
    if algo == "ppo":
        cfg = build(cls, module.LIMITS, overrides=overrides, source=source)
    else:
        for key in ("seed", "frames"):
            if key in overrides:
                raise ValueError(f"{source}: set {key} with --{key}, not in the config")
        cfg = build(cls, module.LIMITS, base=module.config_for(task), overrides=overrides, source=source)
    per = module.frames_per_iteration(cfg)
    budget = -(-asked // per) * per
    if algo != "ppo":
        cfg = dataclasses.replace(cfg, seed=seed, frames=budget)
    config = {"task": task, "algo": algo, "seed": seed, "frames": budget, "frames_asked": asked,
              "frames_per_iteration": per, "muscle_model": muscle_model, "options": {},
              "model_version": MODEL_VERSION, "config": dataclasses.asdict(cfg)}
    return module, cfg, config


def finished_metrics(out: Path, config: dict) -> dict | None:
    """metrics.json of the finished run in `out` if it is the run `config` defines, with at least its frames."""
    from shoulder_bench.train.run import check_same_run, identity_of

    try:
        metrics = json.loads((Path(out) / "metrics.json").read_text())
        recorded = json.loads((Path(out) / "config.json").read_text())
    except (OSError, json.JSONDecodeError):
        return None
    if not (Path(out) / "policy.pt").exists() or metrics.get("frames", 0) < config["frames"]:
        return None
    if identity_of(recorded) != identity_of(config):
        check_same_run(recorded, config, Path(out))  # names the field
    return metrics


def train(task: str, algo: str, frames: int | None = None, seed: int = 0, out: Path | None = None,
          resume: bool = False, config: Path | None = None, muscle_model: str | None = None,
          eval_every: int = 100_000) -> dict:
    """Train, evaluate on the fixed test set, write the run folder; returns metrics.json's content."""
    import shoulder_bench
    from shoulder_bench.eval.evaluate import evaluate
    from shoulder_bench.train.config import read_overrides
    from shoulder_bench.train.policy import save_policy
    from shoulder_bench.train.run import Run
    from shoulder_bench.trajectory import load_test_set

    _, cls = algo_module(algo) if algo in ALGOS else (None, None)
    overrides = read_overrides(config, cls) if cls is not None else {}
    module, cfg, run_config = plan(task, algo, frames, seed, overrides, muscle_model,
                                   source=f"config file {config}" if config else "config")
    eval_every = _count("--eval-every", eval_every)
    seed, frames, muscle_model = run_config["seed"], run_config["frames"], run_config["muscle_model"]
    if frames != run_config["frames_asked"]:
        print(f"budget: {run_config['frames_asked']:,} frames rounded up to {frames:,} "
              f"({frames // run_config['frames_per_iteration']} iterations of {run_config['frames_per_iteration']:,})")
    out = Path(out or Path("runs") / task / algo / str(seed))
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {out} is a file; give a folder for the run")
    done = finished_metrics(out, run_config) if resume else None
    if done is not None:  # nothing to do; opening the run again would start a new TensorBoard file
        return done
    # the simulator's rollout threads own the cores while stepping; torch's small matrices gain nothing from more
    # threads and OpenMP threads spinning against them cost 10x (measured: 34 s -> 3 s per PPO iteration)
    torch.set_num_threads(1)
    torch.manual_seed(seed)
    np.random.seed(seed)
    with Run(out, run_config, resume) as run:
        venv = shoulder_bench.make_vec(task, cfg.num_envs, seed=seed * 100_000, muscle_model=muscle_model)
        run.env = venv
        if run.checkpoint is not None and "env" in run.checkpoint["state"]:
            venv.load_state_dict(run.checkpoint["state"]["env"])
        elif run.checkpoint is not None:
            print(f"warning: {run.dir / 'checkpoint.pt'} predates exact resume (no env state): the episodes restart")
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
        try:
            policy = module.train(run, venv, cfg, frames, evaluate_every, on_eval)
        finally:
            venv.close()
        final = evaluate(policy, task, test, muscle_model=muscle_model)
        metrics = {k: final[k] for k in ("mae_deg", "rmse_deg", "crashes", "n_trajectories")}
        metrics["per_trajectory"] = final["per_trajectory"]
        save_policy(policy, run.dir / "policy.pt",
                    {"task": task, "algo": algo, "seed": seed, "frames": run.frames, "muscle_model": muscle_model,
                     "options": run_config["options"], "model_version": run_config["model_version"],
                     "test": {k: metrics[k] for k in ("mae_deg", "rmse_deg", "crashes")}})
        return run.finish(metrics)


def _train(args) -> int:
    try:
        m = train(args.task, args.algo, args.frames, args.seed, args.out, args.resume, args.config,
                  args.muscle_model, args.eval_every)
    except KeyboardInterrupt:
        out = args.out or Path("runs") / args.task / args.algo / str(args.seed)
        kept = (Path(out) / "checkpoint.pt").exists()
        print("\ntrain: interrupted; " + (f"continue from the last checkpoint with the same command and --resume "
                                            f"(run folder {out})" if kept else "no checkpoint yet, nothing kept"),
              file=sys.stderr)
        return 130
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

    trajs = trajectories_for(args.trajectories)  # a bad file fails before the policy loads
    policy, meta, task = policy_for(args.policy, args.task)
    m = evaluate(policy, task, trajs, muscle_model=meta.get("muscle_model"), options=meta.get("options"))
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
