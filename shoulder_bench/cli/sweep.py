"""`shoulder-bench sweep`: the grid of runs (`eval.sweep`)."""
from __future__ import annotations

import sys
from pathlib import Path

from shoulder_bench.eval.sweep import SUMMARY, grid, read_configs, report, sweep


def add_parser(sub) -> None:
    p = sub.add_parser("sweep", help="train a grid of tasks x algorithms x seeds (local pool, or Ray with --ray)")
    p.add_argument("--tasks", nargs="+", required=True)
    p.add_argument("--algos", nargs="+", required=True, help="ppo, dqn, bdq; pairs that do not fit a task are skipped")
    p.add_argument("--seeds", nargs="+", type=int, default=[0])
    p.add_argument("--frames", type=int, default=None, help="budget per run (default: each algorithm's default)")
    p.add_argument("--eval-every", type=int, default=100_000, help="frames between test-set evaluations")
    p.add_argument("--config", action="append", default=[], metavar="ALGO=FILE",
                   help="JSON config overrides for one algorithm (repeatable), as for `train --config`")
    p.add_argument("--out", type=Path, default=Path("runs/sweep"))
    p.add_argument("--workers", type=int, default=None,
                   help="runs at once on the local pool (default: one per two cores; each run steps on 2 threads)")
    p.add_argument("--ray", default=None, metavar="ADDRESS", help="run on Ray: local, auto or ray://HOST:PORT")
    p.add_argument("--cpus-per-run", type=float, default=2.0, help="Ray CPUs reserved per run")
    p.set_defaults(func=_run)


def _run(args) -> int:
    jobs, skipped = grid(args.tasks, args.algos, args.seeds, args.frames, args.eval_every,
                         read_configs(args.config))
    for pair in skipped:
        print(f"skipping {pair}: the algorithm does not fit the task")
    try:
        records = sweep(jobs, args.out, args.workers, args.ray, args.cpus_per_run)
    except KeyboardInterrupt:
        print(f"sweep interrupted; summary in {args.out / SUMMARY}. Run the same command again to continue: "
              f"finished runs are skipped, interrupted ones resume from their checkpoints", file=sys.stderr)
        return 130
    print(report(records))
    failed = sum(r["status"] == "failed" for r in records)
    print(f"\n{len(records) - failed} of {len(records)} runs finished; summary in {args.out / SUMMARY}"
          + (f"; {failed} FAILED (logs above)" if failed else "")
          + (f"\nnext: shoulder-bench leaderboard --runs {args.out}" if failed < len(records) else ""))
    return 1 if failed else 0
