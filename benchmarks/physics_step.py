"""Choose the physics step: accuracy against a fine reference and stability when a muscle is slammed on.

Accuracy: track a fixed activation profile for 10 s; the profile is what an agent produces (a seeded random walk of
at most 1 % per 0.1 s frame from the activations that hold the arm at 45 deg, held within a frame). Criterion
(issue 4): the angle stays within 0.1 deg of the reference (RK4, 0.5 ms) over the whole 10 s.
Stability: the tracking runs stay finite. For information, each muscle alone at full activation for 5 s from 0, 45 and
150 deg ("slam"): how far the arm is driven past the soft joint limits (beyond 5 deg the tasks call it a crash).

    python benchmarks/physics_step.py [--muscle-model fem|hill] [--seeds 5]
"""
from __future__ import annotations

import argparse

import mujoco
import numpy as np

from shoulder_bench import statics
from shoulder_bench.model import JOINT, law_of, load_model

FRAMES = 100
CANDIDATES = [("RK4", 0.025), ("RK4", 0.05), ("RK4", 0.1), ("IMPLICITFAST", 0.002), ("IMPLICITFAST", 0.005),
              ("IMPLICITFAST", 0.01)]


def profile(law, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    a = statics.holding_activation(law, 45.0)[0]
    out = []
    for _ in range(FRAMES):
        a = np.clip(a + rng.uniform(-0.01, 0.01, size=a.shape), 0.0, 1.0)
        out.append(a.copy())
    return np.array(out)


def simulate(m, acts: np.ndarray, integrator: str, dt: float, start_deg: float = 45.0) -> np.ndarray:
    """Angle (deg) at the end of each 0.1 s frame."""
    m.opt.integrator = getattr(mujoco.mjtIntegrator, f"mjINT_{integrator}")
    m.opt.timestep = dt
    d = mujoco.MjData(m)
    d.qpos[m.joint(JOINT).qposadr[0]] = np.radians(start_deg)
    out = []
    for a in acts:
        d.ctrl[:] = a
        mujoco.mj_step(m, d, nstep=int(round(0.1 / dt)))
        out.append(np.degrees(d.qpos[0]))
    return np.array(out)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--muscle-model", default=None, help="fem or hill (default: the model's default)")
    p.add_argument("--seeds", type=int, default=5)
    args = p.parse_args()
    m = load_model(**({"muscle_model": args.muscle_model} if args.muscle_model else {}))
    law = law_of(m)
    profiles = [profile(law, s) for s in range(args.seeds)]
    refs = [simulate(m, a, "RK4", 0.0005) for a in profiles]
    print(f"{'integrator':>13} {'step ms':>8} {'max error deg':>14} {'slam range deg':>18}  verdict")
    for integrator, dt in CANDIDATES:
        runs = [simulate(m, a, integrator, dt) for a in profiles]
        finite = all(np.all(np.isfinite(r)) for r in runs)
        err = max(float(np.max(np.abs(run - r))) for run, r in zip(runs, refs))
        angles = []
        for k in range(m.nu):
            slam = np.zeros((50, m.nu))
            slam[:, k] = 1.0
            for start in (0.0, 45.0, 150.0):
                angles.append(simulate(m, slam, integrator, dt, start))
        angles = np.concatenate(angles)
        verdict = "unstable" if not finite else ("ok" if err <= 0.1 else "inaccurate")
        print(f"{integrator:>13} {dt * 1000:8.1f} {err:14.4f} {f'[{angles.min():.0f}, {angles.max():.0f}]':>18}  "
              f"{verdict}")


if __name__ == "__main__":
    main()
