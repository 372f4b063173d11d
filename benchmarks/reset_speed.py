"""Episode resets of the batched env: the whole reset (`make_vec(...)._reset` of all copies) and its target part,
per-copy (`trajectory.random_trajectory` once per copy, as resets were built before) against in arrays
(`trajectory.random_targets`), side by side in one run (issue 15 §2).

    .venv/bin/python benchmarks/reset_speed.py [--n 64 256 1024 4096] [--repeats 5]

Per N, alternating the two target constructions `--repeats` times, best of each: ms per reset of all N copies, and
the ratio. The targets are the same numbers either way (tests/test_trajectory.py). The whole-reset column is
`_reset(all copies)` of `make_vec("abduction_4m", N)`: targets, the arm at rest on them, holding activations.
"""
from __future__ import annotations

import argparse
import time

import numpy as np


def best_ms(fn, repeats: int) -> float:
    out = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t)
    return 1e3 * min(out)


def main(argv=None) -> int:
    import shoulder_bench
    from shoulder_bench import trajectory

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--n", type=int, nargs="+", default=[64, 256, 1024, 4096])
    p.add_argument("--repeats", type=int, default=5)
    args = p.parse_args(argv)
    print(f"{'N':>6} {'per-copy targets ms':>20} {'array targets ms':>17} {'ratio':>6} {'whole reset ms':>15}")
    for n in args.n:
        rngs = [np.random.default_rng(i) for i in range(n)]
        per_copy, arrays = [], []
        for _ in range(args.repeats):  # interleaved: both see the same machine load
            per_copy.append(best_ms(lambda rngs=rngs: [trajectory.random_trajectory(r, "train") for r in rngs], 1))
            arrays.append(best_ms(lambda rngs=rngs: trajectory.random_targets(rngs, "train"), 1))
        venv = shoulder_bench.make_vec("abduction_4m", n, seed=0)
        whole = best_ms(lambda venv=venv, n=n: venv._reset(np.arange(n)), args.repeats)
        venv.close()
        print(f"{n:>6} {min(per_copy):>20.2f} {min(arrays):>17.2f} {min(per_copy) / min(arrays):>5.1f}x "
              f"{whole:>15.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
