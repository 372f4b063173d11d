"""`shoulder-bench tasks` and `shoulder-bench demo`."""
from __future__ import annotations

import time

import numpy as np
from tqdm import tqdm


def add_parser(sub) -> None:
    p = sub.add_parser("tasks", help="list the tasks with a one-line description each")
    p.set_defaults(func=_tasks)
    p = sub.add_parser("demo", help="the quick demo: run test episodes with a feedback controller")
    p.add_argument("--task", default="abduction_4m")
    p.add_argument("--episodes", type=int, default=3)
    p.add_argument("--seed", type=int, default=0)
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
    print(f"overall: MAE {np.abs(e).mean():.2f} deg, RMSE {np.sqrt((e ** 2).mean()):.2f} deg over {len(e)} frames "
          f"({len(e) * 0.1 / wall:.0f} simulated s per wall s)")
    return 0
