"""`shoulder-bench tasks` and `shoulder-bench demo`."""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np
from tqdm import tqdm


def add_parser(sub) -> None:
    p = sub.add_parser("tasks", help="list the tasks with a one-line description each")
    p.set_defaults(func=_tasks)
    p = sub.add_parser("demo", help="the quick demo: feedback baseline, then train a small PPO agent and evaluate it")
    p.add_argument("--task", default="abduction_4m")
    p.add_argument("--episodes", type=int, default=3, help="test episodes for the feedback baseline")
    p.add_argument("--frames", type=int, default=200_000, help="PPO training frames")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--out", type=Path, default=Path("runs/demo"))
    p.set_defaults(func=_demo)


def _tasks(args) -> int:
    from shoulder_bench.tasks import TASKS

    width = max(map(len, TASKS))
    for name, (_, _, text) in TASKS.items():
        print(f"{name:<{width}}  {text}")
    return 0


def _demo(args) -> int:
    import shoulder_bench
    from shoulder_bench.controllers import Feedback

    env = shoulder_bench.load(args.task, split="test", seed=args.seed)
    controller = Feedback(env.task.muscles)
    print(f"task {args.task}: {args.episodes} test episodes (20 s targets in [20, 100] deg) with a PD feedback "
          f"controller on the change of activation")
    errors, t0 = [], time.perf_counter()
    for ep in tqdm(range(args.episodes), desc="episodes", unit="ep"):
        ts, err = env.reset(), []
        while not ts.last():
            ts = env.step(controller(ts.observation))
            err.append(ts.observation["angle"][0] - env.task.target_deg())
        e = np.array(err)
        errors.append(e)
        tqdm.write(f"  episode {ep}: MAE {np.abs(e).mean():.2f} deg, RMSE {np.sqrt((e ** 2).mean()):.2f} deg, "
                   f"{'crashed' if env.physics.failed() else 'ok'}")
    e = np.concatenate(errors)
    wall = time.perf_counter() - t0
    print(f"feedback baseline: MAE {np.abs(e).mean():.2f} deg, RMSE {np.sqrt((e ** 2).mean()):.2f} deg over {len(e)} "
          f"frames ({len(e) * 0.1 / wall:.0f} simulated s per wall s)")

    from shoulder_bench.cli_train import train

    run_dir = args.out / args.task / "ppo" / str(args.seed)
    print(f"\ntraining PPO on {args.task} for {args.frames:,} frames -> {run_dir}")
    m = train(args.task, "ppo", frames=args.frames, seed=args.seed, out=run_dir, resume=True)
    print(f"PPO on the fixed test set (100 trajectories of 20 s): MAE {m['mae_deg']:.2f} deg, RMSE "
          f"{m['rmse_deg']:.2f} deg, crashes {m['crashes']}; {m['frames']:,} frames in {m['wall_s']:.0f} s")
    print(f"paper (their FEM model, PPO-4): MAE 5.15 deg, RMSE 6.64 deg. Re-evaluate with: shoulder-bench eval "
          f"--policy {run_dir}")
    return 0
