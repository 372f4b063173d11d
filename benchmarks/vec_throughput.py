"""Batched-env frames/s per wall second and per CPU second, for one N and thread count (median of repeats).

    python benchmarks/vec_throughput.py --num-envs 1024 --nthread 1 [--frames 20 --repeats 3]
    taskset -c 0 python benchmarks/vec_throughput.py ...   # pinned to one core
"""
from __future__ import annotations

import argparse
import json
import os
import time

import torch

import shoulder_bench


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--num-envs", type=int, default=1024)
    p.add_argument("--nthread", type=int, default=1)
    p.add_argument("--frames", type=int, default=20)
    p.add_argument("--repeats", type=int, default=3)
    args = p.parse_args()
    torch.set_num_threads(1)
    n = args.num_envs
    venv = shoulder_bench.make_vec("abduction_4m", n, seed=0, nthread=args.nthread)
    gen = torch.Generator().manual_seed(0)

    def run(k: int) -> None:
        for _ in range(k):
            venv.step((torch.rand((n, 4), generator=gen) * 2 - 1) * 0.01)

    run(5)
    wall, cpu = [], []
    for _ in range(args.repeats):
        w, c = time.perf_counter(), time.process_time()
        run(args.frames)
        wall.append(n * args.frames / (time.perf_counter() - w))
        cpu.append(n * args.frames / (time.process_time() - c))
    venv.close()
    wall.sort()
    cpu.sort()
    print(json.dumps({"num_envs": n, "nthread": args.nthread, "affinity": sorted(os.sched_getaffinity(0)),
                      "frames_per_wall_s_median": round(wall[len(wall) // 2]),
                      "frames_per_cpu_s_median": round(cpu[len(cpu) // 2])}))


if __name__ == "__main__":
    main()
