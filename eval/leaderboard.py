"""`shoulder-bench leaderboard [--runs DIR] [--pretrained] [--suite NAME ...] [--out DIR]`: one row per source and
everything that defines a run but its seed (task, algorithm, muscle model, task options, model version, frame budget,
algorithm config), on the fixed test set (the `paper` suite), the synthetic combing-like profile and any further
suites, with the reference controller and the paper's numbers as reference rows. The columns, their 95 % bootstrap
intervals and the ranking (success, then MAE, then effort, within a muscle set) are `eval.board_columns`' and are
defined in docs/ranking.md; the paper's qualitative findings are measured (saw-tooth rate, ssp + isp share early and
late). Runs that differ only in their seed are seeds of one row; where rows of one task and algorithm differ in budget
or config, a `variant` column says how (the frames, or a short hash of the config).

Written as Markdown, CSV and a self-contained HTML page (figures embedded: error distributions, saw-tooth rates and
sample-efficiency curves). Without runs the rows are the shipped pretrained agents (one seed each); `--pretrained` adds
them next to the runs. Every suite, run and policy is read and checked before any evaluation, and the three files are
renamed into place together once all are complete.
"""
from __future__ import annotations

import hashlib
import json
from collections import defaultdict
from pathlib import Path

import numpy as np

from shoulder_bench.eval import board_columns as board
from shoulder_bench.eval.board_columns import CI, NOTES, TEXT, cells, csv_text, head, options_text
from shoulder_bench.eval.evaluate import evaluate, trajectories_for

PAPER = [  # their ArtiSynth FEM model, 100 test trajectories (combing: their in-vivo recording)
    {"task": "abduction_ssp_discrete", "algo": "paper DQN", "test_mae": 3.70, "test_rmse": 5.78},
    {"task": "abduction_ssp", "algo": "paper PPO", "test_mae": 4.00, "test_rmse": 5.36},
    {"task": "abduction_4m", "algo": "paper PPO-4", "test_mae": 5.15, "test_rmse": 6.64, "combing_mae": 6.57,
     "combing_rmse": 7.67},
]
SAME_SHARE = 0.05  # shares closer than 5 points: no clear early/late difference
SETTING = ("task", "algo", "muscle_model", "options", "model_version")  # shown as columns of their own
NOT_SETTING = ("seed", "frames_asked", "frames_per_iteration", "test")  # recorded, but not what defines a row


def paper_errors(task: str, algo: str | None) -> tuple[float, float] | None:
    """The paper's test (MAE, RMSE) for `algo` on `task`, where the paper ran that algorithm on that task."""
    if algo not in ("ppo", "dqn"):
        return None
    return next(((p["test_mae"], p["test_rmse"]) for p in PAPER if p["task"] == task), None)


def model_version() -> str:
    """The version of the model the board evaluates on now (the reference controller's rows)."""
    from shoulder_bench.arm import MODEL_VERSION

    return str(MODEL_VERSION)


def setting_of(info: dict) -> dict:
    """What defines a row: everything a run's config.json (or a policy's metadata) records but the seed, with the
    defaults of records older than a field (options {}, model version "1", the default muscle model, the
    algorithm's `run.ADDED_FIELDS`)."""
    from shoulder_bench.model import DEFAULT_MUSCLE_MODEL
    from shoulder_bench.train.run import with_added_fields

    out = {k: v for k, v in info.items() if k not in NOT_SETTING}
    out["muscle_model"] = out.get("muscle_model") or DEFAULT_MUSCLE_MODEL
    out["options"] = out.get("options") or {}
    out["model_version"] = str(out.get("model_version") or "1")
    if isinstance(out.get("config"), dict):  # DQN's config repeats the seed
        out["config"] = {k: v for k, v in out["config"].items() if k != "seed"}
        out["config"] = with_added_fields(out.get("algo"), out["config"])
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
    from shoulder_bench.tasks import is_3dof
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
            if is_3dof(cfg["task"]):  # the 3-DOF runs have their own section (eval.board3)
                continue
            metrics = _read_json(run / "metrics.json")
            policy, meta, _ = policy_for(str(run))
            out.append({"spec": str(run), "source": f"runs: {runs}", "policy": policy, "metrics": metrics,
                        "setting": setting_of({"muscle_model": meta.get("muscle_model")} | cfg)})
    if pretrained or runs is None:  # each agent's record (its source run's metrics) lies beside it
        for p in sorted(pretrained_dir().glob("*.pt")):
            policy, meta, _ = policy_for(f"pretrained:{p.stem}")
            if is_3dof(meta["task"]):  # the 3-DOF agents are in their own section (eval.board3)
                continue
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


def _score(policy, task: str, muscle_model, test, combing, suites: dict, options: dict | None = None) -> dict:
    """One policy evaluated on the test set (recorded), combing and each suite; its columns (`board.columns`)."""
    from shoulder_bench.eval.suites import options_for

    t = evaluate(policy, task, test, muscle_model=muscle_model, record=True, options=options)
    c = evaluate(policy, task, combing, muscle_model=muscle_model, options=options)
    s = {spec: evaluate(policy, task, trajectories, muscle_model=muscle_model, options=options_for(spec, options))
         for spec, trajectories in suites.items()}  # a suite's task options on top of the row's own
    return board.columns(t, c, s, test, task, muscle_model, options)


def load_suites(suites) -> dict:
    """{spec: trajectories} of the suites beyond `paper` (the test set, always scored), each loaded and checked
    (`eval.suites.load_suite`: a name or a folder of CSVs); repeats dropped."""
    from shoulder_bench.eval.suites import load_suite

    return {spec: load_suite(spec) for spec in dict.fromkeys(suites or ()) if spec != "paper"}


def collect(runs: Path | None, pretrained: bool = False, progress: bool = False, suites=("paper",)) -> list[dict]:
    """Rows for runs and/or the shipped agents and the reference controller, ranked (`board.ranked`), then the paper's.

    Every policy is evaluated now, on the fixed test set (recorded, for the measures), on the combing profile and on
    each suite of `suites` beyond `paper`; frames and wall time to accuracy and the evaluation histories come from the
    runs' metrics.json and TensorBoard logs (a shipped agent's record beside it)."""
    from tqdm import tqdm

    from shoulder_bench.eval.reference import ReferenceController
    from shoulder_bench.eval.suites import options_for
    from shoulder_bench.model import DEFAULT_MUSCLE_MODEL
    from shoulder_bench.tasks import check_options

    extra = load_suites(suites)
    entries = _entries(runs, pretrained)
    for e, spec in ((e, spec) for e in entries for spec in extra):  # suite options that conflict: before any work
        options_for(spec, e["setting"]["options"], who=f"{e['spec']} (its row's options)")
    test, combing = trajectories_for("test"), trajectories_for("combing")
    groups: dict[tuple[str, str], list[dict]] = defaultdict(list)
    settings: dict[tuple[str, str], dict] = {}
    for e in tqdm(entries, desc="evaluating", unit="policy", disable=not progress):
        s = e["setting"]
        key = (e["source"], json.dumps(s, sort_keys=True))
        settings[key] = s
        run = e["source"].startswith("runs:")
        groups[key].append(_score(e["policy"], s["task"], s["muscle_model"], test, combing, extra, s["options"])
                           | {"accuracy": board.accuracy_of(e["metrics"]), "wall_s": e["metrics"].get("wall_s"),
                              "history": board.history(Path(e["spec"]), e["metrics"]) if run else None})
    # the reference controller under the default options and under every other option set a row was trained with,
    # where its task takes them (a row under delay or randomisation is then ranked next to the controller under them)
    option_sets = [{}] + [json.loads(o) for o in sorted({json.dumps(v["options"], sort_keys=True)
                                                          for v in settings.values() if v["options"]})]
    for task, options in tqdm([(t, o) for t in ("abduction_ssp", "abduction_4m") for o in option_sets],
                              desc="reference controller", disable=not progress):
        try:
            check_options(task, **options)
        except ValueError:  # e.g. a condition that removes the one muscle of abduction_ssp
            continue
        s = {"task": task, "algo": "reference controller", "muscle_model": DEFAULT_MUSCLE_MODEL, "options": options,
             "model_version": model_version()}
        key = ("model-based", json.dumps(s, sort_keys=True))
        settings[key] = s
        groups[key].append(_score(ReferenceController(task), task, None, test, combing, extra, options or None)
                           | {"accuracy": {}, "wall_s": None, "history": None})
    keys = sorted(groups, key=lambda k: (settings[k]["task"], k[0] == "model-based", settings[k]["algo"], k))
    variants = dict(zip(keys, _variants([settings[k] for k in keys])))
    rows = [{k: settings[key][k] for k in SETTING} | {"variant": variants[key], "source": key[0],
                                                       "suites": list(extra)} | board.aggregate(groups[key], extra)
            for key in keys]
    rows = board.ranked(rows)
    for p in PAPER:
        nan3 = (float("nan"),) * 2
        rows.append({k: "" for k in TEXT} | {k: (p[k], *nan3) for k in CI} | {
            "task": p["task"], "algo": p["algo"], "muscle_model": "their FEM", "source": "paper (their FEM model)",
            "combing_mae": (p.get("combing_mae", float("nan")), 0.0),
            "combing_rmse": (p.get("combing_rmse", float("nan")), 0.0), "suites": list(extra)})
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


def _label(r: dict) -> str:
    return (f"{r['algo'].upper() if r['algo'] in ('ppo', 'dqn', 'bdq') else r['algo']} · {r['task']}"
            + (f" ({where(r)})" if r["source"] != "model-based" else ""))


def _figure(rows: list[dict]) -> str:
    """Per-trajectory test errors (box plots) and saw-tooth rates, as one base64 PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from shoulder_bench.eval.plots import error_boxes, png_base64

    scored = [r for r in rows if "per_trajectory_mae" in r]
    groups = [(_label(r), paper_errors(r["task"], r["algo"]), np.array(r["per_trajectory_mae"]),
               np.array(r["per_trajectory_rmse"])) for r in scored]
    fig, axes = plt.subplots(1, 3, figsize=(15, 0.45 * len(groups) + 1.8), sharey=True,
                             gridspec_kw={"width_ratios": [2, 2, 1.2]})
    error_boxes(axes[0], axes[1], groups)
    axes[2].barh(range(1, len(scored) + 1), [r["sawtooth_per_s"][0] for r in scored],
                 xerr=[r["sawtooth_per_s"][1] for r in scored], color="tab:blue")
    axes[2].set(xlabel="saw-tooth: sign changes of\ndelta-activation per s")
    axes[2].grid(alpha=0.3, axis="x")
    axes[0].invert_yaxis()
    fig.tight_layout()
    return png_base64(fig)


def _curves(rows: list[dict]) -> str | None:
    """Sample-efficiency curves (test MAE against frames, mean and 95 % band over seeds), one panel per muscle set,
    every row with an evaluation history; None if none has one."""
    from shoulder_bench.eval.plots import png_base64, sample_efficiency_figure
    from shoulder_bench.tasks import TASKS

    panels: dict[str, list] = {}
    for r in rows:
        if r.get("curve") is not None:
            muscles = TASKS[r["task"]][0]
            name = "one muscle (" + muscles[0] + ")" if len(muscles) == 1 else f"{len(muscles)} muscles"
            panels.setdefault(name, []).append((f"{_label(r)}, n = {r['curve']['n']}", r["curve"]))
    return png_base64(sample_efficiency_figure(panels)) if panels else None


def load_surgery(folders) -> list[dict]:
    """The summaries (summary.json) of `shoulder-bench surgery` output folders, for the board's "surgery" section;
    a folder without one is a clear error, raised before any evaluation."""
    summaries = []
    for folder in folders or ():
        path = Path(folder) / "summary.json"
        if not path.is_file():
            raise ValueError(f"--surgery {folder}: no summary.json there; give a folder written by "
                             "`shoulder-bench surgery --out DIR`")
        summary = _read_json(path)
        if "scenarios" not in summary or "tables" not in summary:
            raise ValueError(f"--surgery {path} is not a surgery summary (no scenarios/tables); give a folder "
                             "written by `shoulder-bench surgery --out DIR`")
        summaries.append(summary)
    return summaries


def _surgery_html(summary: dict) -> str:
    import html

    from shoulder_bench.eval.surgery_report import SECTION_HEAD, leaderboard_rows, section_intro

    intro = section_intro(summary)
    head = "".join(f"<th>{html.escape(h)}</th>" for h in SECTION_HEAD)
    body = "".join("<tr>" + "".join(f"<td>{html.escape(row[h])}</td>" for h in SECTION_HEAD) + "</tr>"
                   for row in leaderboard_rows(summary))
    return f"<h2>Surgery</h2><p>{html.escape(intro)}</p><table><tr>{head}</tr>{body}</table>"


def write(rows: list[dict], out: Path, surgery: list[dict] = (), full: list[dict] = ()) -> dict[str, Path]:
    """leaderboard.md, .csv and .html in `out`, all composed first and renamed into place together; `surgery`:
    summaries of `shoulder-bench surgery` runs (`load_surgery`), each shown as a "surgery" section; `full`: the
    3-DOF rows (`eval.board3.collect`), shown as their own section."""
    import html

    from shoulder_bench.eval import board3
    from shoulder_bench.eval.plots import checked_dir, replace_all
    from shoulder_bench.eval.suites import note as suite_note
    from shoulder_bench.eval.surgery_report import section

    out = checked_dir(out, "--out")
    variant = any(r["variant"] for r in rows)
    titles = head(variant, rows[0]["suites"] if rows else ())
    table = [cells(r, variant) for r in rows]
    found = findings(rows)
    notes_text = NOTES + suite_note(rows[0]["suites"] if rows else ())  # the task options of a suite that has any
    md = ("| " + " | ".join(titles) + " |\n|" + "---|" * len(titles) + "\n"
          + "".join("| " + " | ".join(line) + " |\n" for line in table)
          + "\n" + notes_text + "\n" + ("\n**The paper's qualitative findings, measured:**\n\n" if found else "")
          + "".join(f"- {f}\n" for f in found)
          + "".join("\n" + section(summary) for summary in surgery) + board3.markdown(list(full)))
    body = "".join("<tr>" + "".join(f"<td>{html.escape(c)}</td>" for c in line) + "</tr>" for line in table)
    notes = html.escape(notes_text).replace("**synthetic**", "<b>synthetic</b>")
    curves = _curves(rows)
    page = ("<!doctype html><meta charset='utf-8'><title>shoulder_bench leaderboard</title>"
            "<style>body{font-family:sans-serif;margin:2em}td,th{border:1px solid #ccc;padding:4px 8px}"
            "table{border-collapse:collapse}</style><h1>shoulder_bench leaderboard</h1>"
            f"<table><tr>{''.join(f'<th>{html.escape(h)}</th>' for h in titles)}</tr>{body}</table><p>{notes}</p>"
            + (f"<h2>The paper's qualitative findings, measured</h2><ul>"
               f"{''.join(f'<li>{html.escape(x)}</li>' for x in found)}</ul>" if found else "")
            + "".join(_surgery_html(summary) for summary in surgery) + board3.html(list(full))
            + "<h2>Sample efficiency</h2>"
            + (f"<p><img alt='sample-efficiency curves: test MAE against frames, 95 % bands over seeds' "
               f"src='data:image/png;base64,{curves}'></p><p>Test-set MAE at each evaluation during training "
               f"(TensorBoard test/mae_deg) and the final one; several seeds: their mean on the union of their "
               f"evaluation frames, the band the 95 % bootstrap interval of that mean.</p>" if curves else
               "<p>No row has an evaluation history (runs' tb/ test/mae_deg): shipped agents and the reference "
               "controller have none.</p>")
            + f"<h2>Errors and saw-tooth</h2><p><img alt='per-trajectory test errors and saw-tooth rates' "
              f"src='data:image/png;base64,{_figure(rows)}'></p>")
    texts = {"md": md, "csv": csv_text(rows), "html": page}
    paths = {k: out / f"leaderboard.{k}" for k in texts}
    replace_all([(paths[k], lambda tmp, text=texts[k]: tmp.write_text(text, encoding="utf-8")) for k in texts])
    return paths
