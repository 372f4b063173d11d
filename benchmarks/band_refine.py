"""Would a finer pose grid bring a band table within the 2 % held-out bound where it misses? (docs/fem.md "Taut bands")

    .venv/bin/python benchmarks/band_refine.py [--tendon T ...] [--at PLANE ELEVATION ROTATION]   (1-3 min a tendon)

At a held-out pose p of the tasks' grid (a cell centre: by default the pose where `fem verify --bands` found each
tendon's largest error), the taut band is solved at the 27 poses p + {-h/2, 0, h/2} per coordinate (h the grid's
step): the nodes of the grid twice as fine around p. The eight poses p + (+-h/4, +-h/4, +-h/4), the centres of the
finer grid's cells there (its held-out poses), are solved too, and each compared with the trilinear reading of the
correction (band - MJCF arms) on that finer grid, as `fem verify --bands` scores a table: per coordinate, the torque
error at a = 1 in % of the tendon's peak |F(L, 1) r_band| over the shipped table's grid. Printed beside it: the error
of the shipped table (on its own grid: the tasks', or for
`bands.REFINE` tendons one twice as fine) at p and at the eight quarter poses. Sheets at the tables' resolution (full).
"""
from __future__ import annotations

import argparse
import itertools

import numpy as np

from shoulder_bench import full_arm
from shoulder_bench.authoring.fem.bands import FOOTPRINT_TENDONS, BandTable, full_force, peak_torque, table_path
from shoulder_bench.authoring.fem.footprint import compare
from shoulder_bench.tendon_law import TendonLaw

# each tendon's largest error of `fem verify --bands` on the first tables (588 held-out poses; docs/fem.md)
WORST_DEG = {"ssp": (82.5, 125.0, -37.5), "isp": (82.5, 135.0, -37.5), "tmi": (37.5, 45.0, -22.5),
             "tma": (7.5, 75.0, 52.5), "pec1": (82.5, 135.0, -22.5)}


def trilinear(corners: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """corners (2, 2, 2, 3) at a cell's corners, weights (3,) in [0, 1]: the trilinear reading (3,)."""
    out = np.zeros(3)
    for i, j, k in itertools.product((0, 1), repeat=3):
        w = (weights[0] if i else 1 - weights[0]) * (weights[1] if j else 1 - weights[1]) * \
            (weights[2] if k else 1 - weights[2])
        out += w * corners[i, j, k]
    return out


def setup(tendon: str) -> tuple:
    """(the task model posed, the tendon's band table, its force law, its peak torque: the verify's scale)."""
    pose, table, law = full_arm.Pose(), BandTable(table_path(tendon)), TendonLaw.load("fem", tendons=(tendon,))
    return pose, table, law, peak_torque(table, law, pose)


def study(tendon: str, at) -> None:
    pose, table, law, peak = setup(tendon)
    half = np.array([full_arm.POSE_STEP_DEG[c] / 2 for c in full_arm.COORDINATES])
    p = np.asarray(at, dtype=float)
    offsets = np.array(list(itertools.product((-1, 0, 1), repeat=3)), dtype=float)  # the finer grid's nodes
    quarters = np.array(list(itertools.product((-1, 1), repeat=3)), dtype=float)  # its cell centres here
    poses = np.vstack([p + offsets * half, p + quarters * half / 2])
    r = compare(tendon, poses, table.meta["resolution"], pose=pose, rest="pose")
    if not r["converged"].all():
        print(f"{tendon}: no equilibrium at {poses[~r['converged']].tolist()} deg; skipped")
        return
    c = (r["fem_m"] - r["mjcf_m"])[:27].reshape(3, 3, 3, 3)  # the correction on the finer grid's nodes
    force = full_force(law, pose, tendon, poses)
    fine, coarse = [], []
    for q, s in zip(quarters, range(27, 35)):
        lo = ((q + 1) / 2).astype(int)  # the finer cell: nodes lo..lo+1 along each coordinate (0-2)
        corners = c[lo[0]:lo[0] + 2, lo[1]:lo[1] + 2, lo[2]:lo[2] + 2]
        read = trilinear(corners, np.full(3, 0.5))
        fine.append(force[s] * np.abs(r["mjcf_m"][s] + read - r["fem_m"][s]) / peak * 100)
        coarse.append(force[s] * np.abs(r["mjcf_m"][s] + table.correction(poses[s])[0] - r["fem_m"][s]) / peak * 100)
    at_p = force[13] * np.abs(r["mjcf_m"][13] + table.correction(p)[0] - r["fem_m"][13]) / peak * 100
    fine, coarse = np.max(fine, axis=0), np.max(coarse, axis=0)
    print(f"{tendon:<5} at {tuple(p.tolist())} deg, error % of peak (plane / elevation / rotation): tasks' grid at p "
          + " / ".join(f"{x:.2f}" for x in at_p) + "; at the 8 quarter poses: tasks' grid "
          + " / ".join(f"{x:.2f}" for x in coarse) + ", twice as fine " + " / ".join(f"{x:.2f}" for x in fine),
          flush=True)


def branches(tendon: str, at) -> None:
    from shoulder_bench.authoring.fem.footprint import FootprintSheet
    from shoulder_bench.authoring.fem.solver import NoConvergence

    pose, table, law, peak = setup(tendon)
    p = np.asarray(at, dtype=float)
    quarter = np.array([full_arm.POSE_STEP_DEG[c] / 4 for c in full_arm.COORDINATES])
    sheet = FootprintSheet(tendon, table.meta["resolution"], pose=pose, rest="pose")
    ramped = sheet.solve(p)
    found = [("ramp from rest", ramped, sheet.solve_from(p, ramped["nodes"])["energy_J"])]
    for k, sign in itertools.product(range(3), (-1, 1)):
        q = p.copy()
        q[k] += sign * quarter[k]
        try:
            sol = sheet.solve_from(p, sheet.solve(q)["nodes"])
        except NoConvergence:
            continue
        found.append((f"from {full_arm.COORDINATE_LABELS[full_arm.COORDINATES[k]]} {sign * quarter[k]:+g} deg",
                      sol, sol["energy_J"]))
    force = full_force(law, pose, tendon, p[None])[0]
    mjcf = pose.tendon_geometry(p, (tendon,))[1][0, 0]
    read = mjcf + table.correction(p)[0]
    print(f"{tendon} at {tuple(p.tolist())} deg: equilibria of the sheet built there (moment arms mm; energy J; the "
          "table's error % of peak, plane / elevation / rotation)")
    for label, sol, energy in found:
        err = force * np.abs(read - sol["moment_arm_m"]) / peak * 100
        print(f"  {label:<24} " + " ".join(f"{x:8.3f}" for x in sol["moment_arm_m"] * 1e3)
              + f"  E {energy:.6f}  T {sol['tension_N']:.1f} N  error " + " / ".join(f"{x:.2f}" for x in err),
              flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tendon", nargs="+", choices=FOOTPRINT_TENDONS, default=list(FOOTPRINT_TENDONS))
    ap.add_argument("--at", nargs=3, type=float, metavar=("PLANE", "ELEVATION", "ROTATION"),
                    help="the held-out pose (deg; default each tendon's worst, WORST_DEG)")
    ap.add_argument("--branches", action="store_true", help="the equilibria at the pose instead (see above)")
    args = ap.parse_args()
    for t in args.tendon:
        (branches if args.branches else study)(t, args.at or WORST_DEG[t])


if __name__ == "__main__":
    main()
