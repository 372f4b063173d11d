"""What each physiology option (issue 14 §1) costs the batched env: frames/s of `make_vec("abduction_4m", N)` with
random actions; with --task track_3dof, what they and the band's line of action (`line_of_action="band"`, the
passive-force callback; "band_fibres", the force its fibres') and the compliant tendon (`tendon="compliant"`, a
finer table) cost the full shoulder's. The configurations take
turns in short chunks of frames (round robin, so that a loaded machine's swings hit them alike); each one's rate is
its frames over the summed time of its chunks, also as the ratio to the default protocol.

    python benchmarks/physiology_cost.py [--task abduction_4m|track_3dof] [--envs 256] [--frames 10] [--repeats 40]
"""
from __future__ import annotations

import argparse
import time

import numpy as np

import shoulder_bench

CONFIGS = {"abduction_4m": {"default": {}, "activation_dynamics": {"activation_dynamics": True},
                            "fatigue": {"fatigue": True}, "randomize": {"randomize": True},
                            "all three": {"activation_dynamics": True, "fatigue": True, "randomize": True}},
           "track_3dof": {"default": {}, "line_of_action=band": {"line_of_action": "band"},
                          "line_of_action=band_fibres": {"line_of_action": "band_fibres"},
                          "tendon=compliant": {"tendon": "compliant"},
                          "activation_dynamics": {"activation_dynamics": True}, "fatigue": {"fatigue": True},
                          "randomize": {"randomize": True},
                          "all three": {"activation_dynamics": True, "fatigue": True, "randomize": True}}}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--task", choices=tuple(CONFIGS), default="abduction_4m")
    p.add_argument("--envs", type=int, default=256)
    p.add_argument("--frames", type=int, default=10, help="frames per chunk")
    p.add_argument("--repeats", type=int, default=40, help="chunks per configuration")
    args = p.parse_args()
    envs = {k: shoulder_bench.make_vec(args.task, args.envs, seed=0, **o) for k, o in CONFIGS[args.task].items()}
    n = next(iter(envs.values())).num_actions
    acts = np.random.default_rng(0).uniform(-0.01, 0.01, (args.frames, args.envs, n))
    for env in envs.values():  # warm-up (compiled callbacks, caches)
        env.step(acts[0])
    spent = dict.fromkeys(envs, 0.0)
    for _ in range(args.repeats):
        for k, env in envs.items():
            t0 = time.perf_counter()
            for a in acts:
                env.step(a)
            spent[k] += time.perf_counter() - t0
    rate = {k: args.repeats * args.frames * args.envs / t for k, t in spent.items()}
    print(f"{args.task}, N = {args.envs}, {args.repeats} chunks of {args.frames} frames each (round robin)")
    print(f"{'configuration':>22} {'frames/s':>10} {'ratio to default':>17}")
    for k, r in rate.items():
        print(f"{k:>22} {r:>10.0f} {r / rate['default']:>17.2f}")
    for env in envs.values():
        env.close()


if __name__ == "__main__":
    main()
