"""Sensitivity of the tasks to the elevation joint's damping (the model-v2 issue: "a sourced value, or the smallest that
keeps the protocol stable, with a sensitivity run (0.1 / 0.5 / 1.0) of the reference controller and the shipped
PPO-4").

The v2 arm has no joint damping (none is needed for stability at the 50 ms RK4 step, docs/model_v2.md "Dynamics").
This evaluates the reference controller (told the damping: it is model-based) and the shipped PPO-4 (trained without
damping) on the fixed test set with the task option `joint_damping` at 0, 0.1, 0.5 and 1.0 N m s/rad.

    python benchmarks/damping.py [--dampings 0 0.1 0.5 1.0] [--policy pretrained:ppo_4m] [--trajectories N]
"""
from __future__ import annotations

import argparse

from shoulder_bench.eval.evaluate import evaluate, policy_for
from shoulder_bench.eval.reference import ReferenceController
from shoulder_bench.trajectory import load_test_set


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--dampings", type=float, nargs="+", default=[0.0, 0.1, 0.5, 1.0])
    p.add_argument("--policy", default="pretrained:ppo_4m")
    p.add_argument("--trajectories", type=int, default=100, help="the first N of the 100 test targets")
    args = p.parse_args()
    test = load_test_set()[:args.trajectories]
    agent, meta, task = policy_for(args.policy)
    print(f"task {task}, {len(test)} test trajectories; test MAE / RMSE (deg), crashes")
    print(f"{'joint damping (N m s/rad)':>26} {'reference controller':>24} {args.policy:>24}")
    for b in args.dampings:
        opts = {"joint_damping": b}
        ref = evaluate(ReferenceController(task, joint_damping=b), task, test, options=opts)
        pol = evaluate(agent, task, test, muscle_model=meta.get("muscle_model"), options=opts)
        cells = [f"{r['mae_deg']:.2f} / {r['rmse_deg']:.2f}, {r['crashes']}" for r in (ref, pol)]
        print(f"{b:>26g} {cells[0]:>24} {cells[1]:>24}")


if __name__ == "__main__":
    main()
