"""How a taut band's drape changes its equilibrium (docs/fem.md "The deltoids"): each fibre over its own great circle of
the contact sphere, against the flat drape (`footprint.FLAT_DRAPE`: every fibre in the plane parallel to the central
fibre's), for any footprint tendon on its band table's contact surface (`bands.surface`, or `--surface`). For each
pose: the origin's resultant (tension) over F0, how far the equilibrium lies from the drape (the sheet's stress-free
shape), the contact force and the moment arms, at a = 1.

    python benchmarks/band_drape.py --tendon dpo --at 90 100 60 --at 30 60 0
"""
from __future__ import annotations

import argparse

import numpy as np

from shoulder_bench.authoring.fem import bands
from shoulder_bench.authoring.fem import footprint as F
from shoulder_bench.authoring.fem.solver import NoConvergence


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--tendon", choices=F.TENDONS, required=True)
    p.add_argument("--at", nargs=3, type=float, action="append", required=True, metavar=("PLANE", "ELV", "ROT"))
    p.add_argument("--coarse", action="store_true", help="15 x 5 nodes instead of 31 x 9")
    p.add_argument("--surface", choices=F.SURFACES, help="the contact surface (default: its band table's)")
    args = p.parse_args(argv)
    surface = args.surface or bands.surface(args.tendon)
    print(f"{args.tendon}: drape, pose -> tension / F0, largest |x - X| (mm), contact (N), moment arms plane / "
          "elevation / rotation (mm); MJCF's")
    for drape, flat in (("great circles", False), ("flat", True)):
        sheet = F.FootprintSheet(args.tendon, "coarse" if args.coarse else "full", surface=surface,
                                 rest="pose", flat=flat)
        for pose in map(tuple, args.at):
            try:
                s = sheet.solve(pose)
            except NoConvergence as exc:
                print(f"{drape:>14} {pose}: no equilibrium ({exc})")
                continue
            moved = 1e3 * np.abs(s["nodes"] - sheet.problem.X).max()
            arms = " / ".join(f"{v:.2f}" for v in 1e3 * s["moment_arm_m"])
            mjcf = " / ".join(f"{v:.2f}" for v in 1e3 * sheet.mjcf_moment_arm(pose))
            print(f"{drape:>14} {pose}: {s['tension_N'] / sheet.f0:.2f}, {moved:.1f}, {s['contact_N']:.0f}, "
                  f"{arms}; {mjcf}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
