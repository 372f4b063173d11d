"""Learning curve of the DQN baselines (train/dqn.py): greedy tracking error after given numbers of training frames.

Trains on the task's training split and, at each `--eval-at` budget, rolls the greedy policy out for one episode per
copy on 16 copies of the test split (seed 1000: 20 s, targets in [20, 100] deg) and of the training split (seed 1000:
10 s, [30, 90] deg). MAE is over the frames before a crash; the crash rate is reported beside it.

    nice python benchmarks/dqn_curve.py --task abduction_ssp_discrete --eval-at 100000,300000
    nice python benchmarks/dqn_curve.py --task abduction_4m_discrete --eval-at 200000,500000
    python benchmarks/dqn_curve.py --cfg '{"updates_per_step": 2.0}'    # DQNConfig overrides as JSON
"""
from __future__ import annotations

import argparse
import json
import time

import numpy as np
import torch

import shoulder_bench
from shoulder_bench.train.dqn import DQNAgent, config_for


def greedy_mae(policy, task: str, split: str, num_envs: int = 16, seed: int = 1000) -> tuple[float, float]:
    """(mean over copies of the per-episode MAE in degrees, crash rate) of one greedy episode per copy."""
    env = shoulder_bench.make_vec(task, num_envs, seed=seed, split=split)
    obs = env.get_observations()["policy"]
    err, frames, alive = np.zeros(num_envs), np.zeros(num_envs), np.ones(num_envs, bool)
    with torch.no_grad():
        for _ in range(env.max_episode_length):
            td, _, _, _ = env.step(policy(obs))
            obs = td["policy"]
            alive &= ~env.last_crashed
            err += np.where(alive, np.abs(env.last_angle_deg - env.last_target_deg), 0.0)
            frames += alive
    env.close()
    return float(np.mean(err / np.maximum(frames, 1))), float(1.0 - alive.mean())


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--task", default="abduction_ssp_discrete")
    p.add_argument("--eval-at", default="100000,300000", help="comma-separated frame budgets")
    p.add_argument("--cfg", default="{}", help="JSON overrides of DQNConfig")
    p.add_argument("--threads", type=int, default=1, help="torch threads (tiny networks: 1 is fastest)")
    a = p.parse_args()
    torch.set_num_threads(a.threads)
    cfg = config_for(a.task, **json.loads(a.cfg))
    env = shoulder_bench.make_vec(a.task, cfg.num_envs, seed=cfg.seed)
    agent = DQNAgent(cfg, env.get_observations()["policy"].shape[1], env.n)
    print(a.task, cfg, flush=True)
    t0, train_s = time.perf_counter(), 0.0
    for budget in (int(x) for x in a.eval_at.split(",")):
        t = time.perf_counter()
        agent.learn(env, budget - agent.frames)
        train_s += time.perf_counter() - t
        test = greedy_mae(agent.policy(), a.task, "test")
        train = greedy_mae(agent.policy(), a.task, "train")
        print(f"frames={agent.frames} test_mae_deg={test[0]:.2f} (crash {test[1]:.2f}) "
              f"train_mae_deg={train[0]:.2f} (crash {train[1]:.2f}) training_fps={agent.frames / train_s:.0f} "
              f"wall={time.perf_counter() - t0:.0f}s", flush=True)


if __name__ == "__main__":
    main()
