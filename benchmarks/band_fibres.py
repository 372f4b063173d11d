"""What the band's fibres, each at its own length, change in the force (docs/fem.md "The band's fibres"):

    .venv/bin/python benchmarks/band_fibres.py [--tendon T ...] [--folder DIR] [--activation A ...]

Over the tasks' pose grid (the fibre tables' poses, no solving), at each tendon's band length there (`band_lines`:
L_MJCF + D) and v = 0: the spread of its fibres' departures from the mean fibre (largest - smallest, mm and optimal
fibre lengths l_opt: median and largest over the grid), and the force of its fibres each at its own length
(`band_fibres.fibre_force`) against the length-keyed law's at the band's one length, as % of F0 at each activation
(default 1 and 0, the latter the passive force): median and largest |difference|, and the mean signed one.
"""
from __future__ import annotations

import argparse

import numpy as np

from shoulder_bench import full_arm
from shoulder_bench.authoring.fem import band_fibres, bands
from shoulder_bench.band_lines import BandLines
from shoulder_bench.tendon_law import TendonLaw


def study(tendon: str, folder, activations) -> dict:
    table = band_fibres.FibreTable.load(tendon, folder)
    poses = bands.mesh_poses(table.axes_deg)
    law = TendonLaw.load("fem", (tendon,))
    length = full_arm.Pose().tendon_geometry(poses, (tendon,))[0][:, 0] + \
        BandLines.load((tendon,)).lengthening(poses)[0][:, 0]
    d = table.departure(poses)
    f0, l_opt = float(table.meta["f0_N"]), float(law.tables[0].meta["optimal_fibre_length_m"])
    out = {"spread_mm": np.ptp(d, axis=1) * 1e3, "l_opt_mm": l_opt * 1e3, "force_pct": {}}
    for a in activations:
        ones = np.full(len(poses), a)
        fibres = band_fibres.fibre_force(law, length, d, ones)
        one = law.force(length[:, None], np.zeros((len(poses), 1)), ones[:, None])[:, 0]
        out["force_pct"][a] = 100 * (fibres - one) / f0
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tendon", nargs="+", default=list(bands.FOOTPRINT_TENDONS))
    ap.add_argument("--folder", default=None, help="the fibre tables' folder (default models/muscles_full)")
    ap.add_argument("--activation", nargs="+", type=float, default=[1.0, 0.0])
    args = ap.parse_args(argv)
    print("tendon | fibres' spread, mm: median / largest (l_opt) | " + " | ".join(
        f"fibres vs one length at a = {a:g}, % F0: median |d| / largest |d| / mean d" for a in args.activation))
    for t in args.tendon:
        got = study(t, args.folder, args.activation)
        s = got["spread_mm"]
        cells = [f"{np.median(s):.1f} / {s.max():.1f} ({np.median(s) / got['l_opt_mm']:.3f} / "
                 f"{s.max() / got['l_opt_mm']:.3f})"]
        for a in args.activation:
            f = got["force_pct"][a]
            cells.append(f"{np.median(np.abs(f)):.2f} / {np.abs(f).max():.2f} / {f.mean():+.2f}")
        print(f"{t} | " + " | ".join(cells))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
