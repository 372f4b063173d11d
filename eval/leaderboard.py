"""`shoulder-bench leaderboard [--runs DIR] [--pretrained] [--out DIR]`: one row per source and everything that defines
a run but its seed (task, algorithm, muscle model, task options, model version, frame budget, algorithm config), on the
fixed test set and on the synthetic combing-like profile, with the reference controller and the paper's numbers as
reference rows, the paper's qualitative findings measured (saw-tooth rate, ssp + isp share early and late). Runs that
differ only in their seed are averaged as seeds of one row; where rows of one task and algorithm differ in budget or
config, a `variant` column says how (the frames, or a short hash of the config).

Written as Markdown, CSV and a self-contained HTML page (figures embedded). Without runs the rows are the shipped
pretrained agents (one seed each); `--pretrained` adds them next to the runs. Every run and policy is read and checked
before any evaluation, and the three files are renamed into place together once all are complete.
"""
from __future__ import annotations

import base64
import csv
import hashlib
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
COLUMNS = ["task", "algo", "muscle_model", "options", "model_version", "variant", "source", "seeds", "test_mae",
           "test_rmse", "combing_mae", "combing_rmse",
           "frames_to_paper", "wall_s", "crashes", "sawtooth_per_s", "early_share", "late_share"]
SAME_SHARE = 0.05  # shares closer than 5 points: no clear early/late difference
TEXT = ("task", "algo", "muscle_model", "options", "model_version", "variant", "source", "seeds",
        "crashes")  # the columns that are not (mean, std) pairs
SETTING = ("task", "algo", "muscle_model", "options", "model_version")  # shown as columns of their own
NOT_SETTING = ("seed", "frames_asked", "frames_per_iteration", "test")  # recorded, but not what defines a row


def paper_errors(task: str, algo: str | None) -> tuple[float, float] | None:
    """The paper's test (MAE, RMSE) for `algo` on `task`, where the paper ran that algorithm on that task."""
    if algo not in ("ppo", "dqn"):
        return None
    return next(((p["test_mae"], p["test_rmse"]) for p in PAPER if p["task"] == task), None)


def _mean_std(values) -> tuple[float, float]:
    v = np.array([x for x in values if x is not None], dtype=float)
    return (float(v.mean()), float(v.std())) if v.size else (float("nan"), float("nan"))


def model_version() -> str:
    """The version of the model the board evaluates on now (the reference controller's rows)."""
    from shoulder_bench.arm import MODEL_VERSION

    return str(MODEL_VERSION)


def setting_of(info: dict) -> dict:
    """What defines a row: everything a run's config.json (or a policy's metadata) records but the seed, with the
    defaults of records older than a field (options {}, model version "1", the default muscle model)."""
    from shoulder_bench.model import DEFAULT_MUSCLE_MODEL

    out = {k: v for k, v in info.items() if k not in NOT_SETTING}
    out["muscle_model"] = out.get("muscle_model") or DEFAULT_MUSCLE_MODEL
    out["options"] = out.get("options") or {}
    out["model_version"] = str(out.get("model_version") or "1")
    if isinstance(out.get("config"), dict):  # DQN's config repeats the seed
        out["config"] = {k: v for k, v in out["config"].items() if k != "seed"}
    return json.loads(json.dumps(out, default=str, sort_keys=True))


def _read_json(path: Path) -> dict:
    try:
        data = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ValueError(f"{path} is unreadable or not valid JSON ({exc})") from None
    if not isinstance(data, dict):
        raise ValueError(f"{path} holds no JSON object: not written by shoulder-bench")
    return data


def _entries(runs: Path | None, pretrained: bool) -> list[dict]:
    """Every policy on the board (spec, source label, policy, setting, metrics record), each run folder and policy
    read and checked before any evaluation."""
    from shoulder_bench.eval.evaluate import policy_for, run_config
    from shoulder_bench.train.policy import pretrained_dir

    out = []
    if runs is not None:
        runs = Path(runs)
        if not runs.is_dir():
            raise FileNotFoundError(f"--runs {runs}: " + ("no such folder" if not runs.exists() else "not a folder")
                                    + "; give a folder of runs (runs/<task>/<algo>/<seed>)")
        found = sorted(p.parent for p in runs.glob("*/*/*/metrics.json"))
        if not found:
            raise FileNotFoundError(f"{runs} holds no finished runs (runs/<task>/<algo>/<seed>/metrics.json)")
        for run in found:
            cfg = run_config(run)
            metrics = _read_json(run / "metrics.json")
            policy, meta, _ = policy_for(str(run))
            out.append({"spec": str(run), "source": f"runs: {runs}", "policy": policy, "metrics": metrics,
                        "setting": setting_of({"muscle_model": meta.get("muscle_model")} | cfg)})
    if pretrained or runs is None:  # each agent's record (its source run's metrics) lies beside it
        for p in sorted(pretrained_dir().glob("*.pt")):
            policy, meta, _ = policy_for(f"pretrained:{p.stem}")
            record = p.with_suffix(".json")
            out.append({"spec": f"pretrained:{p.stem}", "source": "shipped agent", "policy": policy,
                        "metrics": _read_json(record) if record.exists() else {}, "setting": setting_of(meta)})
    return out


def _variants(settings: list[dict]) -> list[str]:
    """A short label per setting saying how it differs from the others of its task, algorithm, muscle model,
    options and model version ("" where nothing does): the frames, else a hash of each differing field."""
    labels = []
    for s in settings:
        peers = [t for t in settings if all(t[k] == s[k] for k in SETTING)]
        differ = sorted({k for t in peers for k in set(s) | set(t) if k not in SETTING and s.get(k) != t.get(k)},
                        key=lambda k: (k != "frames", k))
        parts = [f"{s[k]:,} frames" if k == "frames" and isinstance(s.get(k), int) else
                 f"{k} {hashlib.sha1(json.dumps(s.get(k), sort_keys=True).encode()).hexdigest()[:6]}"
                 for k in differ]
        labels.append(" · ".join(parts))
    return labels


def options_text(options) -> str:
    """Task options as `key=value, ...`; "default" for none."""
    if not isinstance(options, dict):
        return str(options)
    return ", ".join(f"{k}={v}" for k, v in sorted(options.items())) or "default"


def _score(policy, task: str, muscle_model, test, combing, options: dict | None = None) -> dict:
    """Test-set and combing metrics plus the qualitative measures of one policy."""
    from shoulder_bench.eval.measures import measures
    from shoulder_bench.tasks import TASKS

    t = evaluate(policy, task, test, muscle_model=muscle_model, record=True, options=options)
    c = evaluate(policy, task, combing, muscle_model=muscle_model, options=options)
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
    from shoulder_bench.model import DEFAULT_MUSCLE_MODEL

    entries = _entries(runs, pretrained)
    test, combing = trajectories_for("test"), trajectories_for("combing")
    groups: dict[tuple[str, str], list[dict]] = defaultdict(list)
    settings: dict[tuple[str, str], dict] = {}
    for e in tqdm(entries, desc="evaluating", unit="policy", disable=not progress):
        s = e["setting"]
        key = (e["source"], json.dumps(s, sort_keys=True))
        settings[key] = s
        groups[key].append(_score(e["policy"], s["task"], s["muscle_model"], test, combing, s["options"])
                           | {"frames_to_paper": e["metrics"].get("frames_to_paper_accuracy"),
                              "wall_s": e["metrics"].get("wall_s")})
    for task in tqdm(("abduction_ssp", "abduction_4m"), desc="reference controller", disable=not progress):
        s = {"task": task, "algo": "reference controller", "muscle_model": DEFAULT_MUSCLE_MODEL, "options": {},
             "model_version": model_version()}
        key = ("model-based", json.dumps(s, sort_keys=True))
        settings[key] = s
        groups[key].append(_score(ReferenceController(task), task, None, test, combing)
                           | {"frames_to_paper": None, "wall_s": None})
    keys = sorted(groups, key=lambda k: (k[0] == "model-based", settings[k]["task"], settings[k]["algo"], k))
    variants = dict(zip(keys, _variants([settings[k] for k in keys])))
    rows = []
    for key in keys:
        s, entries = settings[key], groups[key]
        row = {k: s[k] for k in SETTING} | {"variant": variants[key], "source": key[0], "seeds": len(entries),
                                             "crashes": sum(e["crashes"] for e in entries)}
        for col in COLUMNS:
            if col not in TEXT:
                row[col] = _mean_std(e.get(col) for e in entries)
        row["per_trajectory_mae"] = [x for e in entries for x in e["per_trajectory"]["mae_deg"]]
        row["per_trajectory_rmse"] = [x for e in entries for x in e["per_trajectory"]["rmse_deg"]]
        reached = sum(e["frames_to_paper"] is not None for e in entries)
        row["reached"] = f"{reached}/{len(entries)}" if any(e["wall_s"] is not None for e in entries) else ""
        rows.append(row)
    for p in PAPER:
        rows.append({k: (p[k], 0.0) if k in p and k not in TEXT else p.get(k, "") for k in COLUMNS}
                    | {"task": p["task"], "algo": p["algo"], "muscle_model": "their FEM", "options": "",
                       "model_version": "", "variant": "", "source": "paper (their FEM model)", "seeds": "",
                       "crashes": "", "reached": ""})
    return rows


def where(row: dict) -> str:
    """A row's source, with whatever sets it apart from the default setting (muscle model, options, model version,
    variant)."""
    from shoulder_bench.model import DEFAULT_MUSCLE_MODEL

    extra = [f"{row['muscle_model']} muscles" if row["muscle_model"] != DEFAULT_MUSCLE_MODEL else "",
             options_text(row["options"]) if row["options"] else "",
             f"model v{row['model_version']}" if row["model_version"] != model_version() else "", row["variant"]]
    return "; ".join([row["source"]] + [x for x in extra if x])


def findings(rows: list[dict]) -> list[str]:
    """The paper's qualitative findings, as measured on this board (one sentence each)."""
    def value(row, key):
        return row[key][0] if isinstance(row.get(key), tuple) else float("nan")

    learned = [r for r in rows if r["algo"] in ("ppo", "dqn", "bdq")]
    out = []
    for muscles, tag in (("ssp", "one muscle (ssp)"), ("4m", "four muscles")):
        ppo = [r for r in learned if r["algo"] == "ppo" and r["task"] == f"abduction_{muscles}"]
        dqn = [r for r in learned if r["algo"] != "ppo" and r["task"] == f"abduction_{muscles}_discrete"]
        same = ("source", "muscle_model", "options", "model_version")
        for a, b in ((x, y) for x in dqn for y in ppo if all(x[k] == y[k] for k in same)):
            ratio = value(a, "sawtooth_per_s") / value(b, "sawtooth_per_s")
            out.append(f"Saw-tooth, {tag} ({where(a)}): {a['algo'].upper()} {value(a, 'sawtooth_per_s'):.2f} "
                       f"against PPO {value(b, 'sawtooth_per_s'):.2f} sign changes of delta-activation per second "
                       f"({ratio:.1f}x; paper: DQN saw-tooth, PPO smooth).")
    for r in (r for r in learned if r["algo"] == "ppo" and r["task"] == "abduction_4m"):
        (early, e_sd), (late, l_sd) = r["early_share"], r["late_share"]
        if abs(early - late) <= SAME_SHARE:
            verdict = "no clear difference; the paper saw ssp and isp initiate abduction and then fade"
        else:
            verdict = "as in the paper" if early > late else "the opposite of the paper, where ssp and isp fade"
        spread = f" (± {e_sd:.0%} / ± {l_sd:.0%} over {r['seeds']} seeds)" if r["seeds"] > 1 else ""
        out.append(f"ssp + isp share of the summed activation, PPO-4 ({where(r)}): {early:.0%} below 45 deg "
                   f"against {late:.0%} at or above{spread}: {verdict}.")
    return out


def _pair(value, digits: int = 2) -> str:
    m, s = value
    if not np.isfinite(m):
        return "–"
    return f"{m:.{digits}f} ± {s:.{digits}f}" if s else f"{m:.{digits}f}"


def head(variant: bool) -> list[str]:
    """The Markdown / HTML column titles; the variant column only where some row has one."""
    return HEAD[:5] + (["variant"] if variant else []) + HEAD[5:]


def cells(row: dict, variant: bool = False) -> list[str]:
    """The Markdown / HTML cells of one row (head(variant)'s order)."""
    setting = [row["task"], row["algo"], row["muscle_model"],
               options_text(row["options"]) if "paper" not in row["source"] else "", row["model_version"]]
    setting += [row["variant"]] if variant else []
    if "paper" in row["source"]:
        return setting + [row["source"], "", _pair(row["test_mae"]), _pair(row["test_rmse"]),
                _pair(row["combing_mae"]) if row["combing_mae"] else "", _pair(row["combing_rmse"])
                if row["combing_rmse"] else "", "", "", "", "", ""]
    frames = row["frames_to_paper"][0]
    reached = f" ({row['reached']})" if row["reached"] else ""
    early, late = row["early_share"][0], row["late_share"][0]
    return setting + [row["source"], str(row["seeds"]), _pair(row["test_mae"]),
            _pair(row["test_rmse"]), _pair(row["combing_mae"]), _pair(row["combing_rmse"]),
            ("–" if not np.isfinite(frames) else f"{frames / 1e6:.2f} M") + reached if row["reached"] else "–",
            _pair(row["wall_s"], 0), str(row["crashes"]), _pair(row["sawtooth_per_s"]),
            f"{early:.0%} / {late:.0%}" if np.isfinite(early) else "–"]


HEAD = ["task", "algorithm", "muscle model", "options", "model version", "source", "seeds", "test MAE (deg)",
        "test RMSE (deg)", "combing MAE (deg, synthetic)",
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
               + (f" ({where(r)})" if r["source"] != "model-based" else ""), paper_errors(r["task"], r["algo"]),
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
    """leaderboard.md, .csv and .html in `out`, all composed first and renamed into place together."""
    import html

    from shoulder_bench.eval.plots import checked_dir, replace_all

    out = checked_dir(out, "--out")
    variant = any(r["variant"] for r in rows)
    titles = head(variant)
    table = [cells(r, variant) for r in rows]
    found = findings(rows)
    md = ("| " + " | ".join(titles) + " |\n|" + "---|" * len(titles) + "\n"
          + "".join("| " + " | ".join(line) + " |\n" for line in table)
          + "\n" + NOTES + "\n" + ("\n**The paper's qualitative findings, measured:**\n\n" if found else "")
          + "".join(f"- {f}\n" for f in found))
    buf = io.StringIO()
    w = csv.writer(buf)
    w.writerow([h for c in COLUMNS for h in ((c,) if c in TEXT else (f"{c}_mean", f"{c}_std"))]
               + ["seeds_reaching_paper_accuracy"])
    for r in rows:
        text = r | {"options": json.dumps(r["options"], sort_keys=True) if isinstance(r["options"], dict) else ""}
        w.writerow([v for c in COLUMNS for v in ((text[c],) if c in TEXT else r[c] if isinstance(r[c], tuple)
                                                 else ("", ""))] + [r["reached"]])
    body = "".join("<tr>" + "".join(f"<td>{html.escape(c)}</td>" for c in line) + "</tr>" for line in table)
    notes = html.escape(NOTES).replace("**synthetic**", "<b>synthetic</b>")
    page = ("<!doctype html><meta charset='utf-8'><title>shoulder_bench leaderboard</title>"
            "<style>body{font-family:sans-serif;margin:2em}td,th{border:1px solid #ccc;padding:4px 8px}"
            "table{border-collapse:collapse}</style><h1>shoulder_bench leaderboard</h1>"
            f"<table><tr>{''.join(f'<th>{html.escape(h)}</th>' for h in titles)}</tr>{body}</table><p>{notes}</p>"
            + (f"<h2>The paper's qualitative findings, measured</h2><ul>"
               f"{''.join(f'<li>{html.escape(x)}</li>' for x in found)}</ul>" if found else "")
            + f"<p><img alt='per-trajectory test errors and saw-tooth rates' "
              f"src='data:image/png;base64,{_figure(rows)}'></p>")
    texts = {"md": md, "csv": buf.getvalue(), "html": page}
    paths = {k: out / f"leaderboard.{k}" for k in texts}
    replace_all([(paths[k], lambda tmp, text=texts[k]: tmp.write_text(text, encoding="utf-8")) for k in texts])
    return paths


