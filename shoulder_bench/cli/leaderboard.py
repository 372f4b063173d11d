"""`shoulder-bench leaderboard` (`eval.leaderboard`)."""
from __future__ import annotations

from pathlib import Path

from shoulder_bench.eval.leaderboard import collect, load_suites, load_surgery, write


def add_parser(sub) -> None:
    p = sub.add_parser("leaderboard", help="rank runs (or the pretrained agents), the reference and the paper")
    p.add_argument("--runs", type=Path, default=None, help="a folder of runs (runs/<task>/<algo>/<seed>)")
    p.add_argument("--pretrained", action="store_true", help="add the shipped agents' rows next to the runs'")
    p.add_argument("--suite", nargs="+", default=["paper"], metavar="NAME",
                   help="evaluation suites: paper (the fixed test set, always scored and ranked on; the default), "
                        "fast, wide, adl, robust (the paper set under delay, noise, strength and a 1 kg load, on "
                        "top of each row's options), or a folder of CSV files (a hidden suite); each beyond paper "
                        "adds its MAE and its generalisation gap (suite MAE minus paper MAE); fast, adl and robust "
                        "also add their 3-DOF MAE to the 3-DOF rows (eval/suites.py SUITES3)")
    p.add_argument("--surgery", nargs="+", type=Path, default=[], metavar="DIR",
                   help="add a 'surgery' section from each `shoulder-bench surgery --out DIR` folder (its "
                        "summary.json: pre-op, zero-shot, fine-tuned and from-scratch MAE per scenario)")
    p.add_argument("--out", type=Path, default=Path("leaderboard"),
                   help="folder for leaderboard.md, .csv and .html (created; must not be a file)")
    p.set_defaults(func=_run)


def _run(args) -> int:
    from shoulder_bench.eval.plots import checked_dir

    checked_dir(args.out, "--out")  # before the minutes of evaluation
    load_suites(args.suite)  # every suite named and checksummed before any evaluation
    surgery = load_surgery(args.surgery)
    from shoulder_bench.eval import board3
    from shoulder_bench.eval.suites import load_suite

    for spec in board3.suites_of(args.suite):  # the 3-DOF suites' files too
        load_suite(spec, "track_3dof")

    rows = collect(args.runs, args.pretrained, progress=True, suites=args.suite)
    paths = write(rows, args.out, surgery, full=board3.collect(args.runs, progress=True, pretrained=args.pretrained,
                                                               suites=args.suite))
    print(paths["md"].read_text())
    print("\n".join(str(p) for p in paths.values()))
    return 0
