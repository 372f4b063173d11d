"""Is a shipped band table what today's code builds? Compare the band tables of two folders (docs/fem.md
"Re-verified with today's solver"):

    .venv/bin/shoulder-bench fem build --bands --tendon isp --jobs 2 --out /tmp/isp_band      # ≈ 70 s
    .venv/bin/python benchmarks/band_table_diff.py /tmp/isp_band [models/muscles_full]

For each `<t>_band.npz` in the first folder that the second (default models/muscles_full) has too: the grid poses
unsolved in either (an unsolved pose holds its solved neighbours' mean), the largest difference of the band's moment
arms (mm, any coordinate) and of its tension (N) at the poses solved in both, and at the poses solved in one only.
Exit 1 if a table's grid or activation levels differ.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from shoulder_bench.full_arm import TABLE_FOLDER

AXES = ("plane_deg", "elevation_deg", "rotation_deg")


def compare(a_path: Path, b_path: Path) -> dict | None:
    """The differences of two band tables; None where their grids differ."""
    a, b = np.load(a_path), np.load(b_path)
    if any(not np.array_equal(a[k], b[k]) for k in AXES) or a["moment_arm_m"].shape != b["moment_arm_m"].shape:
        return None
    arms = 1e3 * np.abs(a["moment_arm_m"] - b["moment_arm_m"])
    arms = arms.max(axis=tuple(range(3, arms.ndim)))  # over coordinates (and levels, where a table has them)
    tension = np.abs(a["tension_N"] - b["tension_N"])
    tension = tension.reshape(arms.shape + (-1,)).max(axis=-1)
    ua, ub = a["unsolved"].astype(bool), b["unsolved"].astype(bool)
    ua, ub = ua.reshape(arms.shape + (-1,)).any(axis=-1), ub.reshape(arms.shape + (-1,)).any(axis=-1)
    both, one = ~(ua | ub), ua ^ ub
    grid = np.stack(np.meshgrid(*[a[k] for k in AXES], indexing="ij"), axis=-1)
    return {"unsolved": (grid[ua].tolist(), grid[ub].tolist()),
            "arms_mm": float(arms[both].max()), "tension_N": float(tension[both].max()),
            "over_0.1mm": int((arms[both] > 0.1).sum()), "poses": int(both.sum()),
            "one_only": [(p.tolist(), float(d)) for p, d in zip(grid[one], arms[one])]}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("first", type=Path)
    ap.add_argument("second", type=Path, nargs="?", default=Path(TABLE_FOLDER))
    args = ap.parse_args(argv)
    found, status = 0, 0
    for path in sorted(args.first.glob("*_band.npz")):
        other = args.second / path.name
        if not other.exists():
            continue
        found += 1
        r = compare(path, other)
        if r is None:
            print(f"{path.stem}: the grids differ")
            status = 1
            continue
        print(f"{path.stem}: unsolved {r['unsolved'][0]} in {args.first}, {r['unsolved'][1]} in {args.second}; "
              f"at the {r['poses']} poses solved in both: arms within {r['arms_mm']:.3f} mm ({r['over_0.1mm']} over "
              f"0.1 mm), tension within {r['tension_N']:.2f} N"
              + "".join(f"; at {p} (solved in one only) arms {d:.1f} mm apart" for p, d in r["one_only"]))
    if not found:
        print(f"no band table of {args.first} is in {args.second}")
        return 1
    return status


if __name__ == "__main__":
    raise SystemExit(main())
