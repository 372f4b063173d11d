"""What the band's fibres, each at its own length, change in the force (docs/fem.md "The band's fibres"):

    .venv/bin/python benchmarks/band_fibres.py [--tendon T ...] [--folder DIR] [--activation A ...] [--figure PNG]

Over the tasks' pose grid (the fibre tables' poses, no solving), at each tendon's band length there (`band_lines`:
L_MJCF + D) and v = 0: the spread of its fibres' departures from the mean fibre (largest - smallest, mm and optimal
fibre lengths l_opt: median and largest over the grid), and the force of its fibres each at its own length
(`band_fibres.fibre_force`) against the length-keyed law's at the band's one length, as % of F0 at each activation
(default 1 and 0, the latter the passive force): median and largest |difference|, and the mean signed one. --figure:
that difference at a = 1 and a = 0 over plane of elevation x axial rotation at elevation 90 deg for ssc, isp and pec1
(the three that change most), read between the grid poses as the model reads the tables.
"""
from __future__ import annotations

import argparse

import numpy as np

from shoulder_bench import full_arm
from shoulder_bench.authoring.fem import band_fibres, bands
from shoulder_bench.tendon_law import TendonLaw


def study(tendon: str, folder, activations) -> dict:
    table = band_fibres.FibreTable.load(tendon, folder)
    poses = bands.mesh_poses(table.axes_deg)
    law = TendonLaw.load("fem", (tendon,), line_of_action="band")
    length = law.geometry(full_arm.Pose(), poses)[0][:, 0]  # the band's length
    d = table.departure(poses)
    f0, l_opt = float(table.meta["f0_N"]), float(law.tables[0].meta["optimal_fibre_length_m"])
    out = {"spread_mm": np.ptp(d, axis=1) * 1e3, "l_opt_mm": l_opt * 1e3, "force_pct": {}}
    for a in activations:
        ones = np.full(len(poses), a)
        fibres = band_fibres.fibre_force(law, length, d, ones)
        one = law.force(length[:, None], np.zeros((len(poses), 1)), ones[:, None])[:, 0]
        out["force_pct"][a] = 100 * (fibres - one) / f0
    return out


def figure(path: str, folder, tendons=("ssc", "isp", "pec1"), elevation: float = 90.0) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    planes, rotations = np.linspace(0.0, 90.0, 91), np.linspace(-45.0, 60.0, 106)
    pp, rr = np.meshgrid(planes, rotations, indexing="ij")
    poses = np.stack([pp.ravel(), np.full(pp.size, elevation), rr.ravel()], axis=1)
    fig, axes = plt.subplots(2, len(tendons), figsize=(4.0 * len(tendons), 6.4), squeeze=False, constrained_layout=True)
    for col, t in enumerate(tendons):
        table, law = band_fibres.FibreTable.load(t, folder), TendonLaw.load("fem", (t,), line_of_action="band")
        length = law.geometry(full_arm.Pose(), poses)[0][:, 0]  # the band's length
        d = table.departure(poses)
        for row, a in enumerate((1.0, 0.0)):
            at = np.full(len(poses), a)
            one = law.force(length[:, None], np.zeros((len(poses), 1)), at[:, None])[:, 0]
            g = 100 * (band_fibres.fibre_force(law, length, d, at) - one) / float(table.meta["f0_N"])
            g = g.reshape(pp.shape)
            lim = max(np.abs(g).max(), 0.5)  # a flat panel stays flat
            ax = axes[row, col]
            im = ax.pcolormesh(rotations, planes, g, cmap="RdBu_r", vmin=-lim, vmax=lim, shading="auto")
            ax.set_title(f"{t}, elevation {elevation:g} deg, a = {a:g}", fontsize=9)
            ax.set_xlabel("axial rotation (deg, + internal)")
            ax.set_ylabel("plane of elevation (deg)")
            fig.colorbar(im, ax=ax, label="fibres - one length (% of F0)")
    fig.savefig(path, dpi=110)
    print(f"wrote {path}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tendon", nargs="+", default=list(bands.FOOTPRINT_TENDONS))
    ap.add_argument("--folder", default=None, help="the fibre tables' folder (default models/muscles_full)")
    ap.add_argument("--activation", nargs="+", type=float, default=[1.0, 0.0])
    ap.add_argument("--figure", help="write the figure here instead of the table")
    args = ap.parse_args(argv)
    if args.figure:
        figure(args.figure, args.folder)
        return 0
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
