"""`shoulder-bench reproduce`: the arguments of `eval.reproduce.run`."""
from __future__ import annotations

from pathlib import Path

from shoulder_bench.eval.reproduce import EXPERIMENTS, run


def add_parser(sub) -> None:
    p = sub.add_parser("reproduce", help="the paper's experiments, several seeds each -> table (and pretrained)")
    p.add_argument("--experiments", nargs="+", default=list(EXPERIMENTS), choices=list(EXPERIMENTS))
    p.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    p.add_argument("--runs", type=Path, default=Path("runs/reproduce"))
    p.add_argument("--frames-scale", type=float, default=1.0, help="multiply every budget (e.g. 0.01 to smoke-test)")
    p.add_argument("--table", type=Path, default=None, help="where the table goes (default: RUNS/table.md)")
    p.add_argument("--workers", type=int, default=None,
                   help="runs at once, each in its own process (default: one per core)")
    p.add_argument("--ship", action="store_true", help="copy the best seed of each into the pretrained agents")
    p.set_defaults(func=run)
