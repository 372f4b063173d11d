"""Training wall time to accuracy for PPO and BDQ configs (issue 15 §3): each config trains the four-muscle task for
several seeds, one run after the other, and the table gives the median over seeds of the training wall time
(evaluations excluded, `metrics.json` `to_accuracy`) and frames to test MAE <= 2, 1 and 0.5 deg, the final MAE and
the frames/s.

    .venv/bin/python benchmarks/wallclock.py [--algo ppo|bdq] [--configs NAME ...] [--seeds 0 1 2]
        [--frames 600000] [--eval-every 20000] [--out runs/ppo_wallclock] [--task abduction_4m]

PPO configs are overrides of `PPOConfig`'s defaults before its search (`BEFORE`: 256 envs, 5 epochs x 4 mini-batches,
24 steps; `CONFIGS` below; `default` is `BEFORE` itself; rounds 1-2 chose `e1m8t1_n64`, round 3 `n64_s12`; round 4
tried `s12_*` from it and kept it; round 5 chose `s12_fused`, today's `PPOConfig()`; round 6 tried the overlap, not
kept; round 7 the return's horizon and scale, not kept; round 8 a smaller value network, kept for abduction_4m; round
9 the update's clip ranges, lambda and value loss weight from there, not kept; round 10 more exploration noise, lower
learning rates and 6 mini-batches, not kept). BDQ configs (`BDQ_CONFIGS`, task `abduction_4m_discrete`) are overrides
of the task's preset before its search (`BDQ_BEFORE`, `train.dqn.PRESETS`; round 1 fewer gradient steps per frame,
rounds 2-4 n-step returns, exploration, gamma and the target update, none kept; round 5 the env stepped beside the
updates, kept; rounds 6-7 a lower gamma and half the learning rate with it, not kept; round 8 smaller shared layers).
Runs are normal run folders (`<out>/<config>/<seed>`), so a rerun resumes or reuses finished ones; `<out>/table.md`
and the figure `<out>/wallclock.png` (test MAE against training seconds and frames, each seed and the median, the
goals marked) are rewritten at the end. The runs alternate configs within each seed (seed 0 of every config, then seed
1, ...), so that a change in the machine's load spreads over all configs. Wall times are this machine's: compare
configs only within one table.
"""
from __future__ import annotations

import argparse
import json
import statistics
from pathlib import Path

# PPOConfig's defaults before the search (pinned where a round changed the default: steps_per_env in round 3, the
# optimiser in round 5, the task's value network in round 8; overlap_env, added in round 6, pinned off so the
# search's runs stay what they were)
BEFORE = {"num_envs": 256, "num_learning_epochs": 5, "num_mini_batches": 4, "steps_per_env": 24, "fused_adam": False,
          "overlap_env": False, "critic_hidden_dims": []}
N64 = {"num_learning_epochs": 1, "num_mini_batches": 8, "num_envs": 64}  # rounds 1-2's choice
S12 = {**N64, "steps_per_env": 12}  # round 3's choice
C128 = {**S12, "fused_adam": True, "critic_hidden_dims": [128, 128]}  # round 8's choice
CONFIGS = {
    "default": {},
    "t2": {"update_threads": 2},
    "e2m4t2": {"num_learning_epochs": 2, "update_threads": 2},
    "e1m8t1": {"num_learning_epochs": 1, "num_mini_batches": 8},
    "e1m8t2": {"num_learning_epochs": 1, "num_mini_batches": 8, "update_threads": 2},
    "e2m4t2_err": {"num_learning_epochs": 2, "update_threads": 2, "error_features": True},
    "e1m8t2_err": {"num_learning_epochs": 1, "num_mini_batches": 8, "update_threads": 2, "error_features": True},
    "e1m4t1": {"num_learning_epochs": 1},
    "e2m8t1": {"num_learning_epochs": 2, "num_mini_batches": 8},
    "e1m8t1_n128": {"num_learning_epochs": 1, "num_mini_batches": 8, "num_envs": 128},
    "e1m8t1_n64": N64,
    # round 3, from round 2's choice (e1m8t1_n64): more updates per frame, smaller networks, a looser KL target
    "n64_s12": S12,
    "n32": {**N64, "num_envs": 32},
    "n64_h128": {**N64, "hidden_dims": [128, 128, 128]},
    "n64_kl02": {**N64, "desired_kl": 0.02},
    "n64_s8": {**N64, "steps_per_env": 8},
    # round 4, from round 3's choice (n64_s12, today's defaults): exploration noise, fewer gradient steps, the start of
    # the adaptive learning rate, no entropy bonus
    "s12_std025": {**S12, "init_std": 0.25},
    "s12_m4": {**S12, "num_mini_batches": 4},
    "s12_lr3e-3": {**S12, "learning_rate": 3e-3},
    "s12_ent0": {**S12, "entropy_coef": 0.0},
    # round 5: torch's fused Adam (benchmarks/ppo_update.py), alone, with round 4's fewer mini-batches and with 2
    # torch threads in the update
    "s12_fused": {**S12, "fused_adam": True},
    "s12_m4_fused": {**S12, "num_mini_batches": 4, "fused_adam": True},
    "s12_fused_t2": {**S12, "fused_adam": True, "update_threads": 2},
    # round 6: the next rollout collected during the update (one update behind), alone and with twice the KL target
    # (the KL the adaptive schedule measures then includes the previous update's step)
    "s12_overlap": {**S12, "fused_adam": True, "overlap_env": True},
    "s12_overlap_kl02": {**S12, "fused_adam": True, "overlap_env": True, "desired_kl": 0.02},
    # round 7: the return's horizon and scale, never searched (gamma 0.99 is the paper's, lam 0.95 and the unscaled
    # reward were chosen by hand on model v1): a shorter horizon, a shorter GAE, the values a tenth as large
    "s12_g95": {**S12, "fused_adam": True, "gamma": 0.95},
    "s12_g90": {**S12, "fused_adam": True, "gamma": 0.9},
    "s12_lam09": {**S12, "fused_adam": True, "lam": 0.9},
    "s12_rs01": {**S12, "fused_adam": True, "reward_scale": 0.1},
    # round 8: a smaller value network (the policy stays the paper's 3 x 250): the critic's forward and backward
    # are half of the update's arithmetic (benchmarks/ppo_update.py --critic)
    "s12_c250": {**S12, "fused_adam": True, "critic_hidden_dims": [250]},
    "s12_c128": C128,
    "s12_c64": {**S12, "fused_adam": True, "critic_hidden_dims": [64, 64]},
    # round 9: the update's remaining knobs from round 8's choice (the abduction_4m preset): the clip range, the
    # gradient-norm clip, GAE's lambda, the value loss' weight
    "c128_clip03": {**C128, "clip_param": 0.3},
    "c128_gn5": {**C128, "max_grad_norm": 5.0},
    "c128_lam098": {**C128, "lam": 0.98},
    "c128_vl05": {**C128, "value_loss_coef": 0.5},
    # round 10: exploration and step size the other way from round 4 (which tried less noise and a higher learning
    # rate), and a number of mini-batches between round 4's 4 and the default 8
    "c128_std1": {**C128, "init_std": 1.0},
    "c128_lr5e-4": {**C128, "learning_rate": 5e-4},
    "c128_lr3e-4": {**C128, "learning_rate": 3e-4},
    "c128_m6": {**C128, "num_mini_batches": 6},
}
# BDQ-4: the preset before its search (train.dqn.PRESETS["abduction_4m_discrete"] then: 32 envs, one gradient step of
# 256 per vec step, lr 5e-4, 2 x 256, the env stepped between the gradient steps)
BDQ_BEFORE = {"branching": True, "hidden": [256, 256], "num_envs": 32, "updates_per_step": 1.0, "batch_size": 256,
              "lr": 5e-4, "overlap_env": False}  # overlap_env pinned: round 5 made it the default
BDQ_CONFIGS = {
    "default": {},
    "n128": {"num_envs": 128},  # a quarter of the gradient steps per frame
    "n128_u2": {"num_envs": 128, "updates_per_step": 2.0},  # half of them
    "n64_b512": {"num_envs": 64, "batch_size": 512},  # half the steps, each on twice the batch
    "n128_lr1e-3": {"num_envs": 128, "lr": 1e-3},
    # round 2 (2026-12-06), for sample efficiency: n-step returns (`n_step`), a shorter exploration schedule
    "nstep3": {"n_step": 3},
    "nstep5": {"n_step": 5},
    "eps30k": {"eps_decay_frames": 30_000},
    "nstep3_eps30k": {"n_step": 3, "eps_decay_frames": 30_000},
    # round 3: a shorter horizon (the paper's gamma is 0.99) with round 2's exploration schedule
    "eps30k_g95": {"eps_decay_frames": 30_000, "gamma": 0.95},
    "eps30k_g90": {"eps_decay_frames": 30_000, "gamma": 0.9},
    "nstep3_eps30k_g95": {"n_step": 3, "eps_decay_frames": 30_000, "gamma": 0.95},
    # round 4: a Polyak-averaged target (a small step after every gradient step) instead of a copy every 250
    "eps30k_polyak": {"eps_decay_frames": 30_000, "target_update_every": 1, "target_tau": 0.005},
    "eps30k_g90_polyak": {"eps_decay_frames": 30_000, "gamma": 0.9, "target_update_every": 1, "target_tau": 0.005},
    # round 5: the env stepped in a thread beside the gradient steps (benchmarks/dqn_overlap.py)
    "overlap": {"overlap_env": True},
    # round 6: round 3's best with it, on round 5's budget
    "overlap_eps30k_g90": {"overlap_env": True, "eps_decay_frames": 30_000, "gamma": 0.9},
    # round 7: half the learning rate, as the 3-DOF task's preset since 2026-12-06 (docs/tasks_3dof.md)
    "overlap_lr25": {"overlap_env": True, "lr": 2.5e-4},
    # round 8: smaller shared layers (PPO's round 8 found the update's arithmetic worth cutting)
    "overlap_h128": {"overlap_env": True, "hidden": [128, 128]},
}
SEARCHES = {"ppo": (BEFORE, CONFIGS, "abduction_4m", "runs/ppo_wallclock"),
            "bdq": (BDQ_BEFORE, BDQ_CONFIGS, "abduction_4m_discrete", "runs/bdq_wallclock")}
DEGREES = ("2.0", "1.0", "0.5")
# issue 15's goals, median of 3 seeds: (training seconds, test MAE deg, label)
GOALS = {"ppo": ((8.0, 1.0, "goal: 1 deg in 8 s"), (20.0, 0.5, "goal: 0.5 deg in 20 s")),
         "bdq": ((20.0, 1.0, "goal: 1 deg in 20 s"),)}


def _median(values):
    values = [v for v in values if v is not None]
    return statistics.median(values) if values else None


def _cell(runs: list[dict], deg: str) -> str:
    hits = [m["to_accuracy"].get(deg) for m in runs]
    reached = [h for h in hits if h is not None]
    if len(reached) * 2 <= len(runs):  # the median over seeds is "not reached" when half or more never got there
        return f"– ({len(reached)}/{len(runs)})"
    # a seed that never reached counts as slower than every one that did
    wall = sorted(h["wall_s"] for h in reached) + [float("inf")] * (len(runs) - len(reached))
    frames = sorted(h["frames"] for h in reached) + [float("inf")] * (len(runs) - len(reached))
    return f"{statistics.median(wall):.1f} s · {statistics.median(frames) / 1e3:.0f}k ({len(reached)}/{len(runs)})"


def table(results: dict[str, list[dict]], task: str, algo: str = "ppo") -> str:
    before, configs, _, _ = SEARCHES[algo]
    head = ["config", "overrides", "seeds", *[f"to {float(d):g} deg: wall · frames (seeds)" for d in DEGREES],
            "final MAE (median, deg)", "frames/s (median)"]
    lines = [f"{algo.upper()} on `{task}` (overrides of the defaults before the search, {json.dumps(before)}): "
             f"median over seeds of the training wall time (evaluations excluded) and frames to test "
             f"MAE at or below each threshold (a seed that never reached it counts as the slowest); evaluated every "
             f"--eval-every frames.", "", "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for name, runs in results.items():
        fps = _median([m["frames"] / (m["wall_s"] - m["eval_s"]) for m in runs])
        lines.append("| " + " | ".join([name, json.dumps(configs[name]) if configs[name] else "–", str(len(runs)),
                                        *[_cell(runs, d) for d in DEGREES],
                                        f"{_median([m['mae_deg'] for m in runs]):.2f}",
                                        "–" if fps is None else f"{fps:,.0f}"]) + " |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    from shoulder_bench.eval.experiment import train

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--algo", choices=list(SEARCHES), default="ppo")
    p.add_argument("--configs", nargs="+", help="names from CONFIGS (ppo) or BDQ_CONFIGS (bdq); default all")
    p.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    p.add_argument("--frames", type=int, default=600_000)
    p.add_argument("--eval-every", type=int, default=20_000)
    p.add_argument("--task", help="default: abduction_4m (ppo), abduction_4m_discrete (bdq)")
    p.add_argument("--out", type=Path, help="default: runs/ppo_wallclock (ppo), runs/bdq_wallclock (bdq)")
    args = p.parse_args(argv)
    before, configs, task, out = SEARCHES[args.algo]
    args.configs = args.configs or list(configs)
    unknown = [c for c in args.configs if c not in configs]
    if unknown:
        p.error(f"unknown {args.algo} config(s) {', '.join(unknown)}; known: {', '.join(configs)}")
    args.task, args.out = args.task or task, args.out or Path(out)
    results: dict[str, list[dict]] = {name: [] for name in args.configs}
    for seed in args.seeds:
        for name in args.configs:
            out = args.out / name / str(seed)
            cfg = args.out / name / "config.json"
            cfg.parent.mkdir(parents=True, exist_ok=True)
            cfg.write_text(json.dumps(before | configs[name]))
            m = train(args.task, args.algo, args.frames, seed, out, resume=True, config=cfg, eval_every=args.eval_every)
            results[name].append(m)
            print(f"{name} seed {seed}: MAE {m['mae_deg']:.2f} deg, to_accuracy {m['to_accuracy']}", flush=True)
    text = table(results, args.task, args.algo)
    (args.out / "table.md").write_text(text)
    print(text)
    for path in figure(results, args.task, args.algo, args.out / "wallclock.png"):
        print(path)
    return 0


def figure(results: dict[str, list[dict]], task: str, algo: str, out: Path) -> list[Path]:
    """`<out>` (and its SVG): every run's test MAE against training seconds and frames, the goals marked."""
    from shoulder_bench.eval.plots import save, wallclock_figure

    curves = {name: [m.get("evaluations") or [] for m in runs]  # a run folder from before the curve was kept: none
              for name, runs in results.items()}
    return save(wallclock_figure(curves, GOALS[algo], f"{algo.upper()} on {task}: time to accuracy"), out)


if __name__ == "__main__":
    raise SystemExit(main())
