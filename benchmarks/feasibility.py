"""How far can a task's muscles follow the fixed test set at all? Static capacity and the activation-rate limit.

For every frame of the 100 test trajectories: can the muscles hold the arm at the target angle within activation 1
(static capacity against gravity), and does holding it from one frame to the next need an activation change above the
protocol's 1 % per frame? Both are quasi-static estimates (they ignore acceleration), i.e. optimistic about what a
controller can do.

    python benchmarks/feasibility.py [--muscles ssp] [--muscle-model fem|hill]
"""
from __future__ import annotations

import argparse

import numpy as np

from shoulder_bench import statics
from shoulder_bench.model import DEFAULT_MUSCLE_MODEL
from shoulder_bench.muscle import ForceLaw
from shoulder_bench.trajectory import load_test_set


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--muscles", nargs="+", default=["ssp"])
    p.add_argument("--muscle-model", default=DEFAULT_MUSCLE_MODEL)
    args = p.parse_args()
    law = ForceLaw.load(args.muscle_model, muscles=tuple(args.muscles))
    angles = np.arange(0.0, 121.0, 10.0)
    rad = np.radians(angles)
    full = law.torque(rad, np.zeros_like(rad), np.ones((len(rad), len(args.muscles)))).sum(axis=1)
    print(f"muscles {args.muscles}, tables {args.muscle_model}")
    print("angle (deg)            " + " ".join(f"{a:6.0f}" for a in angles))
    print("all at a = 1 (N m)     " + " ".join(f"{t:6.2f}" for t in full))
    print("gravity needs (N m)    " + " ".join(f"{t:6.2f}" for t in -statics.gravity_torque(rad)))
    def capacity(rad_: np.ndarray) -> np.ndarray:
        """Largest elevating torque at rest: each muscle fully on if that helps, off otherwise."""
        ones, zeros = np.ones((len(rad_), len(args.muscles))), np.zeros((len(rad_), len(args.muscles)))
        v = np.zeros_like(rad_)
        return np.maximum(law.torque(rad_, v, ones), law.torque(rad_, v, zeros)).sum(axis=1)

    test = load_test_set()
    hold = np.stack([statics.holding_activation(law, t.angle_deg) for t in test])  # (100, 201, n)
    allang = np.radians(np.concatenate([t.angle_deg for t in test]))
    cap = capacity(allang)
    unreachable = cap < -statics.gravity_torque(allang)
    rate = np.abs(np.diff(hold, axis=1)).max(axis=2) > 0.01
    print(f"test frames the muscles cannot hold even at activation 1: {unreachable.mean():.1%}")
    print(f"test steps whose holding activation changes faster than 1 %/frame: {rate.mean():.1%}")
    fine = np.radians(np.arange(0.0, 160.0, 0.1))
    holdable = capacity(fine) >= -statics.gravity_torque(fine)
    top = np.degrees(fine[holdable].max())
    target = np.degrees(allang)
    print(f"highest angle held at rest: {top:.1f} deg; quasi-static lower bound on the test MAE (targets above it "
          f"cannot be reached for long): {np.maximum(target - top, 0).mean():.2f} deg")


if __name__ == "__main__":
    main()
