"""What a footprint-sheet table would cost to build, and whether solving along grid lines is the same as solving each
pose from the reference (issue 12 §2; docs/fem.md "Footprint sheets: the pose grid").

    .venv/bin/python benchmarks/footprint_sweep.py [--tendon ssp ...] [--coarse] [--refine 2] [--lines 3]
                                                   [--activation A]

For each tendon, `--lines` grid lines of the tasks' pose grid made `--refine` times finer (elevation 0-140 deg at
plane and rotation drawn from the grid with a fixed seed), solved at a = `--activation` (default 1) two ways, one
after the other in one process: every pose from the reference pose (`FootprintSheet.solve`, what `fem footprint`
does) and along the line, each pose continued from the one before (`FootprintSheet.solve_path`). Prints seconds per
pose each way, their ratio, and the largest difference of the torque vector between the two in % of the tendon's
peak |torque| on the lines (a difference means the two ways found different equilibria: the sheet's contact depends
on the way there).
"""
from __future__ import annotations

import argparse
import time

import numpy as np


def lines(refine: int, count: int, seed: int = 0, chosen=None) -> list[np.ndarray]:
    """`count` elevation lines of the grid `refine` times finer than the tasks' at (plane, rotation) drawn with
    `seed`, or at the (plane, rotation) pairs `chosen`."""
    from shoulder_bench import full_arm

    step = {c: full_arm.POSE_STEP_DEG[c] / refine for c in full_arm.COORDINATES}
    grid = full_arm.pose_grid(step)
    rng = np.random.default_rng(seed)
    planes, rotations = np.unique(grid[:, 0]), np.unique(grid[:, 2])
    elevations = np.unique(grid[:, 1])
    pairs = chosen or [(rng.choice(planes), rng.choice(rotations)) for _ in range(count)]
    out = []
    for plane, rotation in pairs:
        out.append(np.stack([np.full_like(elevations, plane), elevations, np.full_like(elevations, rotation)], 1))
    return out


def main(argv=None) -> int:
    from shoulder_bench.authoring.fem.footprint import FootprintSheet
    from shoulder_bench.authoring.fem.solver import NoConvergence
    from shoulder_bench.full_arm import Pose

    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--tendon", nargs="+", default=["ssp"])
    p.add_argument("--coarse", action="store_true", help="coarse sheets (15 x 5 nodes)")
    p.add_argument("--refine", type=int, default=2, help="the tasks' grid step divided by this")
    p.add_argument("--lines", type=int, default=3)
    p.add_argument("--activation", type=float, default=1.0)
    p.add_argument("--line", nargs=2, type=float, action="append", metavar=("PLANE", "ROTATION"),
                   help="this elevation line instead of drawn ones (repeatable); prints every pose where the two "
                   "ways differ by more than 1 %% of peak")
    args = p.parse_args(argv)
    pose = Pose()
    resolution = "coarse" if args.coarse else "full"
    level = args.activation
    print(f"{resolution} sheets, a = {level:g}, elevation lines of the tasks' grid / {args.refine}")
    print("tendon  poses  from reference (s/pose)  along the line (s/pose)  ratio  solved (ref / line)  "
          "largest difference (% of peak): plane elevation rotation")
    for tendon in args.tendon:
        sheet = FootprintSheet(tendon, resolution, pose=pose)
        sheet.solve(lines(args.refine, 1)[0][0], level)  # the reference equilibrium, built once, outside the timings
        ref_res, path_res, t_ref, t_path, poses = [], [], 0.0, 0.0, []
        for line in lines(args.refine, args.lines, chosen=args.line):
            t = time.perf_counter()
            for q in line:
                try:
                    ref_res.append(sheet.solve(q, level))
                except NoConvergence:
                    ref_res.append(None)
            t_ref += time.perf_counter() - t
            t = time.perf_counter()
            path_res += sheet.solve_path(line, level)
            t_path += time.perf_counter() - t
            poses += list(line)
        ref, path = ([None if r is None else r["torque_Nm"] for r in res] for res in (ref_res, path_res))
        both = [(a, b) for a, b in zip(ref, path) if a is not None and b is not None]
        a, b = np.array([x for x, _ in both]), np.array([y for _, y in both])
        peak = np.abs(a).max(axis=0)
        diff = (np.abs(a - b).max(axis=0) / peak * 100) if both else np.full(3, np.nan)
        n = len(ref)
        print(f"{tendon:<6} {n:>5}  {t_ref / n:>22.2f}  {t_path / n:>23.2f}  {t_ref / t_path:5.1f}  "
              f"{sum(x is not None for x in ref):>8} / {sum(x is not None for x in path):<8}  "
              + " ".join(f"{x:9.2f}" for x in diff))
        if args.line:  # every pose where the two ways found different equilibria
            for q, x, y in zip(poses, ref_res, path_res):
                if x is not None and y is not None and (np.abs(x["torque_Nm"] - y["torque_Nm"]) / peak).max() > 0.01:
                    print(f"   ({q[0]:g}, {q[1]:g}, {q[2]:g}) deg: from the reference {np.round(x['torque_Nm'], 2)} "
                          f"N m, contact {x['contact_N']:.0f} N; along the line {np.round(y['torque_Nm'], 2)} N m, "
                          f"contact {y['contact_N']:.0f} N")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
