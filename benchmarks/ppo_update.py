"""The PPO update (`alg.update()`, rsl-rl) on the default config, its optimiser and torch threads side by side in one
run: rsl-rl's Adam (torch's `foreach` step) against the fused Adam `train.ppo` installs, with 1 and 2 torch threads.

    .venv/bin/python benchmarks/ppo_update.py [--repeats 20] [--task abduction_4m]

One rollout of the default config (64 envs x 12 steps on the task) is collected once; each variant then updates a copy
of the same initial networks on it, `--repeats` times, the variants interleaved so that all see the same machine load;
ms per update, the median and the best. Wall time of the update is most of a PPO iteration on 2 cores
(docs/training.md "Round 5").
"""
from __future__ import annotations

import argparse
import contextlib
import copy
import io
import statistics
import time

import torch


def rollout_and_alg(task: str):
    """An rsl-rl PPO on `task` with the default config, its storage filled by one rollout (collection, returns)."""
    from rsl_rl.runners import OnPolicyRunner

    import shoulder_bench
    from shoulder_bench.train import ppo

    cfg = ppo.config_for(task)
    venv = shoulder_bench.make_vec(task, cfg.num_envs, seed=0)
    env = ppo.ScaledActions(venv, cfg.reward_scale, cfg.error_features)
    torch.manual_seed(0)
    with contextlib.redirect_stdout(io.StringIO()):
        runner = OnPolicyRunner(env, ppo.rsl_config(cfg, venv.num_actions), log_dir=None, device="cpu")
    alg = runner.alg
    alg.train_mode()
    ppo.collect(alg, env, env.get_observations(), cfg.steps_per_env, [])
    venv.close()
    return alg


def timed_update(alg, fused: bool, threads: int) -> float:
    """Seconds of one `alg.update()` on a copy of `alg` (networks, optimiser, storage: every call starts alike)."""
    from shoulder_bench.train import ppo

    a = copy.deepcopy(alg)
    if fused:
        ppo.fuse_optimizer(a)
    before = torch.get_num_threads()
    torch.set_num_threads(threads)
    try:
        t = time.perf_counter()
        a.update()
        return time.perf_counter() - t
    finally:
        torch.set_num_threads(before)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeats", type=int, default=20)
    p.add_argument("--task", default="abduction_4m")
    args = p.parse_args(argv)
    if args.repeats < 1:
        p.error(f"--repeats {args.repeats}: give at least 1")
    torch.set_num_threads(1)
    alg = rollout_and_alg(args.task)
    storage = alg.storage
    variants = [("rsl-rl Adam (foreach)", False, 1), ("fused Adam", True, 1), ("rsl-rl Adam (foreach)", False, 2),
                ("fused Adam", True, 2)]
    times = {v: [] for v in variants}
    for _ in range(args.repeats):
        for v in variants:
            times[v].append(timed_update(alg, v[1], v[2]))
    base = statistics.median(times[variants[0]])
    print(f"task {args.task}, default PPO config, one update of {storage.num_envs} envs x "
          f"{storage.num_transitions_per_env} steps, {args.repeats} repeats interleaved")
    print(f"{'optimiser':<22} {'threads':>7} {'median ms':>10} {'best ms':>8} {'ratio to first':>15}")
    for v in variants:
        med = statistics.median(times[v])
        print(f"{v[0]:<22} {v[2]:>7} {1e3 * med:>10.1f} {1e3 * min(times[v]):>8.1f} {med / base:>15.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
