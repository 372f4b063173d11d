"""BDQ's frames/s with the env stepped in a thread beside the gradient steps (`DQNConfig.overlap_env`, the default
since 2026-12-06) against between them (before), side by side in one run.

    .venv/bin/python benchmarks/dqn_overlap.py [--repeats 5] [--frames 15000] [--task abduction_4m_discrete]

Each repeat trains the task's preset (`train.dqn.PRESETS`) from a fresh agent and env, past its warm-up (learning
starts at 2,000 frames here), then times `--frames` more frames of learning (collection and updates), once each way,
the two interleaved so that both see the same machine load; frames/s of every repeat, and the ratio of the best.
"""
from __future__ import annotations

import argparse
import time

import torch


def frames_per_s(task: str, overlap: bool, frames: int) -> float:
    import shoulder_bench
    from shoulder_bench.train.dqn import DQNAgent, config_for

    cfg = config_for(task, learning_starts=2_000, overlap_env=overlap)
    env = shoulder_bench.make_vec(task, cfg.num_envs, seed=0)
    agent = DQNAgent(cfg, env.get_observations()["policy"].shape[1], env.n, dofs=getattr(env.task, "dofs", 1))
    agent.learn(env, 3_000)  # warm-up and the first updates
    t = time.perf_counter()
    agent.learn(env, frames)
    return frames / (time.perf_counter() - t)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeats", type=int, default=5)
    p.add_argument("--frames", type=int, default=15_000)
    p.add_argument("--task", default="abduction_4m_discrete")
    args = p.parse_args(argv)
    torch.set_num_threads(1)  # as `train` runs DQN
    fps = {False: [], True: []}
    for _ in range(args.repeats):
        for overlap in (False, True):
            fps[overlap].append(frames_per_s(args.task, overlap, args.frames))
    for overlap, name in ((False, "between the updates (before)"), (True, "beside the updates (the default)")):
        print(f"{name:33s} " + " ".join(f"{f:,.0f}" for f in fps[overlap]) + " frames/s")
    print(f"best: {max(fps[True]):,.0f} / {max(fps[False]):,.0f} = {max(fps[True]) / max(fps[False]):.2f} x")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
