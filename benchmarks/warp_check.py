"""What MuJoCo Warp (float32) makes of the tasks' models, on Warp's CPU device (no GPU here): why there is no Warp
backend (docs/gpu.md "MuJoCo Warp"). Needs the `[warp]` extra:

    .venv/bin/pip install -e '.[warp]'
    .venv/bin/python benchmarks/warp_check.py [--n 256] [--seed 1]

For the 1-DOF tasks' arm and the 3-DOF full shoulder, the actuators made plain (the muscle forces as controls, as the
MJX backend feeds them: `mjx_sim`), at N states on the coupling paths (elevations, or poses, drawn in the test split's
ranges; at rest; every actuator pulling with a force drawn in [0, 200] N), it prints per model: the mass matrix's
condition number (MuJoCo C, float64; median and largest over the states); MuJoCo Warp's `forward` at those states:
the copies whose unconstrained acceleration (`qacc_smooth`, M^-1 times the smooth forces) or whose acceleration
(`qacc`) is not finite; and one 0.1 s frame of RK4 steps, with the model's Newton solver and with CG, against MuJoCo
C's `mj_step` from the same state: the copies that end non-finite, and the difference in elevation over the others
(median and largest, deg; copies MuJoCo C itself resets within the frame are left out and counted). The first run
compiles MuJoCo Warp's kernels (minutes on the CPU; cached after).
"""
import argparse
import copy

import mujoco
import numpy as np
import warp as wp

from shoulder_bench import arm, full_arm
from shoulder_bench import trajectory as targets1
from shoulder_bench import trajectory3 as targets3
from shoulder_bench.geometry import forces_as_controls
from shoulder_bench.protocol import FRAME_S

wp.config.log_level = wp.LOG_WARNING  # no line per kernel module loaded
import mujoco_warp as mjw  # noqa: E402

FORCE_N = 200.0
SOLVERS = {"newton": mujoco.mjtSolver.mjSOL_NEWTON, "cg": mujoco.mjtSolver.mjSOL_CG}


def frame_steps(m: mujoco.MjModel) -> int:
    """Physics steps in one of the tasks' frames."""
    return int(round(FRAME_S / m.opt.timestep))


def states(name: str, n: int, rng) -> tuple[mujoco.MjModel, np.ndarray, int]:
    """(plain model, qpos (n, nq) on its couplings, the elevation's qpos address)."""
    if name == "1-DOF arm":
        m = forces_as_controls(arm.compile_arm())
        lo, hi = targets1.SPLITS["test"]["range_deg"]
        qpos = arm.LockedPath(m).qpos(np.radians(rng.uniform(lo, hi, n)))
        return m, qpos, int(m.joint(arm.JOINT).qposadr[0])
    m = forces_as_controls(full_arm.compile_full())
    box = targets3.SPLITS["test"]["range_deg"]
    poses = np.stack([rng.uniform(lo, hi, n) for lo, hi in box], axis=1)
    return m, full_arm.Pose(m).qpos(poses), int(m.joint(full_arm.COORDINATES[1]).qposadr[0])


def reference(m, qpos, ctrl):
    """MuJoCo C (float64): condition numbers of M at the states, the qpos after one frame of mj_step, and whether
    MuJoCo kept the copy (did not reset it)."""
    d = mujoco.MjData(m)
    full = np.zeros((m.nv, m.nv))
    cond, end, kept = [], np.zeros_like(qpos), np.ones(len(qpos), dtype=bool)
    for k in range(len(qpos)):
        mujoco.mj_resetData(m, d)
        d.qpos[:], d.ctrl[:] = qpos[k], ctrl[k]
        mujoco.mj_forward(m, d)
        mujoco.mj_fullM(m, d, full)
        cond.append(np.linalg.cond(full))
        for _ in range(frame_steps(m)):
            mujoco.mj_step(m, d)
        end[k] = d.qpos
        kept[k] = abs(d.time - FRAME_S) < 1e-9  # MuJoCo resets a copy whose acceleration blows up (time restarts)
    return np.array(cond), end, kept


def on_warp(m, qpos, ctrl, solver: str):
    """MuJoCo Warp on the CPU with `solver`: ((qacc_smooth finite, qacc finite) per copy after `forward`, the qpos
    after one frame of `step`s)."""
    m = copy.copy(m)
    m.opt.solver = SOLVERS[solver]

    def posed():  # fresh data of every copy at its state and controls
        d = mjw.make_data(m, nworld=len(qpos))
        d.qpos.assign(qpos.astype(np.float32))
        d.ctrl.assign(ctrl.astype(np.float32))
        return d

    with wp.ScopedDevice("cpu"):
        mx, d = mjw.put_model(m), posed()
        mjw.forward(mx, d)
        finite = (np.isfinite(d.qacc_smooth.numpy()).all(axis=1), np.isfinite(d.qacc.numpy()).all(axis=1))
        d = posed()
        for _ in range(frame_steps(m)):
            mjw.step(mx, d)
        return finite, d.qpos.numpy().astype(np.float64)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=256, help="states per model")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    print(f"mujoco {mujoco.__version__}, mujoco_warp {mjw.__version__ if hasattr(mjw, '__version__') else '?'}, "
          f"warp {wp.config.version}; N = {args.n} states per model, seed {args.seed}")
    print("| model | cond(M) median / largest | qacc_smooth non-finite | qacc non-finite | solver | frame: copies "
          "failed | elevation diff median / largest (deg) |")
    print("|---|---|---|---|---|---|---|")
    for name in ("1-DOF arm", "3-DOF full shoulder"):
        rng = np.random.default_rng(args.seed)
        m, qpos, qadr = states(name, args.n, rng)
        ctrl = -rng.uniform(0.0, FORCE_N, (args.n, m.nu))
        cond, end, kept = reference(m, qpos, ctrl)
        for solver in SOLVERS:
            (smooth_ok, acc_ok), warp_end = on_warp(m, qpos, ctrl, solver)
            ok = np.isfinite(warp_end).all(axis=1)
            both = ok & kept
            diff = np.degrees(np.abs(warp_end[both, qadr] - end[both, qadr]))
            spread = f"{np.median(diff):.2e} / {diff.max():.2e}" if both.any() else "-"
            print(f"| {name} | {np.median(cond):.2e} / {cond.max():.2e} | {(~smooth_ok).sum()} of {args.n} | "
                  f"{(~acc_ok).sum()} of {args.n} | {solver} | {(~ok).sum()} of {args.n} | {spread} |")
        if not kept.all():
            print(f"  ({name}: MuJoCo C reset {(~kept).sum()} copies within the frame; left out of the differences)")


if __name__ == "__main__":
    main()
