"""`shoulder-bench surgery`: the pre-op -> post-op re-learning experiment (`eval.surgery`; docs/surgery.md)."""
from __future__ import annotations

from pathlib import Path


def add_parser(sub) -> None:
    from shoulder_bench.conditions import CONDITIONS, NOT_YET
    from shoulder_bench.train.plan import ALGOS

    p = sub.add_parser("surgery", help="pre-op agent -> post-op shoulder: zero-shot, fine-tune to 90 %% of its "
                       "accuracy, from scratch, activation shifts (docs/surgery.md)")
    p.add_argument("--task", nargs="+", required=True, help="task(s), e.g. abduction_4m or track_3dof")
    p.add_argument("--condition", nargs="+", required=True,
                   help=f"post-op condition(s): {', '.join(CONDITIONS)} (compose with '+')"
                        + (f"; not available yet: {', '.join(NOT_YET)}" if NOT_YET else ""))
    p.add_argument("--algo", choices=ALGOS, default=None,
                   help="default: the task's (ppo continuous, dqn one-muscle discrete, bdq the other discrete)")
    p.add_argument("--seeds", nargs="+", type=int, default=[0])
    src = p.add_mutually_exclusive_group()
    src.add_argument("--pretrained", action="store_true", help="the shipped agent of the task and algorithm is the "
                     "pre-op agent (one for every seed)")
    src.add_argument("--preop-run", type=Path, default=None, metavar="DIR",
                     help="a finished run as the pre-op agent (every seed), or a folder of runs per seed (DIR/<seed>/)")
    p.add_argument("--frames", type=int, default=None, help="frames of the pre-op agent trained here (neither "
                   "--pretrained nor --preop-run); default: the shipped agents' budget")
    p.add_argument("--finetune-frames", type=int, default=None,
                   help="post-op fine-tune budget; default 10 %% of the pre-op agent's training frames")
    p.add_argument("--scratch-frames", type=int, default=None,
                   help="budget of the agent trained post-op from scratch; default the fine-tune's; 0: none")
    p.add_argument("--eval-every", type=int, default=None,
                   help="frames between post-op test-set evaluations (the recovery curve); default budget / 8")
    p.add_argument("--option", action="append", default=[], metavar="KEY=VALUE",
                   help="a condition's fraction: tear_fraction=0.3, weakness_fraction=0.7 (repeatable)")
    p.add_argument("--config", type=Path, default=None,
                   help="JSON file overriding the algorithm's config for every run (the fine-tune keeps the pre-op "
                        "agent's network)")
    p.add_argument("--muscle-model", default=None, help="fem or hill (default: the package default)")
    p.add_argument("--allow-unreachable", action="store_true",
                   help="run even where the post-op muscles cannot hold part of the task's range (3-DOF tasks: some "
                        "poses of its test box); the report says so")
    p.add_argument("--out", type=Path, default=Path("runs/surgery"),
                   help="output folder: run folders, summary.json, report.md, figures/, leaderboard_section.md "
                        "(default: %(default)s)")
    p.set_defaults(func=_surgery)


def _surgery(args) -> int:
    from shoulder_bench.eval.surgery import surgery
    from shoulder_bench.tasks.options import assignments

    surgery(args.task, args.condition, algo=args.algo, seeds=args.seeds, frames=args.frames,
            finetune_frames=args.finetune_frames, scratch_frames=args.scratch_frames, pretrained=args.pretrained,
            preop_run=args.preop_run, out=args.out, config=args.config, muscle_model=args.muscle_model,
            fractions=assignments(args.option), allow_unreachable=args.allow_unreachable,
            eval_every=args.eval_every)
    return 0
