"""`shoulder-bench condition report`: what each shoulder condition does (`eval.conditions`)."""
from __future__ import annotations

import json


def _report(args) -> int:
    from shoulder_bench.eval.conditions import print_report, report

    r = report(args.muscle_model, reference=not args.no_reference)
    if args.json:
        print(json.dumps(r, allow_nan=False))
    else:
        print_report(r)
    return 0


def add_parser(subparsers):
    from shoulder_bench.model import DEFAULT_MUSCLE_MODEL
    from shoulder_bench.muscle import MUSCLE_MODELS

    p = subparsers.add_parser("condition", help="shoulder conditions (cuff tears, deltoid weakness, the latissimus "
                              "transfer; docs/surgery.md)")
    sub = p.add_subparsers(dest="condition_command", required=True, metavar="SUBCOMMAND")
    r = sub.add_parser("report", help="per condition: maximum isometric elevation and external-rotation torque, "
                       "static reach, the rerouted ld's moment arms, the "
                       "reference controller's test MAE; the supraspinatus share against Phillips et al. 2018")
    r.add_argument("--json", action="store_true", help="print one JSON object instead of the table")
    r.add_argument("--muscle-model", choices=MUSCLE_MODELS, default=DEFAULT_MUSCLE_MODEL,
                   help="muscle tables (default: %(default)s)")
    r.add_argument("--no-reference", action="store_true",
                   help="leave out the reference controller's test-set runs (about 2 s per condition)")
    r.set_defaults(func=_report)
    return p
