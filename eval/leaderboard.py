"""`shoulder-bench leaderboard [--runs DIR] [--out DIR]`: one row per task x algorithm, on the fixed test set and on the
synthetic combing-like profile, with the reference controller and the paper's numbers as reference rows.

Written as Markdown, CSV and a self-contained HTML page (the figure embedded). Without runs (or when the folder holds
none) the rows are the shipped pretrained agents (one seed each).
"""
from __future__ import annotations

import base64
import csv
import io
import json
from collections import defaultdict
from pathlib import Path

import numpy as np

from shoulder_bench.eval.evaluate import evaluate, trajectories_for

PAPER = [  # their ArtiSynth FEM model, 100 test trajectories (combing: their in-vivo recording)
    {"task": "abduction_ssp_discrete", "algo": "paper DQN", "test_mae": 3.70, "test_rmse": 5.78},
    {"task": "abduction_ssp", "algo": "paper PPO", "test_mae": 4.00, "test_rmse": 5.36},
    {"task": "abduction_4m", "algo": "paper PPO-4", "test_mae": 5.15, "test_rmse": 6.64, "combing_mae": 6.57,
     "combing_rmse": 7.67},
]
COLUMNS = ["task", "algo", "seeds", "test_mae", "test_rmse", "combing_mae", "combing_rmse", "frames_to_paper",
           "wall_s", "crashes"]


def add_parser(sub) -> None:
    p = sub.add_parser("leaderboard", help="compare runs (or the pretrained agents), the reference and the paper")
    p.add_argument("--runs", type=Path, default=None, help="a folder of runs (runs/<task>/<algo>/<seed>)")
    p.add_argument("--out", type=Path, default=Path("leaderboard"))
    p.set_defaults(func=_run)


def _mean_std(values) -> tuple[float, float]:
    v = np.array([x for x in values if x is not None], dtype=float)
    return (float(v.mean()), float(v.std())) if v.size else (float("nan"), float("nan"))


def collect(runs: Path | None) -> list[dict]:
    """Rows (dicts with COLUMNS) for runs, or pretrained agents, plus the reference controller and the paper."""
    from shoulder_bench.eval.reference import ReferenceController
    from shoulder_bench.train.policy import load_policy, pretrained_dir

    combing = trajectories_for("combing")
    groups: dict[tuple, list[dict]] = defaultdict(list)
    found = sorted(Path(runs).glob("*/*/*/metrics.json")) if runs is not None else []
    if runs is not None and not found:
        raise FileNotFoundError(f"{runs} holds no finished runs (runs/<task>/<algo>/<seed>/metrics.json)")
    sources = [(p.parent, str(p.parent)) for p in found] or [
        (None, f"pretrained:{p.stem}") for p in sorted(pretrained_dir().glob("*.pt"))]
    for folder, spec in sources:
        policy, meta = load_policy(spec)
        metrics = json.loads((folder / "metrics.json").read_text()) if folder else meta["test"] | {"frames": None}
        comb = evaluate(policy, meta["task"], combing, muscle_model=meta.get("muscle_model"))
        groups[(meta["task"], meta["algo"])].append({
            "test_mae": metrics["mae_deg"], "test_rmse": metrics["rmse_deg"], "crashes": metrics["crashes"],
            "combing_mae": comb["mae_deg"], "combing_rmse": comb["rmse_deg"],
            "frames_to_paper": metrics.get("frames_to_paper_accuracy"), "wall_s": metrics.get("wall_s")})
    rows = []
    for (task, algo), entries in sorted(groups.items()):
        row = {"task": task, "algo": algo, "seeds": len(entries),
               "crashes": sum(e["crashes"] for e in entries)}
        for key in ("test_mae", "test_rmse", "combing_mae", "combing_rmse", "frames_to_paper", "wall_s"):
            row[key] = _mean_std(e[key] for e in entries)
        rows.append(row)
    test = trajectories_for("test")
    for task in ("abduction_ssp", "abduction_4m"):
        ref = ReferenceController(task)
        t, c = evaluate(ref, task, test), evaluate(ref, task, combing)
        rows.append({"task": task, "algo": "reference controller", "seeds": 1, "crashes": t["crashes"],
                     "test_mae": (t["mae_deg"], 0.0), "test_rmse": (t["rmse_deg"], 0.0),
                     "combing_mae": (c["mae_deg"], 0.0), "combing_rmse": (c["rmse_deg"], 0.0),
                     "frames_to_paper": (float("nan"), 0.0), "wall_s": (float("nan"), 0.0)})
    for p in PAPER:
        rows.append({k: (p[k], 0.0) if k in p and k not in ("task", "algo") else p.get(k, "") for k in COLUMNS}
                    | {"task": p["task"], "algo": p["algo"], "seeds": "", "crashes": ""})
    return rows


def _cell(value) -> str:
    if isinstance(value, tuple):
        m, s = value
        if not np.isfinite(m):
            return "–"
        if m >= 1000:
            return f"{m / 1e6:.2f} M"
        return f"{m:.2f} ± {s:.2f}" if s else f"{m:.2f}"
    return str(value)


HEAD = ["task", "algorithm", "seeds", "test MAE (deg)", "test RMSE (deg)", "combing MAE (deg, synthetic)",
        "combing RMSE (deg, synthetic)", "frames to 5.15 deg", "wall (s)", "crashes"]


def write(rows: list[dict], out: Path) -> dict[str, Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out.mkdir(parents=True, exist_ok=True)
    table = [[_cell(r[c]) for c in COLUMNS] for r in rows]
    md = "| " + " | ".join(HEAD) + " |\n|" + "---|" * len(HEAD) + "\n" + "".join(
        "| " + " | ".join(line) + " |\n" for line in table)
    paths = {"md": out / "leaderboard.md", "csv": out / "leaderboard.csv", "html": out / "leaderboard.html"}
    paths["md"].write_text(md)
    with paths["csv"].open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow([h for c in COLUMNS for h in ((c,) if c in ("task", "algo", "seeds", "crashes")
                                                 else (f"{c}_mean", f"{c}_std"))])
        for r in rows:
            w.writerow([v for c in COLUMNS for v in ((r[c],) if c in ("task", "algo", "seeds", "crashes")
                                                     else r[c] if isinstance(r[c], tuple) else ("", ""))])
    fig, ax = plt.subplots(figsize=(9, 0.35 * len(rows) + 1))
    labels = [f"{r['algo']} · {r['task']}" for r in rows]
    means = [r["test_mae"][0] if isinstance(r["test_mae"], tuple) else np.nan for r in rows]
    stds = [r["test_mae"][1] if isinstance(r["test_mae"], tuple) else 0 for r in rows]
    ax.barh(labels, means, xerr=stds, color=["gray" if "paper" in r["algo"] else "tab:blue" for r in rows])
    ax.set(xscale="log", xlabel="test-set MAE (deg), log scale")
    ax.invert_yaxis()
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    img = base64.b64encode(buf.getvalue()).decode()
    cells = "".join("<tr>" + "".join(f"<td>{c}</td>" for c in line) + "</tr>" for line in table)
    paths["html"].write_text(
        "<!doctype html><meta charset='utf-8'><title>shoulder_bench leaderboard</title>"
        "<style>body{font-family:sans-serif;margin:2em}td,th{border:1px solid #ccc;padding:4px 8px}"
        "table{border-collapse:collapse}</style><h1>shoulder_bench leaderboard</h1>"
        "<p>Fixed test set: 100 trajectories of 20 s. Combing: a <b>synthetic</b> profile (the paper's in-vivo "
        "recording is not public). Paper rows: their ArtiSynth FEM model.</p>"
        f"<table><tr>{''.join(f'<th>{h}</th>' for h in HEAD)}</tr>{cells}</table>"
        f"<p><img alt='test MAE per row' src='data:image/png;base64,{img}'></p>")
    return paths


def _run(args) -> int:
    paths = write(collect(args.runs), args.out)
    print(paths["md"].read_text())
    print("\n".join(str(p) for p in paths.values()))
    return 0
