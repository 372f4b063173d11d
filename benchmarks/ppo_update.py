"""The PPO update (`alg.update()`, rsl-rl) on the task's config, its optimiser and torch threads side by side in one
run: rsl-rl's Adam (torch's `foreach` step) against the fused Adam `train.ppo` installs, with 1 and 2 torch threads,
the value network the policy's size; with `--critic`, the fused update with 1 thread and that value network too
(`PPOConfig.critic_hidden_dims`; abduction_4m's preset has 128,128 since docs/training.md's round 8).

    .venv/bin/python benchmarks/ppo_update.py [--repeats 20] [--task abduction_4m] [--critic 128,128 ...]

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


def rollout_and_alg(task: str, critic: list[int] | None = None):
    """An rsl-rl PPO on `task` with the default config (`critic`: the value network's hidden layers), its storage
    filled by one rollout (collection, returns)."""
    import dataclasses

    from rsl_rl.runners import OnPolicyRunner

    import shoulder_bench
    from shoulder_bench.train import ppo

    cfg = dataclasses.replace(ppo.config_for(task), critic_hidden_dims=critic or [])
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
    p.add_argument("--critic", action="append", default=[], metavar="H,H,...",
                   help="also the fused update with this value network (hidden layer sizes; repeatable)")
    args = p.parse_args(argv)
    if args.repeats < 1:
        p.error(f"--repeats {args.repeats}: give at least 1")
    try:
        critics = [[int(h) for h in c.split(",")] for c in args.critic]
    except ValueError:
        p.error(f"--critic takes comma-separated layer sizes, got {args.critic}")
    if any(h < 1 for c in critics for h in c):
        p.error(f"--critic takes positive layer sizes, got {args.critic}")
    torch.set_num_threads(1)
    alg = rollout_and_alg(args.task)
    storage = alg.storage
    variants = [("rsl-rl Adam (foreach)", alg, False, 1), ("fused Adam", alg, True, 1),
                ("rsl-rl Adam (foreach)", alg, False, 2), ("fused Adam", alg, True, 2)]
    variants += [(f"fused, critic {c}", rollout_and_alg(args.task, c), True, 1) for c in critics]
    times = [[] for _ in variants]
    for _ in range(args.repeats):
        for v, t in zip(variants, times):
            t.append(timed_update(*v[1:]))
    base = statistics.median(times[0])
    print(f"task {args.task}, default PPO config, one update of {storage.num_envs} envs x "
          f"{storage.num_transitions_per_env} steps, {args.repeats} repeats interleaved")
    print(f"{'optimiser':<30} {'threads':>7} {'median ms':>10} {'best ms':>8} {'ratio to first':>15}")
    for v, t in zip(variants, times):
        med = statistics.median(t)
        print(f"{v[0]:<30} {v[3]:>7} {1e3 * med:>10.1f} {1e3 * min(t):>8.1f} {med / base:>15.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
