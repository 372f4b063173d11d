"""What the parent's compliant tendon in series changes (`tendon="compliant"`; docs/fem.md "A compliant tendon in
series"):

    .venv/bin/python benchmarks/tendon_compliance.py [--tendon T ...] [--refine K] [--figure PNG]

Per tendon of the full shoulder: the compliant table read between its knots and levels against the equilibrium solved
there exactly (`tendon_compliance.interpolation_error`, % of F0; exit 1 over BOUND_PCT; --refine K: on a length grid
K times finer than the rigid table's, default the law's `tendon_compliance.REFINE`); and over the tasks' pose grid on
the MJCF paths (v = 0): the tendon's stretch at a = 1 (mm, and as a fraction of l_opt: how much shorter the fibres
are), and the compliant law's force against the rigid one's at a = 1 and a = 0 (% of F0: median and largest
|difference|, and the mean signed one); and the relaxed arm's rest angle along elevation in the coronal and the
scapular plane (activations 0, rotation 0, girdle coupled: `model validate`'s force section on the FEM tables,
`forces_full.section`) with either tendon; and what the law leaves out, the fibre's own lengthening rate: along the
test set's targets (their poses and rates on the MJCF paths), the fibre's share phi = 1 / (1 + F_r' s') of the path's
rate (F_r' the sheet's stiffness, s' the tendon's compliance, at a = 1) and how much the force at a = 1 would change
if the force-velocity factor read phi L' instead of L'. No solving beyond the tables; about 20 s. --figure: force
against musculotendon length, rigid and compliant, at a = 1 and 0 for the four tendons whose active force changes
most (by the largest change), the lengths the tasks' grid reaches shaded.
"""
from __future__ import annotations

import argparse

import numpy as np

from shoulder_bench import full_arm, tendon_compliance
from shoulder_bench.authoring.fem import bands
from shoulder_bench.tendon_law import TendonLaw, TendonTable, table_path

BOUND_PCT = 0.5  # the compliant table's read against the exact equilibrium, % of F0
FIGURE_TENDONS = ("cor", "dmi", "dan", "pec3")


def study(tendons, refine: int = tendon_compliance.REFINE) -> dict:
    poses = bands.mesh_poses(bands.axes(None))  # the tasks' grid (plane x elevation x rotation)
    lengths = full_arm.Pose().tendon_geometry(poses, tendons)[0]
    rigid, compliant = TendonLaw.load("fem", tendons), TendonLaw.load("fem", tendons, tendon="compliant")
    still = np.zeros_like(lengths)
    force = {(law, a): law.force(lengths, still, np.full(lengths.shape, a)) for law in (rigid, compliant)
             for a in (1.0, 0.0)}
    out = {}
    for c, t in enumerate(tendons):
        table = rigid.tables[c]
        f0, l_opt = float(table.meta["F0_N"]), float(table.meta["optimal_fibre_length_m"])
        soft = tendon_compliance.compliant_table(table, refine)
        out[t] = {"error": tendon_compliance.interpolation_error(table, soft),
                  "force_pct": {a: 100 * (force[compliant, a][:, c] - force[rigid, a][:, c]) / f0 for a in (1.0, 0.0)},
                  "stretch_mm": 1e3 * tendon_compliance.stretch(table, force[compliant, 1.0][:, c]),
                  "l_opt_mm": 1e3 * l_opt}
    return out


def fibre_rate(tendons, every: int = 4) -> dict:
    """{tendon: (phi (P,), force change % of F0 (P,))} at a = 1 along the test set's targets (every `every`-th
    frame): the fibre's share phi of the path's lengthening rate with the compliant tendon, and the compliant law's
    force with the force-velocity factor at phi L' less that at L' (what the law, reading L', leaves out)."""
    from shoulder_bench import trajectory3

    test = trajectory3.load_test_set()
    poses = np.concatenate([t.angle_deg[::every] for t in test])
    rates = np.radians(np.concatenate([t.velocity_deg_s[::every] for t in test]))
    lengths, arms = full_arm.Pose().tendon_geometry(poses, tendons)
    speed = -np.einsum("pnk,pk->pn", arms, rates)  # the paths' lengthening rates, m/s
    law = TendonLaw.load("fem", tendons, tendon="compliant")
    ones = np.ones_like(lengths)
    force = law.force(lengths, np.zeros_like(lengths), ones)
    out, h = {}, 1e-5
    for c, t in enumerate(tendons):
        table = TendonTable.load(table_path(t, "fem"))
        fn, eps = tendon_compliance.strain_curve(table.meta["parent_muscle"])
        f0 = float(table.meta["F0_N"])
        sheet = lengths[:, c] - tendon_compliance.stretch(table, force[:, c])
        stiffness = (tendon_compliance.read(table, sheet + h, 1.0)
                     - tendon_compliance.read(table, sheet - h, 1.0)) / (2 * h)  # N/m
        f = force[:, c] / f0
        slope = (np.interp(f + 1e-6, fn, eps) - np.interp(f, fn, eps)) / 1e-6  # d strain / d (F / F0)
        compliance = float(table.meta["tendon_slack_length_m"]) * slope / f0  # m/N
        out[t] = [1.0 / (1.0 + stiffness * compliance)]
    shared = speed * np.stack([out[t][0] for t in tendons], axis=1)
    change = law.force(lengths, shared, ones) - law.force(lengths, speed, ones)
    for c, t in enumerate(tendons):
        out[t].append(100 * change[:, c] / float(law.tables[c].meta["F0_N"]))
    return out


def rest(model_path: str = "models/shoulder_full.xml") -> dict:
    """{tendon: {plane deg: (relaxed rest deg, largest net passive elevation torque over 0-20 deg, N m)}} on the FEM
    tables with the rigid and the compliant tendon, as `shoulder-bench model validate --model models/shoulder_full.xml`
    shows them."""
    from shoulder_bench.authoring import forces_full, references
    from shoulder_bench.authoring.validate_full import MUSCLES
    from shoulder_bench.model import compile_model

    model, refs = compile_model(model_path), references.load()
    out = {}
    for tendon in tendon_compliance.TENDONS:
        law = TendonLaw.load("fem", groups=full_arm.ACTUATORS, tendon=tendon)
        section = forces_full.section(model, {m: tuple(references.FULL_TENDONS[m]) for m in MUSCLES}, refs, law)
        out[tendon] = {p: (v["fem"]["relaxed_rest_deg"], v["fem"]["passive_max_Nm"]["shoulder_elv"])
                       for p, v in section.items()}
    return out


def figure(path: str, tendons=FIGURE_TENDONS) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    poses = bands.mesh_poses(bands.axes(None))
    reach = full_arm.Pose().tendon_geometry(poses, tendons)[0]
    fig, axes = plt.subplots(1, len(tendons), figsize=(3.6 * len(tendons), 3.4), constrained_layout=True)
    for ax, t, lo, hi in zip(axes, tendons, reach.min(axis=0), reach.max(axis=0)):
        table = TendonTable.load(table_path(t, "fem"))
        soft = tendon_compliance.compliant_table(table)
        x = soft.length_m
        ax.axvspan(1e3 * lo, 1e3 * hi, color="0.9", label="tasks' grid")
        for a, style in ((1.0, "-"), (0.0, "--")):
            ax.plot(1e3 * x, tendon_compliance.read(table, x, a), "k" + style, lw=1.0, label=f"rigid, a = {a:g}")
            ax.plot(1e3 * x, tendon_compliance.read(soft, x, a), "C3" + style, lw=1.0, label=f"compliant, a = {a:g}")
        ax.set_title(f"{t} (F0 {table.meta['F0_N']:g} N, l_ts {1e3 * table.meta['tendon_slack_length_m']:g} mm)",
                     fontsize=9)
        ax.set_xlabel("musculotendon length (mm)")
        ax.set_ylabel("force (N)")
    axes[0].legend(fontsize=7)
    fig.savefig(path, dpi=110)
    print(f"wrote {path}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tendon", nargs="+", default=list(full_arm.TENDONS), choices=full_arm.TENDONS)
    ap.add_argument("--refine", type=int, default=tendon_compliance.REFINE,
                    help="the checked table's length knots per rigid knot interval")
    ap.add_argument("--figure", help="write the figure here instead of the table")
    args = ap.parse_args(argv)
    if args.refine < 1:
        ap.error(f"--refine must be an integer >= 1; got {args.refine}")
    if args.figure:
        figure(args.figure)
        return 0
    rows = study(tuple(args.tendon), args.refine)
    print("tendon | table vs exact, % F0 (at length mm, a) | stretch at a = 1, mm: median / largest (l_opt) | "
          "force change a = 1, % F0: median / largest / mean | a = 0: median / largest / mean")
    worst = 0.0
    for t, r in rows.items():
        e, s = r["error"], r["stretch_mm"]
        worst = max(worst, 100 * e["max_F0"])
        cells = [f"{100 * e['max_F0']:.3f} ({1e3 * e['at'][0]:.1f}, {e['at'][1]:g})",
                 f"{np.median(s):.2f} / {s.max():.2f} ({s.max() / r['l_opt_mm']:.3f})"]
        for a in (1.0, 0.0):
            d = r["force_pct"][a]
            cells.append(f"{np.median(np.abs(d)):.2f} / {np.abs(d).max():.2f} / {d.mean():+.2f}")
        print(f"{t} | " + " | ".join(cells))
    print(f"largest table error {worst:.3f} % of F0 (bound {BOUND_PCT:g} %)")
    print("the fibre's own rate (test-set targets, a = 1): tendon | share phi of the path's rate: median / least | "
          "force change if FV read it, % F0: median |d| / largest |d|")
    for t, (phi, d) in fibre_rate(tuple(args.tendon)).items():
        print(f"{t} | {np.median(phi):.3f} / {phi.min():.3f} | {np.median(np.abs(d)):.3f} / {np.abs(d).max():.3f}")
    relaxed = rest()
    for p, (r_deg, r_nm) in relaxed["rigid"].items():
        c_deg, c_nm = relaxed["compliant"][p]
        print(f"plane {p:g} deg, activations 0: relaxed rest {r_deg:.1f} deg rigid, {c_deg:.1f} deg compliant; "
              f"largest net passive elevation torque over 0-20 deg {r_nm:+.2f} / {c_nm:+.2f} N m")
    return 0 if worst <= BOUND_PCT else 1


if __name__ == "__main__":
    raise SystemExit(main())
