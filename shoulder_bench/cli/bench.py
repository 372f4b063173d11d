"""`shoulder-bench bench`: the arguments of `eval.bench.run`."""
from __future__ import annotations

from shoulder_bench.eval.bench import run


def add_parser(sub) -> None:
    p = sub.add_parser("bench", help="throughput and memory, measured side by side")
    p.add_argument("--quick", action="store_true", help="tiny budget (CI): small batches, few frames")
    p.add_argument("--json", action="store_true", help="print one JSON object as the last line")
    p.add_argument("--repeats", type=int, default=3, help="measurements of each, the best kept (at least 1)")
    p.add_argument("--task", default=None, help="the task whose model and batched env are timed (default "
                   "abduction_4m; track_3dof: the full shoulder's 3-DOF model)")
    p.set_defaults(func=run)
