"""`shoulder-bench model validate`: the model against the references (`authoring.validate`), the report and figures."""
from __future__ import annotations

import json
from pathlib import Path

from shoulder_bench.authoring.validate import DEFAULT_MODEL, DEFAULT_OUT, evaluate
from shoulder_bench.model import DEFAULT_MUSCLE_MODEL


def _run(args) -> int:
    from shoulder_bench.authoring.fem import output_folder

    out = output_folder(args.out, "--out")
    if not Path(args.model).is_file():
        raise FileNotFoundError(f"--model {args.model}: no such file; give an MJCF (models/shoulder_v2.xml, the "
                                "default, or models/shoulder.xml)")
    from shoulder_bench.authoring.validate_report import print_report, write_figures

    report = evaluate(args.muscle_model, args.model)
    report["figures"] = [str(p) for p in write_figures(report, out)]
    if args.json:
        print(json.dumps(report, indent=1, allow_nan=False))
    else:
        print_report(report)
    return 0 if report["passed"] else 1


def add_parser(subparsers):
    from shoulder_bench.muscle import MUSCLE_MODELS

    p = subparsers.add_parser("model", help="check the shoulder model")
    sub = p.add_subparsers(dest="model_command", required=True, metavar="SUBCOMMAND")
    v = sub.add_parser("validate", help="moment arms against the MoBL-ARMS, MyoArm and OpenSim references, rest "
                       "posture, passive and peak torques; overlay figures; exit status 1 when a target is missed")
    v.add_argument("--model", type=Path, default=DEFAULT_MODEL, metavar="PATH",
                   help="the MJCF to validate: v2 (default, models/shoulder_v2.xml, the geometry of the tasks' locked "
                   "variant; force targets by a static estimate, the tasks' tables shown beside) or v1 "
                   "(models/shoulder.xml, kept for comparison)")
    v.add_argument("--json", action="store_true", help="print one JSON object instead of the tables")
    v.add_argument("--out", type=Path, default=DEFAULT_OUT, help="folder for the figures validate_<muscle>.png "
                   "(v2: validate_v2_<muscle>.png; default: %(default)s, under the current folder, as the other "
                   "commands' runs/...; created if missing)")
    v.add_argument("--muscle-model", choices=MUSCLE_MODELS, default=DEFAULT_MUSCLE_MODEL,
                   help="muscle tables for the force quantities (v1: its tables; v2: the tasks' tables shown beside "
                   "the static estimate; default: %(default)s)")
    v.set_defaults(func=_run)
    return p
