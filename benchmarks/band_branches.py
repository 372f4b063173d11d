"""How often does the ramp from rest land on a higher-energy equilibrium of a taut band? (docs/fem.md "Closing three
misses")

    .venv/bin/python benchmarks/band_branches.py --tendon ssp [--n 150] [--seed 0]   (≈ 5 s a pose for ssp)
    .venv/bin/python benchmarks/band_branches.py --tendon pec2 --at 82.5 75 -37.5 [--at P E R ...] [--activation A]
        [--iteration-stall] [--max-iter N]

At N poses drawn from the tendon's table grid (`bands.grid_poses`, fixed seed) the band is solved as
`bands.least_energy` solves it with all six starts (the ramp at p, and Newton at p from the ramp's at p +-
PROBE_FRACTION of the tasks' step along each coordinate, `bands.probe_offsets`), and for each pose it reports whether
a start other than the ramp reached another equilibrium of lower energy (lower by more than LOWER_J, its moment arms
more than SAME_MM from the ramp's: closer ones are the same equilibrium to the solver's tolerance), by how much the
arms differ and which starts found it: what the least-energy rule would change in a table built by the ramp, and
whether fewer starts would do. Where the ramp finds no equilibrium, it reports which of the other starts reach one
at p (and the band's moment arms there). --at: these poses (deg) instead of the drawn ones; --activation: every
solve at this level (default 1: the tables' level), the ramp's from rest to it. --iteration-stall: a study of a
solver rule no table uses (`SolverSettings.iteration_stall`): Newton's last iterate accepted where its residual is
inside the stall band (stall_factor x the tolerance) a stalled line search is accepted in. --max-iter: another cap on
Newton's iterations in every solve (a study: the tables' is footprint.SETTINGS.max_iter, 60). With --at, each pose
the ramp solves is printed with its band's moment arms.
"""
from __future__ import annotations

import argparse
import dataclasses

import numpy as np

from shoulder_bench import full_arm
from shoulder_bench.authoring.fem import footprint
from shoulder_bench.authoring.fem.bands import FOOTPRINT_TENDONS, grid_poses, probe_offsets, surface
from shoulder_bench.authoring.fem.footprint import FootprintSheet
from shoulder_bench.authoring.fem.solver import NoConvergence

LOWER_J = 1e-6  # an equilibrium counts as lower when its energy is below the ramp's by more than this
SAME_MM = 0.05  # and as another one when some moment arm differs from the ramp's by more than this


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tendon", choices=FOOTPRINT_TENDONS, required=True)
    ap.add_argument("--n", type=int, default=150, help="poses drawn from the table's grid")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--at", nargs=3, type=float, action="append", metavar=("PLANE", "ELEVATION", "ROTATION"),
                    help="a pose (deg) to solve instead of the drawn ones; repeat for more")
    ap.add_argument("--activation", type=float, default=1.0, help="the level every band is solved at (0, 1]")
    ap.add_argument("--iteration-stall", action="store_true",
                    help="Newton's last iterate accepted inside the stall band (a study: no table uses it)")
    ap.add_argument("--max-iter", type=int, default=footprint.SETTINGS.max_iter,
                    help="Newton's iteration cap in every solve (a study: the tables use %(default)s)")
    args = ap.parse_args()
    if not 0.0 < args.activation <= 1.0:
        ap.error(f"--activation {args.activation:g}: give a level in (0, 1]")
    if args.max_iter < 1:
        ap.error(f"--max-iter {args.max_iter}: give a whole number >= 1")
    footprint.SETTINGS = dataclasses.replace(footprint.SETTINGS, max_iter=args.max_iter,  # read by every sheet
                                             iteration_stall=args.iteration_stall)
    a = args.activation
    poses = grid_poses(args.tendon)
    poses = poses[np.sort(np.random.default_rng(args.seed).choice(len(poses), min(args.n, len(poses)), False))]
    if args.at:
        poses = np.array(args.at, dtype=float)
    labels = [f"{s}{c}" for s in "+-" for c in ("plane", "elevation", "rotation")]  # probe_offsets' order
    sheet = FootprintSheet(args.tendon, "full", pose=full_arm.Pose(), rest="pose",
                           surface=surface(args.tendon))
    lower, shift, found_by = 0, [], {label: 0 for label in labels}
    for p in poses:
        try:
            ramp = sheet.solve_from(p, sheet.solve(p, a)["nodes"], a)
        except NoConvergence as failure:
            reached = []
            for label, start in zip(labels, p + probe_offsets()):
                try:
                    sol = sheet.solve_from(p, sheet.solve(start, a)["nodes"], a)
                except NoConvergence:
                    continue
                reached.append(f"{label} (arms {np.round(sol['moment_arm_m'] * 1e3, 1).tolist()} mm)")
            print(f"{tuple(p.tolist())}: the ramp finds no equilibrium ({failure}); "
                  + (f"from the other starts: {', '.join(reached)}" if reached else "nor does any other start"))
            continue
        if args.at:
            print(f"{tuple(p.tolist())}: the ramp's equilibrium, arms "
                  f"{np.round(ramp['moment_arm_m'] * 1e3, 1).tolist()} mm", flush=True)
        best, by = ramp, []
        for label, start in zip(labels, p + probe_offsets()):
            try:
                sol = sheet.solve_from(p, sheet.solve(start, a)["nodes"], a)
            except NoConvergence:
                continue
            other = np.abs(sol["moment_arm_m"] - ramp["moment_arm_m"]).max() * 1e3 > SAME_MM
            if other and sol["energy_J"] < ramp["energy_J"] - LOWER_J:
                if sol["energy_J"] < best["energy_J"] - LOWER_J:
                    best, by = sol, []
                if abs(sol["energy_J"] - best["energy_J"]) <= LOWER_J:
                    by.append(label)
        if best is not ramp:
            lower += 1
            shift.append(np.abs(best["moment_arm_m"] - ramp["moment_arm_m"]).max() * 1e3)
            for label in by:
                found_by[label] += 1
            print(f"{tuple(p.tolist())} deg: {ramp['energy_J'] - best['energy_J']:.2e} J lower, arms moved "
                  f"{shift[-1]:.3f} mm, found from {', '.join(by)}", flush=True)
    print(f"{args.tendon}: another equilibrium of lower energy than the ramp's at {lower} of {len(poses)} grid poses"
          + (f" (arms moved {np.median(shift):.3f} mm median, {max(shift):.3f} mm largest); the least-energy one found "
             "from: " + ", ".join(f"{k} {v}" for k, v in found_by.items()) if lower else ""))


if __name__ == "__main__":
    main()
