"""How much the band corrections change the full shoulder's dynamics: the 3-DOF reference controller planning with
one line of action on a task simulated with the other (docs/fem.md "The bands in MuJoCo").

    .venv/bin/python benchmarks/line_of_action.py [--n 20]      (about 2 min for 20 trajectories on 2 cores)

The reference controller (`eval.reference3`: computed torque + static optimisation) plans with the moment arms of its
law: the MJCF paths', or with line_of_action="band" the band tables' (`band_lines`). On each task variant
(track_3dof with line_of_action "mjcf" or "band") it runs the first `--n` trajectories of the fixed 3-DOF test set;
prints the orientation MAE and the per-coordinate MAE (deg) for the four pairings. Planning with the simulated line
of action is the controller's own row on the board; the crossed pairings show what a controller that assumes the
other line loses.
"""
from __future__ import annotations

import argparse

from shoulder_bench.band_lines import LINES
from shoulder_bench.eval.evaluate import evaluate
from shoulder_bench.eval.reference3 import ReferenceController3
from shoulder_bench.trajectory3 import load_test_set


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--n", type=int, default=20, help="trajectories of the test set (from the first; 1-100)")
    args = p.parse_args()
    if not 1 <= args.n <= 100:
        p.error(f"--n must be in 1-100, not {args.n}")
    test = load_test_set()[:args.n]
    print(f"reference controller, first {args.n} test trajectories of track_3dof: MAE deg (plane / elevation / "
          "rotation)")
    for plan in LINES:
        for simulated in LINES:
            s = evaluate(ReferenceController3("track_3dof", line_of_action=plan), "track_3dof", test,
                         options={"line_of_action": simulated})
            c = s["coordinate_mae_deg"]
            print(f"  plans with {plan:<4}  simulated with {simulated:<4}  {s['mae_deg']:6.2f}  ({c['plane']:.2f} / "
                  f"{c['elevation']:.2f} / {c['rotation']:.2f})  crashes {s['crashes']}", flush=True)


if __name__ == "__main__":
    main()
