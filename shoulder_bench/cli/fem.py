"""`shoulder-bench fem build|verify` (registered by shoulder_bench.cli through `add_parser`)."""
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


def _verify(args) -> int:
    from shoulder_bench.authoring.fem.verify import verify

    return verify(folder=args.tables, out=args.out, figure=not args.no_figure)


def _convergence(args) -> int:
    from shoulder_bench.authoring.fem.verify import convergence

    convergence(args.muscle)
    return 0


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser("fem", help="build or verify the FEM muscle tables")
    sub = p.add_subparsers(dest="fem_command", required=True)
    b = sub.add_parser("build", help="solve the muscle sheets over the grid and write models/muscles/<m>_fem.npz")
    b.add_argument("--muscle", type=_muscle, help=f"one of {', '.join(anatomy.MUSCLES)} (default: all)")
    b.add_argument("--coarse", action="store_true", help="coarse meshes (CI); same grid; needs --out")
    b.add_argument("--out", type=Path, default=None, help="output folder, created if missing (default: models/muscles)")
    b.set_defaults(func=_build)
    v = sub.add_parser("verify", help="re-solve held-out points, compare MuJoCo's torque with the FEM's, check "
                       "literature bands, draw the figure; exit status 1 when any check fails")
    v.add_argument("--tables", type=Path, default=None, help="folder of the tables (default: models/muscles)")
    v.add_argument("--out", type=Path, default=None,
                   help="folder for the figure muscle_torques.png (default: the current directory)")
    v.add_argument("--no-figure", action="store_true")
    v.set_defaults(func=_verify)
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
