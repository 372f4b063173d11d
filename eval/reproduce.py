"""`shoulder-bench reproduce`: the paper's experiments on our model, several seeds each, as a table next to the
paper's numbers; `--ship` copies the best seed of each experiment into the package's pretrained agents."""
from __future__ import annotations

import json
import math
import os
import shutil
from pathlib import Path

import numpy as np

# name -> (task, algo, frames, the paper's (MAE, RMSE) on their FEM model). PPO gets half the paper's 1.6 M frames:
# on this model PPO-4 passes the paper's accuracy at the first test evaluation (100k frames) and keeps improving.
EXPERIMENTS = {
    "dqn_ssp": ("abduction_ssp_discrete", "dqn", 200_000, (3.70, 5.78)),
    "ppo_ssp": ("abduction_ssp", "ppo", 800_000, (4.00, 5.36)),
    "ppo_4m": ("abduction_4m", "ppo", 800_000, (5.15, 6.64)),
    "bdq_4m": ("abduction_4m_discrete", "bdq", 500_000, None),
}
TABLE = Path("docs/reproduction.md")


def check_args(args) -> None:
    """The inputs, checked before any training: a positive finite budget scale, folders and a table file that can
    be written."""
    if not (math.isfinite(args.frames_scale) and args.frames_scale > 0):
        raise ValueError(f"--frames-scale {args.frames_scale}: give a positive number (e.g. 0.01 to smoke-test)")
    if args.runs.exists() and not args.runs.is_dir():
        raise ValueError(f"--runs {args.runs} is an existing file, not a folder; give a folder for the runs")
    if args.table.is_dir():
        raise ValueError(f"--table {args.table} is a directory; give a file name such as {args.table / 'table.md'}")


def run(args) -> int:
    from shoulder_bench.eval.experiment import train
    from shoulder_bench.eval.plots import replace_all

    check_args(args)
    results = {}
    for name in args.experiments:
        task, algo, frames, _ = EXPERIMENTS[name]
        results[name] = []
        for seed in args.seeds:
            out = args.runs / task / algo / str(seed)
            m = train(task, algo, frames=max(1, int(frames * args.frames_scale)), seed=seed, out=out, resume=True)
            results[name].append((seed, out, m))
    text = table(results)
    replace_all([(args.table, lambda tmp: tmp.write_text(text, encoding="utf-8"))])
    print(text)
    if args.ship:
        ship(results)
    return 0


def table(results: dict) -> str:
    lines = ["| experiment | task | frames | test MAE (deg) | test RMSE (deg) | crashes | wall (s) "
             "| frames to 5.15 deg | paper MAE / RMSE |", "|---|---|---|---|---|---|---|---|---|"]
    for name, runs in results.items():
        task, algo, _, paper = EXPERIMENTS[name]
        ms = [m for _, _, m in runs]
        mae, rmse = np.array([m["mae_deg"] for m in ms]), np.array([m["rmse_deg"] for m in ms])
        hit = [m.get("frames_to_paper_accuracy") for m in ms]
        hit_s = ", ".join("–" if h is None else f"{h / 1e6:.2f} M" for h in hit)
        paper_s = (f"{paper[0]:.2f} / {paper[1]:.2f}" if paper
                   else "— (paper: infeasible for DQN; its PPO-4 5.15 / 6.64)")
        lines.append(f"| {name} ({algo.upper()}, {len(ms)} seeds) | `{task}` | {ms[0]['frames']:,} | "
                     f"{mae.mean():.2f} ± {mae.std():.2f} | {rmse.mean():.2f} ± {rmse.std():.2f} | "
                     f"{sum(m['crashes'] for m in ms)} | {np.mean([m['wall_s'] for m in ms]):.0f} | {hit_s} | "
                     f"{paper_s} |")
    return "\n".join(lines) + "\n"


def ship(results: dict) -> None:
    from shoulder_bench.eval.plots import replace_all
    from shoulder_bench.train.policy import pretrained_dir

    dest = pretrained_dir()
    dest.mkdir(parents=True, exist_ok=True)
    for name, runs in results.items():
        seed, out, m = min(runs, key=lambda r: r[2]["mae_deg"])
        tmp = dest / f".{name}.pt.tmp{os.getpid()}"
        shutil.copy(out / "policy.pt", tmp)
        os.replace(tmp, dest / f"{name}.pt")
        record = {"source_run": str(out), "seed": seed, "mae_deg": m["mae_deg"], "rmse_deg": m["rmse_deg"],
                  "crashes": m["crashes"], "frames": m["frames"], "wall_s": m["wall_s"],
                  "frames_to_paper_accuracy": m.get("frames_to_paper_accuracy"),
                  "per_trajectory_mae_deg": m["per_trajectory"]["mae_deg"]}
        text = json.dumps(record, indent=1) + "\n"
        replace_all([(dest / f"{name}.json", lambda tmp, text=text: tmp.write_text(text, encoding="utf-8"))])
        print(f"shipped {name}: seed {seed}, test MAE {m['mae_deg']:.2f} deg")
