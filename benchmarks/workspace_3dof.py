"""Which poses the full shoulder's muscles can hold against gravity: the 3-DOF tasks' workspace (docs/tasks_3dof.md).

    .venv/bin/python benchmarks/workspace_3dof.py [--condition C [--condition C ...]]   (about 1-2 min each)

Static optimisation (`statics_full.Statics.holding`) at every pose of a 10 deg grid over plane 0-90, elevation
10-130, rotation -40-60 deg; a pose is held when the three equilibrium equations are met within
statics_full.FEASIBLE_NM. Prints the share held per elevation, and for the train and test boxes of
`trajectory3.SPLITS` the share held and the largest activation needed (median, max). `--condition C`: the same for
the post-op shoulder (`shoulder_bench.conditions`, its law and model `tasks.track3d.condition_law`), one after
another: whether the muscles a tear leaves can still hold the tasks' poses.
"""
from __future__ import annotations

import argparse
import itertools

import numpy as np

from shoulder_bench import trajectory3
from shoulder_bench.statics_full import FEASIBLE_NM, Statics
from shoulder_bench.tasks.track3d import condition_law


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--condition", action="append", default=[], help="a shoulder condition (repeatable)")
    args = p.parse_args()
    for condition in args.condition or [None]:
        print(f"\n== {condition or 'intact'}")
        workspace(Statics(*condition_law(condition)))  # ld_transfer: the rerouted model and tables too


def workspace(st: Statics) -> None:
    h = np.array(list(itertools.product(range(0, 91, 10), range(10, 131, 10), range(-40, 61, 10))), dtype=float)
    held, amax = st.held(h)
    h = np.c_[h, amax]
    print(f"{len(h)} poses (plane 0-90, elevation 10-130, rotation -40-60 deg, 10 deg grid), held within "
          f"{FEASIBLE_NM:g} N m:")
    for e in np.unique(h[:, 1]):
        at = h[:, 1] == e
        print(f"  elevation {e:5.0f}: {100 * held[at].mean():5.1f} % held, median largest activation "
              f"{np.median(h[at, 3]):.2f}")
    for split, cfg in trajectory3.SPLITS.items():
        (p0, p1), (e0, e1), (r0, r1) = cfg["range_deg"]
        box = (h[:, 0] >= p0) & (h[:, 0] <= p1) & (h[:, 1] >= e0) & (h[:, 1] <= e1) & (h[:, 2] >= r0) & \
            (h[:, 2] <= r1)
        print(f"{split} box {cfg['range_deg']}: {int(held[box].sum())}/{int(box.sum())} grid poses held; largest "
              f"activation median {np.median(h[box, 3]):.2f}, max {h[box, 3].max():.2f}; not held: "
              f"{[tuple(int(x) for x in row[:3]) for row in h[box & ~held]]}")


if __name__ == "__main__":
    main()
