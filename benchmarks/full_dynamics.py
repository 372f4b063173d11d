"""Stepping the full shoulder (`models/shoulder_full_task.xml`, 3 DOF, 15 tendons with the FEM tables): which RK4
step keeps it stable at the tasks' 0.1 s frames, what the glenohumeral armature changes, and the cost.

    .venv/bin/python benchmarks/full_dynamics.py [--seeds 5]

Stability: 20 s (200 frames) from a random pose of the tables' pose space, at rest, under four activation patterns
held over each frame: all zero (the arm falls to the side, onto MoBL's plane singularity), all one, random 0/1 per
muscle and frame ("bang"), and random a = u^3 per muscle and frame; stable = finite, no MuJoCo instability warning.
The tasks change activations by at most 1 % a frame, far gentler than "bang".
Armature: the same 2 s motion (constant activations 0.2, from (45, 60, 0) deg) with the model's armature and with none,
at the model's step; the largest coordinate difference. Cost: mj_step on one MjData per 0.1 s frame.
"""
from __future__ import annotations

import argparse
import time

import mujoco
import numpy as np

from shoulder_bench import full_arm
from shoulder_bench.model import attach_law, install_callbacks
from shoulder_bench.tendon_law import TendonLaw

STEPS_S = (0.01, 0.0125, 0.02)
PATTERNS = ("zero", "full", "bang", "random")


def model(law, timestep: float, armature: float | None = None):
    m = full_arm.compile_full()
    attach_law(m, law)
    install_callbacks()
    m.opt.timestep = timestep
    if armature is not None:
        m.dof_armature[[m.joint(c).dofadr[0] for c in full_arm.COORDINATES]] = armature
    return m


def activations(pattern: str, rng, n: int) -> np.ndarray:
    return {"zero": np.zeros(n), "full": np.ones(n), "bang": rng.integers(0, 2, n).astype(float),
            "random": rng.uniform(0, 1, n) ** 3}[pattern]


def episode(m, law, pose, start_deg, pattern, rng, frames=200) -> bool:
    d = mujoco.MjData(m)
    d.qpos[:] = pose.qpos(start_deg)[0]
    ids = [[m.actuator(t).id for t in full_arm.ACTUATORS[mu]] for mu in law.muscles]
    steps = int(round(0.1 / m.opt.timestep))
    for _ in range(frames):
        a = activations(pattern, rng, len(law.muscles))
        for k, idx in enumerate(ids):
            d.ctrl[idx] = a[k]
        mujoco.mj_step(m, d, steps)
        if not np.isfinite(d.qpos).all() or d.warning[mujoco.mjtWarning.mjWARN_BADQACC].number:
            return False
    return True


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=5)
    args = ap.parse_args()
    law = TendonLaw.load("fem", groups=full_arm.ACTUATORS)
    nominal = full_arm.compile_full()
    armature = float(nominal.dof_armature[nominal.joint("shoulder_elv").dofadr[0]])
    print(f"model: RK4 at {nominal.opt.timestep} s, glenohumeral armature {armature:g} kg m^2")
    lo = np.array([r[0] for r in full_arm.POSE_RANGE_DEG.values()])
    hi = np.array([r[1] for r in full_arm.POSE_RANGE_DEG.values()])
    print("stable episodes (20 s) of", args.seeds, "seeds per activation pattern:")
    for h in STEPS_S:
        m = model(law, h, armature)
        pose = full_arm.Pose(m)
        row = []
        for pattern in PATTERNS:
            ok = 0
            for seed in range(args.seeds):
                rng = np.random.default_rng(seed)
                ok += episode(m, law, pose, rng.uniform(lo, hi), pattern, rng)
            row.append(f"{pattern} {ok}/{args.seeds}")
        d = mujoco.MjData(m)
        d.qpos[:] = pose.qpos([45, 60, 0])[0]
        d.ctrl[:] = 0.2
        steps = int(round(0.1 / h))
        t0 = time.perf_counter()
        for _ in range(50):
            mujoco.mj_step(m, d, steps)
        cost = (time.perf_counter() - t0) / 50 * 1e3
        print(f"  step {h * 1e3:5.1f} ms ({steps:2d} per frame): {', '.join(row)}; {cost:.2f} ms per frame")
    motions = {}
    for a in (armature, 0.0):
        m = model(law, float(nominal.opt.timestep), a)
        d = mujoco.MjData(m)
        d.qpos[:] = full_arm.Pose(m).qpos([45, 60, 0])[0]
        d.ctrl[:] = 0.2
        qadr = [m.joint(c).qposadr[0] for c in full_arm.COORDINATES]
        path = []
        for _ in range(20):
            mujoco.mj_step(m, d, int(round(0.1 / m.opt.timestep)))
            path.append(np.degrees(d.qpos[qadr]))
        motions[a] = np.array(path)
    diff = np.abs(motions[armature] - motions[0.0]).max(axis=0)
    span = np.ptp(motions[0.0], axis=0)
    print(f"armature {armature:g} vs none, 2 s at a = 0.2 from (45, 60, 0) deg: max difference "
          f"{', '.join(f'{x:.3f}' for x in diff)} deg (plane, elevation, rotation; the motion spans "
          f"{', '.join(f'{x:.1f}' for x in span)} deg)")


if __name__ == "__main__":
    main()
