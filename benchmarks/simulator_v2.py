"""Frames/s of `BatchSimulator.frame` for v1 and the v2 locked variant, side by side (docs/physics.md "Multi-DOF").

v1: the abduction hinge with the four-muscle FEM law (holding activations at 30-90 deg), and without a law (passive,
the same cost structure as v2 today). v2: `mobl.model_xml(locked_plane_deg=0, dynamics=True)` + `harden_couplings`,
11 hinges and 10 equalities, no muscles yet (law=None), from 30-90 deg elevation at rest. The rows are measured
interleaved (best of `--repeats`, each `--frames` frames) so that load from other processes hits them alike.

    python benchmarks/simulator_v2.py [--num-envs 64 1024 --frames 10 --repeats 5 --nthread 2]
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from shoulder_bench import arm, statics
from shoulder_bench.authoring import mobl
from shoulder_bench.muscle import ForceLaw
from shoulder_bench.simulator import BatchSimulator


def cases(n: int, nthread: int) -> dict:
    """name -> (simulator, qpos, qvel, act)."""
    rng = np.random.default_rng(0)
    start = rng.uniform(30, 90, n)
    law = ForceLaw.load("fem")
    v1 = BatchSimulator(law, n, nthread=nthread)
    v1_passive = BatchSimulator(None, n, nthread=nthread)
    xml = mobl.model_xml(locked_plane_deg=0.0, dynamics=True)
    v2 = BatchSimulator(None, n, nthread=nthread, xml=xml, prepare=arm.harden_couplings, joint="shoulder_elv")
    slope = np.zeros(v2.nv)
    slope[v2.dadr] = 1.0
    m = v2.model
    for e in range(m.neq):
        slope[m.jnt_dofadr[m.eq_obj1id[e]]] = m.eq_data[e, 1]
    q1 = np.radians(start)
    return {"v1 (4 muscles)": (v1, q1, np.zeros(n), statics.holding_activation(law, start)),
            "v1 passive (law=None)": (v1_passive, q1, np.zeros(n), None),
            "v2 locked (law=None)": (v2, np.radians(start)[:, None] * slope, np.zeros((n, v2.nv)), None)}


def measure(n: int, frames: int, repeats: int, nthread: int) -> dict[str, float]:
    runs = cases(n, nthread)
    best = {k: 0.0 for k in runs}
    for _ in range(repeats):
        for name, (sim, q, v, act) in runs.items():
            t = time.perf_counter()
            for _ in range(frames):
                q, v, _ = sim.frame(q, v, act)
            best[name] = max(best[name], n * frames / (time.perf_counter() - t))
    for sim, *_ in runs.values():
        sim.close()
    return best


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--num-envs", type=int, nargs="+", default=[64, 1024])
    p.add_argument("--frames", type=int, default=10)
    p.add_argument("--repeats", type=int, default=5)
    p.add_argument("--nthread", type=int, default=2)
    args = p.parse_args()
    print(f"frames/s of BatchSimulator.frame, best of {args.repeats} x {args.frames} frames, {args.nthread} threads")
    for n in args.num_envs:
        r = measure(n, args.frames, args.repeats, args.nthread)
        base = r["v1 (4 muscles)"]
        for name, x in r.items():
            print(f"  N = {n:5d}  {name:24s} {x:10,.0f}  ({x / base:.2f} x v1)")


if __name__ == "__main__":
    main()
