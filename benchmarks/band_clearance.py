"""Where a footprint tendon's free part meets its contact surfaces (docs/fem.md "dan and ld1-3"): over its band table's
pose grid (`bands.grid_poses`), the clearance of the proximal site P and of the straight line P-Q
from the MJCF's wrap object (sphere or cylinder) and from the humeral head sphere (`footprint.HUMERAL_HEAD`), negative
where inside; and at how many poses MuJoCo's path wraps the object at all (its free length beyond the straight line).
A site inside the surface is a pose where MuJoCo does not wrap and the sheet's contact pushes the band off it.

    python benchmarks/band_clearance.py --tendon dan ld1 ld2 ld3
"""
from __future__ import annotations

import argparse

import numpy as np

from shoulder_bench.authoring.fem import bands
from shoulder_bench.authoring.fem import footprint as F


def _clearance(p, q, centre, radius, axis) -> float:
    """Least distance of the segment p-q from the sphere (axis None) or the infinite cylinder about `axis`, negative
    inside (m): its closest point to the centre, or to the axis in the projection along it (q = p: the point p)."""
    a, b = p - centre, q - centre
    if axis is not None:
        a, b = a - (a @ axis) * axis, b - (b @ axis) * axis
    d = b - a
    t = float(np.clip(-(a @ d) / (d @ d), 0.0, 1.0)) if d @ d > 0 else 0.0
    return float(np.linalg.norm(a + t * d) - radius)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--tendon", nargs="+", choices=F.TENDONS, required=True)
    args = ap.parse_args(argv)
    print("clearance (mm, negative inside): P's least, the line P-Q's least, poses with P inside")
    for tendon in args.tendon:
        poses = bands.grid_poses(tendon)
        for surface in ("wrap", "head"):
            sheet = F.FootprintSheet(tendon, "coarse", surface=surface)
            rows, wrapped = [], 0
            for pose in poses:
                sheet._set(pose)
                p, q, _ = sheet._ends()
                c, radius, axis = sheet._contact_surface()[:3]
                rows.append((_clearance(p, p, c, radius, axis), _clearance(p, q, c, radius, axis)))
                wrapped += sheet.central_length() > np.linalg.norm(q - p) + 1e-6
            rows = 1e3 * np.array(rows)
            name = "MJCF wrap" if surface == "wrap" else "head"
            print(f"{tendon:5} {name:9} ({len(poses)} poses): P {rows[:, 0].min():6.1f}, line {rows[:, 1].min():6.1f}, "
                  f"P inside at {int((rows[:, 0] < 0).sum())}; MuJoCo's path wraps at {int(wrapped)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
