"""`shoulder-bench leaderboard` (`eval.leaderboard`)."""
from __future__ import annotations

from pathlib import Path

from shoulder_bench.eval.leaderboard import collect, write


def add_parser(sub) -> None:
    p = sub.add_parser("leaderboard", help="compare runs (or the pretrained agents), the reference and the paper")
    p.add_argument("--runs", type=Path, default=None, help="a folder of runs (runs/<task>/<algo>/<seed>)")
    p.add_argument("--pretrained", action="store_true", help="add the shipped agents' rows next to the runs'")
    p.add_argument("--out", type=Path, default=Path("leaderboard"),
                   help="folder for leaderboard.md, .csv and .html (created; must not be a file)")
    p.set_defaults(func=_run)


def _run(args) -> int:
    from shoulder_bench.eval.plots import checked_dir

    checked_dir(args.out, "--out")  # before the minutes of evaluation
    paths = write(collect(args.runs, args.pretrained, progress=True), args.out)
    print(paths["md"].read_text())
    print("\n".join(str(p) for p in paths.values()))
    return 0
