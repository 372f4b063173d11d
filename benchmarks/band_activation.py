"""Does the taut band's line of action depend on the activation? (docs/fem.md "Taut bands", "The activation")

    .venv/bin/python benchmarks/band_activation.py --tendon ssp [--n 40] [--seed 0]   (≈ 1-5 s a pose)
    .venv/bin/python benchmarks/band_activation.py --tendon tma --along PLANE ROTATION E0 E1 [--step 2.5]

The band tables hold one line of action per pose, the band's at a = 1, and `fem verify --bands` checks them at a = 1
only. At a lower activation the tendon's force F(L_MT, a) is smaller, but the band's line may move: this measures by
how much. At N poses drawn from the tendon's table grid (`bands.grid_poses`, fixed seed) the band is solved at a = 1
by its table's rule (the ramp, or `LEAST_ENERGY`'s least-energy equilibrium) and then, on the same branch, at each
lower level of ACTIVATIONS (`footprint_compare.continued`: Newton from the equilibrium at the level above); the ramp
from rest to each level is solved too, to see whether it reaches the same equilibrium. At a grid pose the table's
line is the band's at a = 1, so the scheme's error at level a is F(L_MT(q), a) |r_band(q, a) - r_band(q, 1)| per
coordinate, reported as the verify reports its errors: in % of the tendon's peak |F(L_MT, 1) r_band| over its grid
(`band_verify.peak_torque`), against the verify's bound (`verify_full.HELD_OUT_TOL`). `--along`: instead of the
draw, the poses along elevation from E0 to E1 deg every `--step` at that plane and rotation (off the grid too): how
the move varies from one pose to the next (docs/fem.md "The activation tabled").
"""
from __future__ import annotations

import argparse

import numpy as np

from shoulder_bench import full_arm
from shoulder_bench.authoring.fem.band_verify import peak_torque, tendon_force
from shoulder_bench.authoring.fem.bands import (
    FOOTPRINT_TENDONS,
    LEAST_ENERGY,
    BandTable,
    grid_poses,
    probe_offsets,
    surface,
)
from shoulder_bench.authoring.fem.footprint import FootprintSheet
from shoulder_bench.authoring.fem.footprint_compare import continued
from shoulder_bench.authoring.fem.solver import NoConvergence
from shoulder_bench.authoring.fem.verify_full import HELD_OUT_TOL
from shoulder_bench.band_lines import table_path
from shoulder_bench.tendon_law import TendonLaw

ACTIVATIONS = (0.25, 0.5, 0.75)  # the levels below 1 the band is solved at (the FEM ramp's own steps)
SAME_MM = 0.05  # the ramp to a level reaches the continued equilibrium when its arms are this close


def at_full(sheet: FootprintSheet, tendon: str, p: np.ndarray) -> dict:
    """The band at `p`, a = 1, as its table solves it."""
    if tendon in LEAST_ENERGY:
        return sheet.solve_least_energy(p, probe_offsets()[:LEAST_ENERGY[tendon]])
    return sheet.solve_from(p, sheet.solve(p)["nodes"])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tendon", choices=FOOTPRINT_TENDONS, required=True)
    ap.add_argument("--n", type=int, default=40, help="poses drawn from the table's grid")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--along", nargs=4, type=float, metavar=("PLANE", "ROTATION", "E0", "E1"),
                    help="the poses along elevation E0..E1 deg at this plane and rotation instead of the draw")
    ap.add_argument("--step", type=float, default=2.5, help="with --along: deg between the poses")
    args = ap.parse_args()
    t, pose = args.tendon, full_arm.Pose()
    if args.along:
        plane, rotation, e0, e1 = args.along
        elevations = np.arange(e0, e1 + 1e-9, args.step)
        poses = np.column_stack([np.full_like(elevations, plane), elevations, np.full_like(elevations, rotation)])
    else:
        poses = grid_poses(t)
        poses = poses[np.sort(np.random.default_rng(args.seed).choice(len(poses), min(args.n, len(poses)), False))]
    law = TendonLaw.load("fem", tendons=(t,))
    peak = peak_torque(BandTable(table_path(t, full_arm.TABLE_FOLDER)), law, pose)
    lengths = pose.tendon_geometry(poses, (t,))[0]
    sheet = FootprintSheet(t, "full", pose=pose, rest="pose", surface=surface(t))
    moved = {a: [] for a in ACTIVATIONS}  # (mm, 3) per solved pose
    error = {a: [] for a in ACTIVATIONS}  # (% of peak, 3)
    ramp_other = {a: 0 for a in ACTIVATIONS}  # poses where the ramp to a reaches another equilibrium, or none
    ramp_gap = {a: [0.0] for a in ACTIVATIONS}  # (mm) how far that one's arms lie from the continued one's
    skipped = 0
    for i, p in enumerate(poses):
        try:
            full = at_full(sheet, t, p)
        except NoConvergence:
            full = None
        down = sorted(ACTIVATIONS, reverse=True)  # each level continued from the one above
        arms = continued(sheet, p, full["nodes"], down) if full is not None else np.full((len(down), 3), np.nan)
        if np.isnan(arms).any():
            skipped += 1
            print(f"{tuple(p.tolist())}: no equilibrium at some level; skipped", flush=True)
            continue
        for a, arm in zip(down, arms):
            d = np.abs(arm - full["moment_arm_m"])
            force = law.force(lengths[i:i + 1], np.zeros((1, 1)), np.full((1, 1), a))[0, 0]
            moved[a].append(d * 1e3)
            error[a].append(force * d / peak * 100)
            try:
                gap = np.abs(sheet.solve(p, a)["moment_arm_m"] - arm).max() * 1e3
                ramp_other[a] += int(gap > SAME_MM)
                ramp_gap[a].append(gap)
            except NoConvergence:
                ramp_other[a] += 1
        worst = max(error[a][-1].max() for a in ACTIVATIONS)
        print(f"{tuple(p.tolist())} deg: arms moved at a = {', '.join(map(str, ACTIVATIONS))}: "
              + "; ".join(" ".join(f"{x:.2f}" for x in moved[a][-1]) for a in ACTIVATIONS)
              + f" mm; largest error {worst:.2f} %", flush=True)
    solved = len(poses) - skipped
    f1 = tendon_force(law, pose, t, poses)
    print(f"\n{t}: {solved} of {len(poses)} grid poses solved at every level; F(L, 1) at the poses "
          f"{f1.min():.0f}-{f1.max():.0f} N; peak torque "
          + " / ".join(f"{x:.2f}" for x in peak) + " N m (plane / elevation / rotation)")
    print("level  arms moved from a = 1, median / largest (mm)        error, largest (% of peak)   over "
          f"{HELD_OUT_TOL * 100:g} %  ramp elsewhere (largest gap, mm)")
    for a in ACTIVATIONS:
        if not solved:
            break
        m, e = np.array(moved[a]), np.array(error[a])
        print(f"{a:5.2f}  " + "  ".join(f"{np.median(m[:, k]):.2f} / {m[:, k].max():.2f}" for k in range(3))
              + "   " + " / ".join(f"{x:.2f}" for x in e.max(axis=0))
              + f"   {int((e.max(axis=1) > HELD_OUT_TOL * 100).sum()):4d}"
              + f"   {ramp_other[a]:4d} ({max(ramp_gap[a]):.2f})")


if __name__ == "__main__":
    main()
