"""`shoulder-bench fem build|verify|footprint|convergence` (registered by shoulder_bench.cli through `add_parser`)."""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from shoulder_bench.authoring import anatomy


def _muscle(name: str) -> str:
    if name not in anatomy.MUSCLES:
        raise argparse.ArgumentTypeError(f"unknown muscle {name!r}; valid names: {', '.join(anatomy.MUSCLES)}")
    return name


def _build(args) -> int:
    if args.variant and not args.full:
        raise SystemExit("shoulder-bench fem build: error: --variant is for --full (the v2 arm's variant tables: "
                         "python -m shoulder_bench.authoring.fem.v2 --variant ld_transfer)")
    if args.fibres:
        return _build_fibres(args)
    if args.bands:
        return _build_bands(args)
    if args.full:
        return _build_full(args)
    if args.jobs != 1:
        raise SystemExit("shoulder-bench fem build: error: --jobs is for --full")
    from shoulder_bench.authoring.fem.build import build

    muscles = (args.muscle,) if args.muscle else anatomy.MUSCLES
    t0 = time.perf_counter()
    metas = build(muscles, coarse=args.coarse, out=args.out)
    for m, meta in metas.items():
        note = ""
        if meta["force_interpolated_deg"]:
            note = (f"  force interpolated near zero moment arm at {meta['force_interpolated_deg']} deg "
                    f"(MuJoCo torque off the FEM by <= {meta['max_torque_mismatch_Nm']:.2f} N m there)")
        how = ("solved" if not meta["cached"] else "inputs unchanged, moment arms refreshed" if meta["written"]
               else "up to date, nothing to do")
        print(f"{m}: {meta['resolution']} mesh, {how} ({meta['build_seconds']:.1f} s to solve){note}")
    print(f"total {time.perf_counter() - t0:.1f} s")
    return 0


def _build_full(args) -> int:
    from shoulder_bench.authoring.fem import full
    from shoulder_bench.full_arm import TENDONS

    if args.muscle:
        raise SystemExit("shoulder-bench fem build: error: --muscle is for the v1 tables; with --full give "
                         f"--tendon (one of {', '.join(TENDONS)})")
    t0 = time.perf_counter()
    try:
        metas = full.build(coarse=args.coarse, out=args.out, jobs=args.jobs,
                           tendons_=tuple(args.tendon) if args.tendon else None, geometry=args.variant)
    except ValueError as exc:
        raise SystemExit(f"shoulder-bench fem build: error: {exc}") from None
    for t, m in metas.items():
        n, lam = m["newton_iterations"], m["fibre_stretch_range"]
        how = "up to date, nothing to do" if m["cached"] else "solved"
        print(f"{t}: {m['sheet']['resolution']} sheet, {how} ({m['build_seconds']:.1f} s to solve; Newton "
              f"{n['total']} iterations, <= {n['max_per_point']} per point, {m['tolerance']}; fibre stretch "
              f"{lam[0]:.3f}-{lam[1]:.3f})")
    print(f"total {time.perf_counter() - t0:.1f} s")
    return 0


def _build_bands(args) -> int:
    from shoulder_bench.authoring.fem import band_levels, bands

    if args.muscle or args.full:
        raise SystemExit("shoulder-bench fem build: error: --bands builds the footprint sheets' line-of-action tables "
                         f"of {', '.join(bands.FOOTPRINT_TENDONS)}: give --tendon, not --muscle or --full")
    t0 = time.perf_counter()
    try:
        tendons = tuple(args.tendon) if args.tendon else bands.FOOTPRINT_TENDONS
        metas = bands.build(tendons, coarse=args.coarse, out=args.out, jobs=args.jobs)
        levels = band_levels.build(tendons, coarse=args.coarse, out=args.out, jobs=args.jobs)
    except (ValueError, RuntimeError) as exc:
        raise SystemExit(f"shoulder-bench fem build: error: {exc}") from None
    for t, m in metas.items():
        how = "up to date, nothing to do" if m["cached"] else "solved"
        if not m["cached"] and m.get("reused_poses"):
            how += f" but {m['reused_poses']} poses taken from the table it replaces"
        if not m["cached"] and m.get("resumed_poses"):
            how += f", {m['resumed_poses']} poses from the interrupted build it resumes"
        big = ", ".join(f"{k} {v:.1f}" for k, v in m["largest_correction_mm"].items())
        print(f"{t}: {m['resolution']} band, {how} ({m['build_seconds']:.1f} s to solve; largest correction to the "
              f"MJCF arms, mm: {big}; tension {m['tension_range_N'][0]:.0f}-{m['tension_range_N'][1]:.0f} N)")
    for t, m in levels.items():
        how = "up to date, nothing to do" if m["cached"] else "solved"
        moves = ", ".join(f"a = {a:g} " + " / ".join(f"{x:.2f}" for x in d)
                          for a, d in zip(m["levels"][1:], m["largest_move_mm"]))
        print(f"{t}: its band below a = 1 on the tasks' grid, {how} ({m['build_seconds']:.1f} s to solve; largest "
              f"move of its arms from a = 1, plane / elevation / rotation, mm: {moves})")
    print(f"total {time.perf_counter() - t0:.1f} s")
    return 0


def _build_fibres(args) -> int:
    from shoulder_bench.authoring.fem import band_fibres, bands

    if args.muscle or args.full or args.bands or args.coarse:
        raise SystemExit("shoulder-bench fem build: error: --fibres builds the taut bands' fibre tables on the full "
                         "sheets: give --tendon, --jobs, --out only")
    t0 = time.perf_counter()
    try:
        metas = band_fibres.build(tuple(args.tendon) if args.tendon else bands.FOOTPRINT_TENDONS,
                                  out=args.out, jobs=args.jobs)
    except (ValueError, RuntimeError) as exc:
        raise SystemExit(f"shoulder-bench fem build: error: {exc}") from None
    for t, m in metas.items():
        how = "up to date, nothing to do" if m["cached"] else "solved"
        if not m["cached"] and m.get("band_poses"):
            how += f" but {m['band_poses']} poses taken from its band table"
        print(f"{t}: fibre table, {how} ({m['build_seconds']:.1f} s to solve; largest departure from the mean fibre "
              f"{m['largest_departure_mm']:.2f} mm; {len(m['unsolved_poses_deg'])} unsolved poses)")
    print(f"total {time.perf_counter() - t0:.1f} s")
    return 0


def _verify(args) -> int:
    if args.variant and not args.full:
        raise SystemExit("shoulder-bench fem verify: error: --variant is for --full (the v2 arm's variant tables: "
                         "python -m shoulder_bench.authoring.fem.v2 --variant ld_transfer)")
    if args.fibres:
        from shoulder_bench.authoring.fem import band_fibres, bands

        if args.bands or args.full or args.activation or args.interpolation != "linear":
            raise SystemExit("shoulder-bench fem verify: error: --fibres goes with --tendon, --held-out, --jobs, "
                             "--tables only")
        if (args.held_out is not None and args.held_out < 1) or args.jobs < 1:
            raise SystemExit("shoulder-bench fem verify: error: --held-out and --jobs must be >= 1")
        try:
            return band_fibres.verify(tuple(args.tendon) if args.tendon else bands.FOOTPRINT_TENDONS,
                                      args.tables, args.held_out, args.jobs)
        except (ValueError, RuntimeError) as exc:
            raise SystemExit(f"shoulder-bench fem verify: error: {exc}") from None
    if args.bands:
        from shoulder_bench.authoring.fem import band_verify, bands

        if args.held_out is not None and args.held_out < 0:
            raise SystemExit(f"shoulder-bench fem verify: error: --held-out must be >= 0, not {args.held_out}")
        if args.jobs < 1:
            raise SystemExit(f"shoulder-bench fem verify: error: --jobs must be >= 1, not {args.jobs}")
        unknown = [t for t in args.tendon or () if t not in bands.FOOTPRINT_TENDONS]
        if unknown:
            raise SystemExit(f"shoulder-bench fem verify: error: no band table for {', '.join(unknown)}; choose from "
                             f"{', '.join(bands.FOOTPRINT_TENDONS)}")
        try:
            return band_verify.verify(folder=args.tables, tendons=args.tendon, interpolation=args.interpolation,
                                      count=args.held_out, jobs=args.jobs, activations=args.activation or ())
        except ValueError as exc:  # a missing or unreadable table, a level outside (0, 1]
            raise SystemExit(f"shoulder-bench fem verify: error: {exc}") from None
    if args.held_out is not None or args.tendon or args.interpolation != "linear" or args.jobs != 1 or args.activation:
        raise SystemExit("shoulder-bench fem verify: error: --tendon, --held-out, --interpolation, --jobs and "
                         "--activation go with --bands")
    if args.full:
        from shoulder_bench.authoring.fem.verify_full import verify as verify_full

        try:
            return verify_full(folder=args.tables, coarse=args.coarse, geometry=args.variant)
        except ValueError as exc:
            raise SystemExit(f"shoulder-bench fem verify: error: {exc}") from None
    from shoulder_bench.authoring.fem.verify import verify

    return verify(folder=args.tables, out=args.out, figure=not args.no_figure)


def _convergence(args) -> int:
    from shoulder_bench.authoring.fem.verify import convergence

    convergence(args.muscle)
    return 0


def _footprint(args) -> int:
    from shoulder_bench.authoring.fem.footprint import TENDONS
    from shoulder_bench.authoring.fem.footprint_report import run

    unknown = [t for t in args.tendon or () if t not in TENDONS]
    if unknown:
        raise SystemExit(f"shoulder-bench fem footprint: error: no footprint sheet for {', '.join(unknown)}; "
                         f"choose from {', '.join(TENDONS)}")
    if args.out is not None and args.out.exists() and not args.out.is_dir():
        raise SystemExit(f"shoulder-bench fem footprint: error: --out {args.out} is a file, not a folder")
    if args.activation and args.grid:
        raise SystemExit("shoulder-bench fem footprint: error: give --activation or --grid, not both")
    if args.refine != 1 and not args.grid:
        raise SystemExit("shoulder-bench fem footprint: error: --refine goes with --grid")
    if args.refine < 1:
        raise SystemExit(f"shoulder-bench fem footprint: error: --refine must be a whole number >= 1, "
                         f"not {args.refine}")
    if args.activation and args.rest != "reference":
        raise SystemExit("shoulder-bench fem footprint: error: --activation goes with --rest reference (a taut band "
                         "relaxed to a = 0 pulls nothing: its line of action is not defined there)")
    extra = {"refine": args.refine} if args.grid else {}
    if not args.activation:
        extra["rest"] = args.rest
    if args.activation:  # the line of action and linearity over activations (footprint_activation)
        from shoulder_bench.authoring.fem.footprint_activation import run
    if args.grid:  # a torque table on the tasks' pose grid against held-out re-solves (footprint_grid)
        from shoulder_bench.authoring.fem.footprint_grid import run
    run(tuple(args.tendon) if args.tendon else TENDONS, "coarse" if args.coarse else "full", args.out, args.surface,
        **extra)
    return 0


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser("fem", help="build or verify the FEM muscle tables")
    sub = p.add_subparsers(dest="fem_command", required=True)
    b = sub.add_parser("build", help="solve the muscle sheets over the grid and write models/muscles/<m>_fem.npz")
    b.add_argument("--muscle", type=_muscle, help=f"one of {', '.join(anatomy.MUSCLES)} (default: all)")
    b.add_argument("--coarse", action="store_true", help="coarse meshes (CI); same grid; needs --out")
    b.add_argument("--out", type=Path, default=None,
                   help="output folder, created if missing (default: models/muscles, with --full models/muscles_full)")
    b.add_argument("--full", action="store_true",
                   help="the full shoulder's 15 tendons over the 3-DOF pose space (models/muscles_full)")
    b.add_argument("--tendon", action="append", help="with --full or --bands: only this tendon (repeatable; default "
                   "all)")
    b.add_argument("--bands", action="store_true", help="the footprint sheets' line-of-action tables (taut bands) of "
                   "ssp, isp, tmi, tma, pec1, pec2, pec3, dpo, dan, ld1-3 over the 3-DOF pose grid "
                   "(models/muscles_full/<t>_band.npz)")
    b.add_argument("--fibres", action="store_true", help="the taut bands' fibre tables: each fibre's length change "
                   "less the mean fibre's over the tasks' pose grid (models/muscles_full/<t>_fibres.npz; read with "
                   "line_of_action=band_fibres)")
    b.add_argument("--jobs", type=int, default=1, help="with --full: solve this many tendons at once (processes); "
                   "with --bands or --fibres: this many processes solve each tendon's poses")
    b.add_argument("--variant", choices=("ld_transfer",), default=None, help="with --full: a rerouted geometry's "
                   "tendons (ld_transfer: ld1-3 on models/shoulder_full_task_ld_transfer.xml, re-tensioned, into "
                   "models/muscles_full_ld_transfer; docs/surgery.md)")
    b.set_defaults(func=_build)
    v = sub.add_parser("verify", help="re-solve held-out points, compare MuJoCo's torque with the FEM's, check "
                       "literature bands, draw the figure; exit status 1 when any check fails")
    v.add_argument("--tables", type=Path, default=None, help="folder of the tables (default: models/muscles)")
    v.add_argument("--out", type=Path, default=None,
                   help="folder for the figure muscle_torques.png (default: the current directory)")
    v.add_argument("--no-figure", action="store_true")
    v.add_argument("--full", action="store_true", help="the full shoulder's tables (default folder "
                   "models/muscles_full): held-out poses re-solved, MuJoCo vs FEM over the 3-DOF pose grid")
    v.add_argument("--coarse", action="store_true", help="with --full: re-solve on coarse sheets (coarse tables)")
    v.add_argument("--variant", choices=("ld_transfer",), default=None, help="with --full: a rerouted geometry's "
                   "tables (ld_transfer: ld1-3 in models/muscles_full_ld_transfer) on its model")
    v.add_argument("--bands", action="store_true", help="the band tables (default folder models/muscles_full): the "
                   "taut bands re-solved at held-out poses against the tables")
    v.add_argument("--fibres", action="store_true", help="the fibre tables: the taut bands re-solved at the tasks' "
                   "grid's cell centres, the fibre force from the tables against theirs at a = 1 and 0 (within 2 %% "
                   "of F0)")
    v.add_argument("--tendon", action="append", help="with --bands or --fibres: only this tendon (repeatable)")
    v.add_argument("--held-out", type=int, default=None, metavar="N",
                   help="with --bands: N held-out poses per tendon drawn with a fixed seed (default: all of its "
                   "table grid's, 588 on the tasks' grid; 0: none, only the check of what MuJoCo applies)")
    v.add_argument("--jobs", type=int, default=1, help="with --bands: this many processes re-solve the held-out "
                   "poses")
    v.add_argument("--activation", type=float, action="append", metavar="A",
                   help="with --bands: also check at this activation level in (0, 1] (repeatable), the band taken "
                   "down from a = 1 level by level, the least energy of the continued and the ramped equilibrium "
                   "(the tables hold its line at a = 1, tma's level table below it)")
    v.add_argument("--interpolation", choices=("linear", "cubic"), default="linear",
                   help="with --bands: the tables read trilinearly (the scheme) or by a tricubic spline")
    v.set_defaults(func=_verify)
    f = sub.add_parser("footprint", help="footprint sheets (ssp, isp, ssc, tmi, tma, pec1, pec2, pec3, dmi, dpo) "
                       "solved in 3-D with contact: their moment arms beside the MJCF tendons' over 72 poses "
                       "(docs/fem.md)")
    f.add_argument("--tendon", action="append", help="only this tendon (repeatable; default all)")
    f.add_argument("--coarse", action="store_true", help="coarse sheets (15 x 5 nodes instead of 31 x 9)")
    f.add_argument("--out", type=Path, default=None, help="folder for footprint.json and footprint_moment_arms.png")
    f.add_argument("--surface", choices=("wrap", "head"), default="wrap",
                   help="contact with the MJCF's wrap objects (default) or with the humeral head sphere fitted to the "
                   "MoBL parent's humerus (ssp, isp, dmi, dpo; footprint_head.json)")
    f.add_argument("--activation", action="store_true",
                   help="instead: solve at activations 0, 0.25, 0.5, 1 and report how the line of action and the "
                   "torque depend on the activation (footprint_activation.json)")
    f.add_argument("--grid", action="store_true",
                   help="instead: would a table of the torque vector on the tasks' pose grid at a = 0 and 1 meet the "
                   "2 %% bound? held-out cells re-solved (footprint_grid.json)")
    f.add_argument("--refine", type=int, default=1, metavar="K",
                   help="with --grid: the same check on a grid K times finer in every coordinate, in sub-cells of "
                   "the same cells (footprint_grid_refineK.json)")
    f.add_argument("--rest", choices=("reference", "pose"), default="reference",
                   help="the sheet's stress-free state: its shape at the reference pose, carried to each pose by a "
                   "walk (default), or its shape at each pose it is solved at (the taut band: every fibre at its "
                   "optimal length; *_taut.json); with the report and --grid")
    f.set_defaults(func=_footprint)
    c = sub.add_parser("convergence", help="mesh-refinement study of the torque at a few points (slow)")
    c.add_argument("--muscle", type=_muscle, default="ssp")
    c.set_defaults(func=_convergence)
    return p


def main(argv=None) -> int:
    """Stand-alone entry (`python -m shoulder_bench.cli.fem build ...`), same arguments as `shoulder-bench
    fem`."""
    parser = argparse.ArgumentParser(prog="shoulder-bench")
    add_parser(parser.add_subparsers(dest="command", required=True))
    args = parser.parse_args(["fem", *(argv if argv is not None else sys.argv[1:])])
    return args.func(args)


if __name__ == "__main__":
    raise SystemExit(main())
