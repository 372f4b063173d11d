"""How far can a task's muscles follow the fixed test set at all? Static capacity and the activation-rate limit.

For every frame of the 100 test trajectories: can the muscles of the tasks' arm hold it at the target angle within
activation 1 (static capacity against gravity), and does holding it from one frame to the next need an activation
change above the protocol's 1 % per frame? Both are quasi-static estimates (they ignore acceleration), i.e.
optimistic about what a controller can do.

    python benchmarks/feasibility.py [--muscles ssp] [--muscle-model fem|hill]
"""
from __future__ import annotations

import argparse

import numpy as np

from shoulder_bench import statics
from shoulder_bench.arm import arm
from shoulder_bench.authoring.validate import static_reach
from shoulder_bench.model import DEFAULT_MUSCLE_MODEL
from shoulder_bench.trajectory import load_test_set


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--muscles", nargs="+", default=["ssp"])
    p.add_argument("--muscle-model", default=DEFAULT_MUSCLE_MODEL)
    args = p.parse_args()
    law = arm().load_law(args.muscle_model, tuple(args.muscles))  # the tasks' arm (model v2)
    angles = np.arange(0.0, 121.0, 10.0)
    rad = np.radians(angles)
    full = law.torque(rad, np.zeros_like(rad), np.ones((len(rad), len(args.muscles)))).sum(axis=1)
    print(f"muscles {args.muscles}, tables {args.muscle_model}")
    print("angle (deg)            " + " ".join(f"{a:6.0f}" for a in angles))
    print("all at a = 1 (N m)     " + " ".join(f"{t:6.2f}" for t in full))
    print("gravity needs (N m)    " + " ".join(f"{t:6.2f}" for t in -statics.gravity_torque(rad)))
    test = load_test_set()
    hold = np.stack([statics.holding_activation(law, t.angle_deg) for t in test])  # (100, 201, n)
    allang = np.radians(np.concatenate([t.angle_deg for t in test]))
    cap = statics.static_capacity(law, allang)
    unreachable = cap < -statics.gravity_torque(allang)
    rate = np.abs(np.diff(hold, axis=1)).max(axis=2) > 0.01
    print(f"test frames the muscles cannot hold even at activation 1: {unreachable.mean():.1%}")
    print(f"test steps whose holding activation changes faster than 1 %/frame: {rate.mean():.1%}")
    top = static_reach(law, gravity=statics.gravity_torque)  # held at rest at every angle from 0 up to top (0.1 deg)
    target = np.degrees(allang)
    print(f"highest angle held at rest: {top:.1f} deg; quasi-static lower bound on the test MAE (targets above it "
          f"cannot be reached for long): {np.maximum(target - top, 0).mean():.2f} deg")


if __name__ == "__main__":
    main()
