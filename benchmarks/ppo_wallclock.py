"""Training wall time to accuracy for PPO configs (issue 15 §3): each config trains `abduction_4m` for several seeds,
one run after the other, and the table gives the median over seeds of the training wall time (evaluations excluded,
`metrics.json` `to_accuracy`) and frames to test MAE <= 2, 1 and 0.5 deg, the final MAE and the frames/s.

    .venv/bin/python benchmarks/ppo_wallclock.py [--configs default e1m8t2 ...] [--seeds 0 1 2] [--frames 600000]
        [--eval-every 20000] [--out runs/ppo_wallclock] [--task abduction_4m]

Configs are overrides of `PPOConfig`'s defaults before this search (`BEFORE`: 256 envs, 5 epochs x 4 mini-batches;
`CONFIGS` below; `default` is `BEFORE` itself; the search chose `e1m8t1_n64`, today's `PPOConfig()`). Runs are normal
run folders (`<out>/<config>/<seed>`), so a rerun resumes or reuses finished ones; `<out>/table.md` is rewritten at
the end. The runs alternate configs within each seed (seed 0 of every config, then seed 1, ...), so that a change in
the machine's load spreads over all configs. Wall times are this machine's: compare configs only within one table.
"""
from __future__ import annotations

import argparse
import json
import statistics
from pathlib import Path

BEFORE = {"num_envs": 256, "num_learning_epochs": 5, "num_mini_batches": 4}  # PPOConfig's defaults before the search
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
    "e1m8t1_n64": {"num_learning_epochs": 1, "num_mini_batches": 8, "num_envs": 64},
}
DEGREES = ("2.0", "1.0", "0.5")


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


def table(results: dict[str, list[dict]], task: str) -> str:
    head = ["config", "overrides", "seeds", *[f"to {float(d):g} deg: wall · frames (seeds)" for d in DEGREES],
            "final MAE (median, deg)", "frames/s (median)"]
    lines = [f"PPO on `{task}` (overrides of the defaults before the search, {json.dumps(BEFORE)}): median over "
             f"seeds of the training wall time (evaluations excluded) and frames to test "
             f"MAE at or below each threshold (a seed that never reached it counts as the slowest); evaluated every "
             f"--eval-every frames.", "", "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for name, runs in results.items():
        fps = _median([m["frames"] / (m["wall_s"] - m["eval_s"]) for m in runs])
        lines.append("| " + " | ".join([name, json.dumps(CONFIGS[name]) if CONFIGS[name] else "–", str(len(runs)),
                                        *[_cell(runs, d) for d in DEGREES],
                                        f"{_median([m['mae_deg'] for m in runs]):.2f}",
                                        "–" if fps is None else f"{fps:,.0f}"]) + " |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    from shoulder_bench.eval.experiment import train

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--configs", nargs="+", default=list(CONFIGS), choices=list(CONFIGS))
    p.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    p.add_argument("--frames", type=int, default=600_000)
    p.add_argument("--eval-every", type=int, default=20_000)
    p.add_argument("--task", default="abduction_4m")
    p.add_argument("--out", type=Path, default=Path("runs/ppo_wallclock"))
    args = p.parse_args(argv)
    results: dict[str, list[dict]] = {name: [] for name in args.configs}
    for seed in args.seeds:
        for name in args.configs:
            out = args.out / name / str(seed)
            cfg = args.out / name / "config.json"
            cfg.parent.mkdir(parents=True, exist_ok=True)
            cfg.write_text(json.dumps(BEFORE | CONFIGS[name]))
            m = train(args.task, "ppo", args.frames, seed, out, resume=True, config=cfg, eval_every=args.eval_every)
            results[name].append(m)
            print(f"{name} seed {seed}: MAE {m['mae_deg']:.2f} deg, to_accuracy {m['to_accuracy']}", flush=True)
    text = table(results, args.task)
    (args.out / "table.md").write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
