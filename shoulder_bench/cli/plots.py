"""`shoulder-bench plot ...` (`eval.plots`): each command prints the files it wrote."""
from __future__ import annotations

from pathlib import Path

from shoulder_bench.eval.plots import paper_figures, plot_activations, plot_curves, plot_errors, plot_trajectory


def add_parser(sub) -> None:
    p = sub.add_parser("plot", help="figures (PNG and SVG): curves, trajectory, errors, activations, paper")
    what = p.add_subparsers(dest="figure", required=True, metavar="FIGURE")
    c = what.add_parser("curves", help="reward and test-MAE curves of training runs")
    c.add_argument("runs", nargs="+", type=Path, help="run folders (runs/<task>/<algo>/<seed>)")
    c.add_argument("--out", type=Path, default=Path("curves.png"))
    c.set_defaults(func=lambda a: _done(plot_curves(a.runs, a.out)))
    for name, text in (("trajectory", "one trajectory: target, angle and activations, per policy"),
                       ("errors", "per-trajectory MAE and RMSE on the test set, box plots per policy"),
                       ("activations", "activation of each muscle against the abduction angle, a row per policy")):
        f = what.add_parser(name, help=text)
        f.add_argument("--policy", required=True, action="append",
                       help="policy file, run folder, pretrained:NAME or reference (repeat for more)")
        f.add_argument("--task", default=None, help="the task for `reference` (default abduction_4m)")
        f.add_argument("--out", type=Path, default=Path(f"{name}.png"))
        if name == "trajectory":
            f.add_argument("--trajectories", default="test", help="test, combing or a CSV file")
            f.add_argument("--index", type=int, default=0, help="which trajectory of that set")
        f.set_defaults(func=_figure)
    a = what.add_parser("paper", help="the paper-style figures from the shipped agents (and curves from --runs)")
    a.add_argument("--runs", type=Path, default=None, help="runs/<task>/<algo>/<seed> folders for the curves")
    a.add_argument("--out-dir", type=Path, default=Path("figures"))
    a.set_defaults(func=lambda a: _done(*paper_figures(a.out_dir, a.runs)))


def _done(*paths) -> int:
    for p in paths:
        for q in p if isinstance(p, list) else [p]:
            print(q)
    return 0


def _figure(args) -> int:
    if args.figure == "trajectory":
        return _done(plot_trajectory(args.policy, args.out, args.task, args.trajectories, args.index))
    if args.figure == "errors":
        return _done(plot_errors(args.policy, args.out, args.task))
    return _done(plot_activations(args.policy, args.out, args.task))
