"""Is a band table's line of action the gradient of a length, and how far is that length from the MJCF path's?
(docs/fem.md "The band's own length").

A cable on frictionless surfaces pulls with the generalised force -T dL/dq: its moment arms r = -dL/dq are a
gradient field over the pose space, and the same length L keys its force. MuJoCo's tendons are such cables (r_MJCF =
-ten_J S is the exact derivative of ten_length). With `line_of_action="band"` a tendon pulled with F(L_MJCF(q), a)
along the band's arms r_band(q) from the table: the force keyed on the MJCF path's length, the line from the FEM; since
this study the model reads it at L_MJCF + D (`band_lines.band_length`, D below). This script integrates each shipped
band table's arms over its pose grid (least squares over the grid's edges: for the edge from pose i to pose j along
coordinate k, L_j - L_i = -h_k (r_k,i + r_k,j) / 2, h_k the step in rad: `band_lines.integrate_arms`, as the model
does) and prints:

* the control: the MJCF arms of the same table integrated the same way against MuJoCo's own ten_length at the grid
  poses (largest difference, mm): the integration's error;
* the edge residual (RMS and largest, mm) of the band's arms against the MJCF's: what of the band's field is not a
  gradient (the MJCF's residual is the trapezoid rule's error alone);
* D(q) = L_band(q) - L_MJCF(q) as the model reads it (the potential of -(r_band - r_MJCF)), over the grid: its
  range (largest - smallest, mm; no constant fixes it), and that range in optimal fibre lengths l_opt (with the rigid
  tendon of the force tables, a change of the musculotendon length is a change of the fibre length);
* the force the law gives at the band's length against at the MJCF's, the two lengths equal at the footprint sheets'
  reference pose (30, 45, 0, `band_lines.LENGTH_ANCHOR_DEG`): largest |difference| over the grid at a = 1 and a = 0
  (passive), in % of F0;
* with --loop: the work (J) a tendon alone at a = 1 does round a closed path of poses (a rectangle in plane and
  rotation at one elevation, 4 x 200 steps): along its MJCF path (a gradient: zero but for the quadrature), along
  the band's line with the force at the MJCF length, and at the band's (as the model applies it); the work along
  the path's steps summed without sign (the scale); and the circulation of the band's correction round the path (mm
  rad), which no choice of length removes;
* with --solve N: D against the bands themselves, solved at N random poses (`solved_lengths`), and how far the
  band's fibres' length changes from the anchor pose differ across its width (in l_opt: what a law keyed on one
  length cannot see), and what that does to the active force if each fibre were a pennated Hill fibre at its own
  length in series with the rigid tendon (`_active`, the tables' geometry) against all at the band's one length;
* with --figure PNG: D over plane of elevation x axial rotation at elevation 30 and 90 deg (ssc and isp, or --tendon's).

    python benchmarks/band_potential.py [--tendon T ...] [--folder DIR] [--loop ELEVATION PLANE0 PLANE1 ROT0 ROT1]
                                        [--solve N] [--figure PNG]
"""
from __future__ import annotations

import argparse

import numpy as np

from shoulder_bench import full_arm
from shoulder_bench.band_lines import AXES, BAND_TENDONS, BandLines, integrate_arms, read_table, table_path
from shoulder_bench.tendon_law import TendonLaw


def study(tendon: str, folder, pose: full_arm.Pose, law: TendonLaw) -> dict:
    arrays, _ = read_table(table_path(tendon, folder))
    axes = [arrays[k] for k in AXES]
    steps = [np.radians(a[1] - a[0]) for a in axes]
    _, band_res = integrate_arms(arrays["moment_arm_m"], steps)
    mjcf, mjcf_res = integrate_arms(arrays["mjcf_moment_arm_m"], steps)
    poses = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    length = pose.tendon_geometry(poses, (tendon,))[0][:, 0]
    control = mjcf.ravel() - (length - length[0])
    d = BandLines.load((tendon,), folder).lengthening(poses)[0][:, 0]  # D as the model reads it: 0 at the anchor
    column = law.actuators.index(tendon)
    table = law.tables[column]
    forces = {}
    for a in (1.0, 0.0):
        act = np.full((len(poses), len(law.muscles)), a)
        at = np.repeat(length[:, None], len(law.actuators), axis=1)
        f_mjcf = law.force(at, 0.0, act)[:, column]
        at[:, column] += d
        forces[a] = float(np.abs(law.force(at, 0.0, act)[:, column] - f_mjcf).max() / table.meta["F0_N"])
    return {"tendon": tendon, "grid": mjcf.shape, "control_mm": 1e3 * np.abs(control - control.mean()).max(),
            "band_res_mm": 1e3 * np.array([np.sqrt(np.mean(band_res ** 2)), np.abs(band_res).max()]),
            "mjcf_res_mm": 1e3 * np.array([np.sqrt(np.mean(mjcf_res ** 2)), np.abs(mjcf_res).max()]),
            "range_mm": 1e3 * float(d.max() - d.min()),
            "range_lopt": float(d.max() - d.min()) / float(table.meta["optimal_fibre_length_m"]),
            "force_a1": 100 * forces[1.0], "force_a0": 100 * forces[0.0]}


def loop_work(tendon: str, folder, pose: full_arm.Pose, corners, steps: int = 200) -> dict:
    """Work (J) of the tendon alone at a = 1 round the closed path through `corners` (deg), trapezoid rule."""
    q = np.concatenate([np.asarray(a, float) + (np.asarray(b, float) - a) * np.linspace(0, 1, steps, endpoint=False)
                        [:, None] for a, b in zip(corners, corners[1:] + corners[:1])])
    dq = np.radians(np.roll(q, -1, axis=0) - q)
    out = {}
    for name in ("MJCF path", "band, MJCF length", "band, band length"):
        law = TendonLaw.load("fem", (tendon,), line_of_action="mjcf" if name == "MJCF path" else "band")
        if law.lines is not None:
            law.lines = BandLines.load((tendon,), folder)
            if name == "band, MJCF length":
                law.lines.lengths[:] = 0.0
        length, r = law.geometry(pose, q)
        gen = law.force(length, np.zeros_like(length), np.ones((len(q), 1)))[:, :1] * r[:, 0]
        step = (gen + np.roll(gen, -1, axis=0)) / 2 * dq
        out[name] = float(np.sum(step))
        if name == "band, band length":  # the scale: the work done along the path's steps, summed without sign
            out["|work| along the path"] = float(np.abs(step).sum())
    c = BandLines.load((tendon,), folder).correction(q)[:, 0]
    out["circulation_mm_rad"] = 1e3 * float(np.sum((c + np.roll(c, -1, axis=0)) / 2 * dq))
    return out


def solved_lengths(tendon: str, folder, poses_deg) -> dict:
    """D(q) - D(anchor) as the model reads it against the solved band's own: at each pose the band solved (full
    resolution, its table's contact surface, rest="pose", a = 1), its fibres' lengths from the nodes (the central
    fibre's and the mean over the width) plus the path beyond P, less the MJCF tendon's length, each less its value at
    the anchor pose (mm)."""
    from shoulder_bench.authoring.fem import bands
    from shoulder_bench.authoring.fem.footprint import FootprintSheet
    from shoulder_bench.band_lines import LENGTH_ANCHOR_DEG

    sheet = FootprintSheet(tendon, "full", surface=bands.surface(tendon), rest="pose")
    poses = np.vstack([LENGTH_ANCHOR_DEG, np.atleast_2d(poses_deg)])
    central, mean, spread = [], [], []
    for q in poses:
        x = sheet.solve(tuple(q))["nodes"].reshape(sheet.ns, sheet.nt, 3)
        fibres = np.linalg.norm(np.diff(x, axis=0), axis=2).sum(axis=0)  # (nt,) each fibre's length
        beyond = sheet.beyond_length()
        central.append(fibres[sheet.nt // 2] + beyond)
        mean.append(fibres.mean() + beyond)
        spread.append(fibres)
    mjcf = full_arm.Pose().tendon_geometry(poses, (tendon,))[0][:, 0]
    model = BandLines.load((tendon,), folder).lengthening(poses)[0][:, 0]
    out = {"model": model[1:] - model[0]}
    for name, own in (("central fibre", np.array(central)), ("mean fibre", np.array(mean))):
        d = own - mjcf
        out[name] = d[1:] - d[0]
    out = {k: 1e3 * v for k, v in out.items()}
    change = np.array(spread[1:]) - spread[0]  # each fibre's length change from the anchor pose
    meta = TendonLaw.load("fem", (tendon,)).tables[0].meta
    l_opt = meta["optimal_fibre_length_m"]
    out["spread_lopt"] = np.ptp(change, axis=1) / l_opt
    # each fibre at its own length (the band's model length plus its change's departure from the band's mean), a
    # pennated Hill fibre in series with the rigid tendon, against all at the band's one length: active force, % F0
    length = (mjcf + model)[1:, None] + (change - change.mean(axis=1, keepdims=True))
    out["per_fibre_pct"] = 100 * np.abs(_active(length, meta).mean(axis=1) - _active((mjcf + model)[1:], meta))
    return out


def _active(length_mt, meta) -> np.ndarray:
    """Active axial force / F0 at a = 1 of a pennated fibre (constant thickness) in series with the rigid tendon, at
    musculotendon lengths `length_mt` (m): the length-keyed tables' geometry (`fem.v2_sheet`), Hill's form."""
    from shoulder_bench.authoring.fem.material import f_active

    l_opt, alpha = meta["optimal_fibre_length_m"], meta["pennation_angle_rad"]
    axial = (np.asarray(length_mt) - meta["tendon_slack_length_m"]) / l_opt
    fibre = np.sqrt(axial ** 2 + np.sin(alpha) ** 2)
    return f_active(fibre) * axial / fibre


def figure(path: str, folder, tendons=("ssc", "isp"), elevations=(30.0, 90.0)) -> None:
    """D (mm) as the model reads it over plane of elevation x axial rotation, at `elevations`, for `tendons`."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    lines = BandLines.load(tuple(tendons), folder)
    planes, rotations = np.linspace(0.0, 90.0, 91), np.linspace(-45.0, 60.0, 106)
    fig, axes = plt.subplots(len(tendons), len(elevations), figsize=(4.2 * len(elevations), 3.4 * len(tendons)),
                             squeeze=False, constrained_layout=True)
    for row, t in enumerate(tendons):
        grids = []
        for e in elevations:
            pp, rr = np.meshgrid(planes, rotations, indexing="ij")
            poses = np.stack([pp.ravel(), np.full(pp.size, e), rr.ravel()], axis=1)
            grids.append(1e3 * lines.lengthening(poses)[0][:, row].reshape(pp.shape))
        lim = max(np.abs(g).max() for g in grids)
        for col, (e, g) in enumerate(zip(elevations, grids)):
            ax = axes[row, col]
            im = ax.pcolormesh(rotations, planes, g, cmap="RdBu_r", vmin=-lim, vmax=lim, shading="auto")
            ax.set_title(f"{t}, elevation {e:g} deg (D = 0 at (30, 45, 0))", fontsize=9)
            ax.set_xlabel("axial rotation (deg, + internal)")
            ax.set_ylabel("plane of elevation (deg)")
        fig.colorbar(im, ax=axes[row].tolist(), label="D = L_band - L_MJCF (mm)")
    fig.savefig(path, dpi=110)
    print(f"wrote {path}")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--tendon", action="append", choices=BAND_TENDONS)
    p.add_argument("--folder", default=None, help="the band tables' folder (default: the shipped ones)")
    p.add_argument("--loop", nargs=5, type=float, metavar=("ELEVATION", "PLANE0", "PLANE1", "ROT0", "ROT1"))
    p.add_argument("--solve", type=int, metavar="N", help="check D against N bands solved at random poses")
    p.add_argument("--figure", metavar="PNG", help="plot D of ssc and isp (or --tendon's) over plane x rotation")
    args = p.parse_args(argv)
    if args.figure:
        figure(args.figure, args.folder, tuple(args.tendon or ("ssc", "isp")))
        return 0
    pose, law = full_arm.Pose(), TendonLaw.load()
    tendons = args.tendon or BAND_TENDONS
    if args.solve:
        lo, hi = np.array([0.0, 0.0, -45.0]), np.array([90.0, 140.0, 60.0])
        poses = lo + (hi - lo) * np.random.default_rng(0).random((args.solve, 3))
        print(f"D(q) - D(30, 45, 0) (mm): the model's against the solved band's, at {args.solve} random poses (seed 0)")
        for t in tendons:
            got = solved_lengths(t, args.folder, poses)
            for name in ("central fibre", "mean fibre"):
                e = got[name] - got["model"]
                print(f"{t:>6} vs {name:<13}: model range {np.ptp(got['model']):6.2f}, difference RMS "
                      f"{np.sqrt(np.mean(e ** 2)):5.2f} largest {np.abs(e).max():5.2f}")
            print(f"{t:>6} fibres' length change from the anchor across the band: largest - smallest "
                  f"{np.median(got['spread_lopt']):.3f} l_opt (median over the poses), up to "
                  f"{got['spread_lopt'].max():.3f} l_opt; each fibre at its own length against all at one: active "
                  f"force {np.median(got['per_fibre_pct']):.2f} % of F0 (median), up to "
                  f"{got['per_fibre_pct'].max():.2f} %")
        return 0
    if args.loop:
        e, p0, p1, r0, r1 = args.loop
        corners = [(p0, e, r0), (p1, e, r0), (p1, e, r1), (p0, e, r1)]
        print(f"work at a = 1 round plane {p0:g}-{p1:g}, rotation {r0:g}-{r1:g} deg at elevation {e:g} deg (J)")
        for t in tendons:
            w = loop_work(t, args.folder, pose, corners)
            print(f"{t:>6} " + "  ".join(f"{k} {v:.4f}" for k, v in w.items()))
        return 0
    print(f"{'tendon':>6} {'grid':>12} {'control':>8} {'band residual':>15} {'MJCF residual':>15} "
          f"{'D range':>8} {'/ l_opt':>7} {'dF a=1':>7} {'dF a=0':>7}")
    print(f"{'':>6} {'':>12} {'(mm)':>8} {'RMS / max (mm)':>15} {'RMS / max (mm)':>15} {'(mm)':>8} {'':>7} "
          f"{'(% F0)':>7} {'(% F0)':>7}")
    for t in tendons:
        s = study(t, args.folder, pose, law)
        print(f"{t:>6} {'x'.join(map(str, s['grid'])):>12} {s['control_mm']:8.3f} "
              f"{s['band_res_mm'][0]:7.3f} /{s['band_res_mm'][1]:6.2f} {s['mjcf_res_mm'][0]:7.3f} /"
              f"{s['mjcf_res_mm'][1]:6.2f} {s['range_mm']:8.2f} {s['range_lopt']:7.3f} {s['force_a1']:7.1f} "
              f"{s['force_a0']:7.1f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
