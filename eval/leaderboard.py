"""`shoulder-bench leaderboard [--runs DIR] [--pretrained] [--out DIR]`: one row per task x algorithm x source, on the
fixed test set and on the synthetic combing-like profile, with the reference controller and the paper's numbers as
reference rows, the paper's qualitative findings measured (saw-tooth rate, ssp + isp share early and late).

Written as Markdown, CSV and a self-contained HTML page (figures embedded). Without runs the rows are the shipped
pretrained agents (one seed each); `--pretrained` adds them next to the runs.
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
COLUMNS = ["task", "algo", "source", "seeds", "test_mae", "test_rmse", "combing_mae", "combing_rmse",
           "frames_to_paper", "wall_s", "crashes", "sawtooth_per_s", "early_share", "late_share"]
SAME_SHARE = 0.05  # shares closer than 5 points: no clear early/late difference
TEXT = ("task", "algo", "source", "seeds", "crashes")  # the columns that are not (mean, std) pairs


def paper_errors(task: str, algo: str | None) -> tuple[float, float] | None:
    """The paper's test (MAE, RMSE) for `algo` on `task`, where the paper ran that algorithm on that task."""
    if algo not in ("ppo", "dqn"):
        return None
    return next(((p["test_mae"], p["test_rmse"]) for p in PAPER if p["task"] == task), None)


def add_parser(sub) -> None:
    p = sub.add_parser("leaderboard", help="compare runs (or the pretrained agents), the reference and the paper")
    p.add_argument("--runs", type=Path, default=None, help="a folder of runs (runs/<task>/<algo>/<seed>)")
    p.add_argument("--pretrained", action="store_true", help="add the shipped agents' rows next to the runs'")
    p.add_argument("--out", type=Path, default=Path("leaderboard"))
    p.set_defaults(func=_run)


def _mean_std(values) -> tuple[float, float]:
    v = np.array([x for x in values if x is not None], dtype=float)
    return (float(v.mean()), float(v.std())) if v.size else (float("nan"), float("nan"))


def _sources(runs: Path | None, pretrained: bool) -> list[tuple[Path, str, str]]:
    """(metrics file, policy spec, source label) for every policy on the board."""
    from shoulder_bench.train.policy import pretrained_dir

    found = sorted(Path(runs).glob("*/*/*/metrics.json")) if runs is not None else []
    if runs is not None and not found:
        raise FileNotFoundError(f"{runs} holds no finished runs (runs/<task>/<algo>/<seed>/metrics.json)")
    out = [(p.parent / "metrics.json", str(p.parent), f"runs: {runs}") for p in found]
    if pretrained or runs is None:  # each agent's record (its source run's metrics) lies beside it
        out += [(p.with_suffix(".json"), f"pretrained:{p.stem}", "shipped agent")
                for p in sorted(pretrained_dir().glob("*.pt"))]
    return out


def _score(policy, task: str, muscle_model, test, combing) -> dict:
    """Test-set and combing metrics plus the qualitative measures of one policy."""
    from shoulder_bench.eval.measures import measures
    from shoulder_bench.tasks import TASKS

    t = evaluate(policy, task, test, muscle_model=muscle_model, record=True)
    c = evaluate(policy, task, combing, muscle_model=muscle_model)
    return {"test_mae": t["mae_deg"], "test_rmse": t["rmse_deg"], "crashes": t["crashes"] + c["crashes"],
            "combing_mae": c["mae_deg"], "combing_rmse": c["rmse_deg"], **measures(t["trace"], TASKS[task][0]),
            "per_trajectory": t["per_trajectory"]}


def collect(runs: Path | None, pretrained: bool = False, progress: bool = False) -> list[dict]:
    """Rows (dicts with COLUMNS) for runs and/or the shipped agents, the reference controller and the paper.

    Every policy is evaluated now, on the fixed test set (recorded, for the qualitative measures) and on the combing
    profile; frames to the paper's accuracy and wall time come from the runs' metrics.json (a shipped agent's from the
    record beside it)."""
    from tqdm import tqdm

    from shoulder_bench.eval.reference import ReferenceController
    from shoulder_bench.train.policy import load_policy

    test, combing = trajectories_for("test"), trajectories_for("combing")
    sources = _sources(runs, pretrained)
    groups: dict[tuple, list[dict]] = defaultdict(list)
    for record, spec, label in tqdm(sources, desc="evaluating", unit="policy", disable=not progress):
        policy, meta = load_policy(spec)
        metrics = json.loads(record.read_text()) if record.exists() else {}
        groups[(meta["task"], meta["algo"], label)].append(
            _score(policy, meta["task"], meta.get("muscle_model"), test, combing)
            | {"frames_to_paper": metrics.get("frames_to_paper_accuracy"), "wall_s": metrics.get("wall_s")})
    for task in tqdm(("abduction_ssp", "abduction_4m"), desc="reference controller", disable=not progress):
        groups[(task, "reference controller", "model-based")].append(
            _score(ReferenceController(task), task, None, test, combing) | {"frames_to_paper": None, "wall_s": None})
    rows = []
    for (task, algo, label), entries in sorted(groups.items(), key=lambda kv: (kv[0][2] == "model-based", kv[0])):
        row = {"task": task, "algo": algo, "source": label, "seeds": len(entries),
               "crashes": sum(e["crashes"] for e in entries)}
        for key in COLUMNS:
            if key not in TEXT:
                row[key] = _mean_std(e.get(key) for e in entries)
        row["per_trajectory_mae"] = [x for e in entries for x in e["per_trajectory"]["mae_deg"]]
        row["per_trajectory_rmse"] = [x for e in entries for x in e["per_trajectory"]["rmse_deg"]]
        reached = sum(e["frames_to_paper"] is not None for e in entries)
        row["reached"] = f"{reached}/{len(entries)}" if any(e["wall_s"] is not None for e in entries) else ""
        rows.append(row)
    for p in PAPER:
        rows.append({k: (p[k], 0.0) if k in p and k not in TEXT else p.get(k, "") for k in COLUMNS}
                    | {"task": p["task"], "algo": p["algo"], "source": "paper (their FEM model)", "seeds": "",
                       "crashes": "", "reached": ""})
    return rows


def findings(rows: list[dict]) -> list[str]:
    """The paper's qualitative findings, as measured on this board (one sentence each)."""
    def value(row, key):
        return row[key][0] if isinstance(row.get(key), tuple) else float("nan")

    learned = [r for r in rows if r["algo"] in ("ppo", "dqn", "bdq")]
    out = []
    for muscles, tag in (("ssp", "one muscle (ssp)"), ("4m", "four muscles")):
        ppo = [r for r in learned if r["algo"] == "ppo" and r["task"] == f"abduction_{muscles}"]
        dqn = [r for r in learned if r["algo"] != "ppo" and r["task"] == f"abduction_{muscles}_discrete"]
        for a, b in ((x, y) for x in dqn for y in ppo if x["source"] == y["source"]):
            ratio = value(a, "sawtooth_per_s") / value(b, "sawtooth_per_s")
            out.append(f"Saw-tooth, {tag} ({a['source']}): {a['algo'].upper()} {value(a, 'sawtooth_per_s'):.2f} "
                       f"against PPO {value(b, 'sawtooth_per_s'):.2f} sign changes of delta-activation per second "
                       f"({ratio:.1f}x; paper: DQN saw-tooth, PPO smooth).")
    for r in (r for r in learned if r["algo"] == "ppo" and r["task"] == "abduction_4m"):
        (early, e_sd), (late, l_sd) = r["early_share"], r["late_share"]
        if abs(early - late) <= SAME_SHARE:
            verdict = "no clear difference; the paper saw ssp and isp initiate abduction and then fade"
        else:
            verdict = "as in the paper" if early > late else "the opposite of the paper, where ssp and isp fade"
        spread = f" (± {e_sd:.0%} / ± {l_sd:.0%} over {r['seeds']} seeds)" if r["seeds"] > 1 else ""
        out.append(f"ssp + isp share of the summed activation, PPO-4 ({r['source']}): {early:.0%} below 45 deg "
                   f"against {late:.0%} at or above{spread}: {verdict}.")
    return out


def _pair(value, digits: int = 2) -> str:
    m, s = value
    if not np.isfinite(m):
        return "–"
    return f"{m:.{digits}f} ± {s:.{digits}f}" if s else f"{m:.{digits}f}"


def cells(row: dict) -> list[str]:
    """The Markdown / HTML cells of one row (HEAD's order)."""
    if "paper" in row["source"]:
        return [row["task"], row["algo"], row["source"], "", _pair(row["test_mae"]), _pair(row["test_rmse"]),
                _pair(row["combing_mae"]) if row["combing_mae"] else "", _pair(row["combing_rmse"])
                if row["combing_rmse"] else "", "", "", "", "", ""]
    frames = row["frames_to_paper"][0]
    reached = f" ({row['reached']})" if row["reached"] else ""
    early, late = row["early_share"][0], row["late_share"][0]
    return [row["task"], row["algo"], row["source"], str(row["seeds"]), _pair(row["test_mae"]),
            _pair(row["test_rmse"]), _pair(row["combing_mae"]), _pair(row["combing_rmse"]),
            ("–" if not np.isfinite(frames) else f"{frames / 1e6:.2f} M") + reached if row["reached"] else "–",
            _pair(row["wall_s"], 0), str(row["crashes"]), _pair(row["sawtooth_per_s"]),
            f"{early:.0%} / {late:.0%}" if np.isfinite(early) else "–"]


HEAD = ["task", "algorithm", "source", "seeds", "test MAE (deg)", "test RMSE (deg)", "combing MAE (deg, synthetic)",
        "combing RMSE (deg, synthetic)", "frames to 5.15 deg (seeds reaching it)", "wall (s)", "crashes",
        "saw-tooth (sign changes/s)", "ssp+isp share <45 / >=45 deg"]
NOTES = ("Fixed test set: 100 trajectories of 20 s, every policy evaluated when the board was built. Combing: a "
         "**synthetic** profile (the paper's in-vivo recording is not public). Paper rows: their ArtiSynth FEM model, "
         "not this one. Saw-tooth: sign changes of delta-activation per second and muscle on the test set. "
         "ssp+isp share: their part of the summed activation with the arm below 45 deg / at or above.")


def _figure(rows: list[dict]) -> str:
    """Per-trajectory test errors (box plots) and saw-tooth rates, as one base64 PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from shoulder_bench.eval.plots import error_boxes

    ranked = [r for r in rows if "per_trajectory_mae" in r]
    groups = [(f"{r['algo'].upper() if r['algo'] in ('ppo', 'dqn', 'bdq') else r['algo']} · {r['task']}"
               + (f" ({r['source']})" if r["source"] != "model-based" else ""), paper_errors(r["task"], r["algo"]),
               np.array(r["per_trajectory_mae"]), np.array(r["per_trajectory_rmse"])) for r in ranked]
    fig, axes = plt.subplots(1, 3, figsize=(15, 0.45 * len(groups) + 1.8), sharey=True,
                             gridspec_kw={"width_ratios": [2, 2, 1.2]})
    error_boxes(axes[0], axes[1], groups)
    axes[2].barh(range(1, len(ranked) + 1), [r["sawtooth_per_s"][0] for r in ranked],
                 xerr=[r["sawtooth_per_s"][1] for r in ranked], color="tab:blue")
    axes[2].set(xlabel="saw-tooth: sign changes of\ndelta-activation per s")
    axes[2].grid(alpha=0.3, axis="x")
    axes[0].invert_yaxis()
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    plt.close(fig)
    return base64.b64encode(buf.getvalue()).decode()


def write(rows: list[dict], out: Path) -> dict[str, Path]:
    import html

    out.mkdir(parents=True, exist_ok=True)
    table = [cells(r) for r in rows]
    found = findings(rows)
    md = ("| " + " | ".join(HEAD) + " |\n|" + "---|" * len(HEAD) + "\n"
          + "".join("| " + " | ".join(line) + " |\n" for line in table)
          + "\n" + NOTES + "\n" + ("\n**The paper's qualitative findings, measured:**\n\n" if found else "")
          + "".join(f"- {f}\n" for f in found))
    paths = {"md": out / "leaderboard.md", "csv": out / "leaderboard.csv", "html": out / "leaderboard.html"}
    paths["md"].write_text(md)
    with paths["csv"].open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow([h for c in COLUMNS for h in ((c,) if c in TEXT else (f"{c}_mean", f"{c}_std"))]
                   + ["seeds_reaching_paper_accuracy"])
        for r in rows:
            w.writerow([v for c in COLUMNS for v in ((r[c],) if c in TEXT else r[c] if isinstance(r[c], tuple)
                                                     else ("", ""))] + [r["reached"]])
    body = "".join("<tr>" + "".join(f"<td>{html.escape(c)}</td>" for c in line) + "</tr>" for line in table)
    notes = html.escape(NOTES).replace("**synthetic**", "<b>synthetic</b>")
    paths["html"].write_text(
        "<!doctype html><meta charset='utf-8'><title>shoulder_bench leaderboard</title>"
        "<style>body{font-family:sans-serif;margin:2em}td,th{border:1px solid #ccc;padding:4px 8px}"
        "table{border-collapse:collapse}</style><h1>shoulder_bench leaderboard</h1>"
        f"<table><tr>{''.join(f'<th>{html.escape(h)}</th>' for h in HEAD)}</tr>{body}</table><p>{notes}</p>"
        + (f"<h2>The paper's qualitative findings, measured</h2><ul>"
           f"{''.join(f'<li>{html.escape(x)}</li>' for x in found)}</ul>" if found else "")
        + f"<p><img alt='per-trajectory test errors and saw-tooth rates' src='data:image/png;base64,{_figure(rows)}'>"
          "</p>")
    return paths


def _run(args) -> int:
    paths = write(collect(args.runs, args.pretrained, progress=True), args.out)
    print(paths["md"].read_text())
    print("\n".join(str(p) for p in paths.values()))
    return 0
