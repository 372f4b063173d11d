"""The leaderboard's section for the full shoulder's 3-DOF tasks (issue 12 §4): one row per (task, algorithm,
setting) over its seeds, and the reference controller, each evaluated now on its task's fixed test set
(`tasks.fixed_test_set`: the 3-DOF one; the scapular-plane task: the 1-DOF one in the scapular plane).

Columns: the success rate, the humerus orientation error (MAE with a 95 % bootstrap interval over seeds, RMSE), the
error of each coordinate (plane of elevation, elevation, axial rotation; MAE over the frames that did not crash),
effort, saw-tooth and mean |delta a| (`eval.measures`, as the 1-DOF board's; success on the orientation error),
crashes, frames and the run's wall time (its periodic test evaluations included), and the MAE on each of the board's
suites that the 3-DOF tasks take (`suites_of`: fast, adl, robust in three dimensions, `eval.suites`). The main board
(`eval.leaderboard`) keeps the 1-DOF tasks. Co-contraction: the share of the
summed activation in muscles whose torque vector has a negative dot product with the net one (`TorqueLaw3`).
"""
from __future__ import annotations

import json
from collections import defaultdict
from pathlib import Path

import numpy as np

from shoulder_bench.eval import stats
from shoulder_bench.eval.evaluate import law_options
from shoulder_bench.eval.leaderboard import setting_of

COLUMNS = ("task", "algorithm", "seeds", "success", "orientation MAE (deg) [95 % CI]", "orientation RMSE (deg)",
           "plane MAE (deg)", "elevation MAE (deg)", "rotation MAE (deg)", "effort (Σa² per frame)",
           "saw-tooth (sign changes/s)", "mean abs Δa per frame", "co-contraction", "crashes", "frames",
           "run wall (s, evaluations included)")
MEASURES = ("success", "effort", "sawtooth_per_s", "mean_abs_delta", "co_contraction")


class TorqueLaw3:
    """The full shoulder's isometric muscle torques for `measures.co_contraction`: torque(angles rad (F, 3), velocity,
    activation (F, muscles)) -> (F, muscles, 3) N m about plane, elevation, rotation (the tasks' FEM tables through
    the tendon moment arms, `full_arm.Pose.tendon_geometry`; a muscle's the sum over its tendons); the law of a task
    with `line_of_action` and a shoulder condition (`tasks.track3d.condition_law`)."""

    def __init__(self, line_of_action: str = "mjcf", **condition):
        from shoulder_bench.tasks.track3d import condition_law

        self.law, self.pose = condition_law(**condition, line_of_action=line_of_action)
        self.muscles = self.law.muscles

    def torque(self, angle, velocity, activation) -> np.ndarray:
        L, r = self.law.geometry(self.pose, np.degrees(angle), activation)
        f = self.law.force(L, np.zeros_like(L), activation, self.law.departures(np.degrees(angle)))  # isometric
        tau = f[..., None] * r  # (F, tendons, 3)
        return np.stack([tau[:, list(self.law.muscle_of == k)].sum(axis=1) for k in range(len(self.muscles))], axis=1)


def score_of(policy, task: str, test: list, options: dict | None = None, law=None) -> dict:
    """`evaluate` with a recorded trace, plus the board's measures of it (the trace itself dropped); `law` a
    TorqueLaw3 for the co-contraction (default a new one, on the task's line of action)."""
    from shoulder_bench.eval import measures
    from shoulder_bench.eval.evaluate import evaluate

    score = evaluate(policy, task, test, options=options, record=True)
    trace = score.pop("trace")
    frames = [t.frames for t in test]
    ok = measures.successes(measures.tracking_error(trace, frames), frames)
    return score | {"success": float(ok.mean()), "effort": measures.effort(trace["activation"]),
                    "sawtooth_per_s": measures.sawtooth_rate(trace["activation"]),
                    "mean_abs_delta": measures.mean_abs_delta(trace["activation"]),
                    "co_contraction": measures.co_contraction(trace["angle_deg"], trace["activation"],
                                                              law or TorqueLaw3(**law_options(options)))}


def suites_of(requested) -> list[str]:
    """The named suites of `requested` (the board's --suite) that 3-DOF tasks take beyond their test set, in order:
    fast, adl and robust (`eval.suites.SUITES3`; the scapular-plane task takes them as the 1-DOF ones, `SCAPULAR`);
    paper, wide and folders of CSV files are the 1-DOF board's."""
    from shoulder_bench.eval.suites import SUITES3

    return [s for s in dict.fromkeys(requested or ()) if s in SUITES3]


def suite_scores(policy, task: str, specs: list[str], options: dict | None, sets: dict) -> dict:
    """{suite: MAE} of `policy` on each suite of `specs` (`eval.suites.load_suite` for `task`, its task options on
    top of `options`); `sets` caches the loaded suites per (suite, task)."""
    from shoulder_bench.eval.evaluate import evaluate
    from shoulder_bench.eval.suites import load_suite, options_for

    out = {}
    for spec in specs:
        if (spec, task) not in sets:
            sets[(spec, task)] = load_suite(spec, task)
        out[spec] = evaluate(policy, task, sets[(spec, task)], options=options_for(spec, options))["mae_deg"]
    return out


def law_of(options: dict | None) -> str:
    """The muscles' law a 3-DOF run's task options simulate beyond the defaults (`track3d.LAW_OPTIONS`: line of
    action, tendon), as sorted JSON ("{}": the default law)."""
    from shoulder_bench.tasks.options import DEFAULTS
    from shoulder_bench.tasks.track3d import LAW_OPTIONS

    return json.dumps({k: v for k, v in (options or {}).items() if k in LAW_OPTIONS and v != DEFAULTS[k]},
                      sort_keys=True)


def run_folders(runs: Path) -> list[Path]:
    """The finished run folders under `runs` whose task is a 3-DOF one."""
    from shoulder_bench.tasks import TASKS_3DOF

    out = []
    for cfg in sorted(Path(runs).rglob("config.json")):
        folder = cfg.parent
        if not (folder / "policy.pt").exists():
            continue
        try:
            task = json.loads(cfg.read_text()).get("task")
        except (OSError, ValueError):
            continue
        if task in TASKS_3DOF:
            out.append(folder)
    return out


def setting_key(cfg: dict) -> str:
    """A run's row: runs pool only when their algorithm config and options agree, seeds and budgets apart
    (`leaderboard.setting_of`, which also drops the seed DQN's config repeats)."""
    return json.dumps(setting_of({"algo": cfg.get("algo"), "config": cfg.get("config"), "options": cfg.get("options")}),
                      sort_keys=True)


def _variant(setting: str, settings: list[str]) -> str:
    """" (key=value, ...)": the task options this setting sets (e.g. line_of_action=band), and what in its algorithm
    config sets it apart from the others of its task and algorithm; "" if nothing does."""
    if not setting:
        return ""
    d = json.loads(setting)
    mine, options = d["config"] or {}, d["options"] or {}
    others = [json.loads(s)["config"] or {} for s in settings if s != setting] if len(settings) > 1 else []
    keys = sorted(k for k in mine if any(o.get(k) != mine[k] for o in others))
    labels = [f"{k}={mine[k]}" for k in keys] + [f"{k}={v}" for k, v in sorted(options.items())]
    return " (" + ", ".join(labels) + ")" if labels else ""


def _row(task: str, algo: str, scores: list[dict], metrics: list[dict]) -> dict:
    mae = [s["mae_deg"] for s in scores]
    suites = {k: float(np.mean([s["suites"][k] for s in scores])) for k in scores[0].get("suites", {})}
    lo, hi = stats.bootstrap_ci(mae) if len(mae) > 1 else (float("nan"), float("nan"))
    coord = {k: float(np.mean([s["coordinate_mae_deg"][k] for s in scores])) for k in ("plane", "elevation",
                                                                                         "rotation")}
    return {"task": task, "algorithm": algo, "seeds": len(scores), "mae": float(np.mean(mae)), "ci": (lo, hi),
            "rmse": float(np.mean([s["rmse_deg"] for s in scores])), **coord, "suites": suites,
            **{k: float(np.mean([s[k] for s in scores])) for k in MEASURES},
            "crashes": int(sum(s["crashes"] for s in scores)),
            "frames": [m.get("frames") for m in metrics if m], "wall_s": [m.get("wall_s") for m in metrics if m]}


def shipped() -> list[tuple[Path, object, dict]]:
    """The shipped 3-DOF agents (train/pretrained/*.pt whose task is a 3-DOF one): (path, policy, metadata)."""
    from shoulder_bench.tasks import TASKS_3DOF
    from shoulder_bench.train.policy import load_policy, pretrained_dir

    agents = [(p, *load_policy(str(p))) for p in sorted(pretrained_dir().glob("*.pt"))]
    return [a for a in agents if a[2].get("task") in TASKS_3DOF]


def collect(runs: Path | None, progress: bool = False, test: list | None = None,
            pretrained: bool = False, suites=()) -> list[dict]:
    """Rows of the 3-DOF runs under `runs` (and, with `pretrained` or without runs, of the shipped 3-DOF agents,
    as the main board takes the shipped agents) and of the reference controller on each continuous 3-DOF task a
    row has (empty without any); `test`: the trajectories (default each task's fixed test set; the tests pass
    fewer); `suites`: the board's --suite, of which those 3-DOF tasks take (`suites_of`) add their MAE, each row
    under the suite's task options on top of its own (a run whose options conflict with a suite's is refused
    before any evaluation)."""
    from tqdm import tqdm

    from shoulder_bench.eval.reference3 import ReferenceController3
    from shoulder_bench.eval.suites import options_for
    from shoulder_bench.tasks import TASKS_3DOF, fixed_test_set
    from shoulder_bench.train.policy import load_policy

    folders = run_folders(runs) if runs is not None else []
    agents = shipped() if pretrained or runs is None else []
    if not folders and not agents:
        return []
    specs = suites_of(suites)
    configs = {f: json.loads((f / "config.json").read_text()) for f in folders}
    for who, options in [(f"run {f}", c.get("options")) for f, c in configs.items()] + [
            (f"agent {p.stem}", m.get("options")) for p, _, m in agents]:
        for spec in specs:  # a suite's fixed options against a row's own: every conflict before any evaluation
            options_for(spec, options, who=who)
    sets: dict[str, list] = {}
    suite_sets: dict[tuple, list] = {}

    def test_of(task: str) -> list:
        if test is not None:
            return test
        if task not in sets:
            sets[task] = fixed_test_set(task)
        return sets[task]
    groups: dict[tuple[str, str], tuple[list, list]] = defaultdict(lambda: ([], []))
    torques: dict[str, TorqueLaw3] = {}  # per law (line of action, tendon) and condition
    laws: dict[str, set] = defaultdict(set)  # task -> the muscles' laws its rows simulate (`law_of`)

    def torques_for(task: str, options: dict | None) -> TorqueLaw3:
        laws[task].add(law_of(options))
        key = json.dumps(law_options(options), sort_keys=True)
        if key not in torques:
            torques[key] = TorqueLaw3(**law_options(options))
        return torques[key]
    for folder in tqdm(folders, desc="evaluating 3-DOF runs", disable=not progress):
        cfg = configs[folder]
        policy, _ = load_policy(str(folder / "policy.pt"))
        options = cfg.get("options") or None
        score = score_of(policy, cfg["task"], test_of(cfg["task"]), options=options,
                         law=torques_for(cfg["task"], options))
        score["suites"] = suite_scores(policy, cfg["task"], specs, options, suite_sets)
        metrics = json.loads((folder / "metrics.json").read_text()) if (folder / "metrics.json").exists() else {}
        g = groups[(cfg["task"], cfg["algo"].upper(), setting_key(cfg))]
        g[0].append(score)
        g[1].append(metrics)
    for path, policy, meta in agents:  # a shipped agent's record (its source run's metrics) lies beside it
        record = path.with_suffix(".json")
        metrics = json.loads(record.read_text()) if record.exists() else {}
        options = meta.get("options") or None
        score = score_of(policy, meta["task"], test_of(meta["task"]), options=options,
                         law=torques_for(meta["task"], options))
        score["suites"] = suite_scores(policy, meta["task"], specs, options, suite_sets)
        g = groups[(meta["task"], f"{str(meta.get('algo', '')).upper()} (shipped agent {path.stem})", "")]
        g[0].append(score)
        g[1].append(metrics)
    rows = [_row(task, algo + _variant(setting, [s for t, a, s in groups if (t, a) == (task, algo)]),
                 *groups[(task, algo, setting)]) for task, algo, setting in sorted(groups)]
    for task in sorted({t for t, _, _ in groups if not TASKS_3DOF[t][1]}):  # the continuous tasks' reference,
        for key in sorted(laws[task], key=lambda k: (len(k), k)):  # with each law its rows simulate (default first)
            options = json.loads(key) or None
            controller = ReferenceController3(task, **(options or {}))
            score = score_of(controller, task, test_of(task), options=options, law=torques_for(task, options))
            score["suites"] = suite_scores(controller, task, specs, options, suite_sets)
            named = "" if options is None else " (" + ", ".join(f"{k}={v}" for k, v in options.items()) + ")"
            rows.append(_row(task, "reference controller" + named, [score], []))
    return rows


def _cells(r: dict) -> list[str]:
    ci = "" if np.isnan(r["ci"][0]) else f" [{r['ci'][0]:.2f}, {r['ci'][1]:.2f}]"
    frames = ", ".join(f"{f:,}" for f in r["frames"] if f) or "-"
    wall = ", ".join(f"{w:.0f}" for w in r["wall_s"] if w) or "-"
    return [r["task"], r["algorithm"], str(r["seeds"]), f"{r['success']:.0%}", f"{r['mae']:.2f}{ci}",
            f"{r['rmse']:.2f}", *(f"{v:.2f}" for v in r["suites"].values()),
            f"{r['plane']:.2f}", f"{r['elevation']:.2f}", f"{r['rotation']:.2f}",
            f"{r['effort']:.3f}", f"{r['sawtooth_per_s']:.2f}", f"{r['mean_abs_delta']:.4f}",
            f"{r['co_contraction']:.0%}", str(r["crashes"]),
            frames, wall]


NOTE = ("3-DOF rows: evaluated now on their task's fixed 100-trajectory test set (eval/data/test_set_3dof.csv; "
        "elevate_scapular_plane_12m: the 1-DOF test set's elevations in the scapular plane at rotation 0) under "
        "the row's own task options (those its label names: a row trained with delay_frames=1 is scored with it); the "
        "orientation error is the angle between the achieved and the target humerus orientation; each coordinate's "
        "MAE excludes crashed frames; the interval is the 95 % bootstrap over seeds (none for one seed). Success: the "
        "share of test trajectories whose orientation error stays under 2 deg on at least 90 % of their frames "
        "(frames after a crash fail); effort, saw-tooth and mean abs Δa as in the main board; co-contraction: the "
        "share of the summed activation in muscles whose isometric torque vector (plane, elevation, rotation) points "
        "against the net muscle torque (negative dot product); with several seeds, means over seeds.")


SUITE_NOTE = (" Suite columns (the board's --suite): the row's orientation MAE on that suite (mean over seeds), on "
              "track_3dof(_discrete) the 3-DOF suite of that name (fast: 2-3 s segments in all three coordinates "
              "within the test ranges; adl: the four synthetic ADL profiles, which leave the test ranges), on "
              "elevate_scapular_plane_12m the 1-DOF one in the scapular plane (eval/suites.py).")


def titles(rows: list[dict]) -> list[str]:
    """The column titles: COLUMNS with one MAE column per suite after the test RMSE."""
    named = [f"{s} MAE (deg)" for s in rows[0]["suites"]]
    return [*COLUMNS[:6], *named, *COLUMNS[6:]]


def notes(rows: list[dict]) -> str:
    from shoulder_bench.eval.suites import note

    specs = list(rows[0]["suites"])
    return NOTE + (SUITE_NOTE + note(specs, three=True) if specs else "")


def markdown(rows: list[dict]) -> str:
    if not rows:
        return ""
    head = titles(rows)
    return ("\n## The full shoulder (3-DOF tasks)\n\n| " + " | ".join(head) + " |\n|" + "---|" * len(head)
            + "\n" + "".join("| " + " | ".join(_cells(r)) + " |\n" for r in rows) + "\n" + notes(rows) + "\n")


def suite_figure(rows: list[dict]) -> str:
    """Each row's orientation MAE on its test set and on each suite, grouped bars on a log axis, as one base64 PNG:
    where a ranking on the test set holds across the suites and where it turns."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from shoulder_bench.eval.plots import png_base64

    sets = ["test", *rows[0]["suites"]]
    width = 0.8 / len(sets)
    fig, ax = plt.subplots(figsize=(10, 0.5 * len(rows) * len(sets) * 0.45 + 1.6))
    for k, name in enumerate(sets):
        values = [r["mae"] if name == "test" else r["suites"][name] for r in rows]
        ax.barh(np.arange(len(rows)) + (k - (len(sets) - 1) / 2) * width, values, height=width, label=name)
    ax.set_yticks(range(len(rows)), [f"{r['task']} · {r['algorithm']}" for r in rows], fontsize=7)
    ax.set(xscale="log", xlabel="orientation MAE (deg, log scale)")
    ax.invert_yaxis()
    ax.grid(alpha=0.3, axis="x", which="both")
    ax.legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    return png_base64(fig)


def html(rows: list[dict]) -> str:
    import html as h

    if not rows:
        return ""
    body = "".join("<tr>" + "".join(f"<td>{h.escape(c)}</td>" for c in _cells(r)) + "</tr>" for r in rows)
    head = "".join(f"<th>{h.escape(c)}</th>" for c in titles(rows))
    figure = (f"<p><img alt='orientation MAE of each 3-DOF row on its test set and each suite' "
              f"src='data:image/png;base64,{suite_figure(rows)}'></p>" if rows[0]["suites"] else "")
    return (f"<h2>The full shoulder (3-DOF tasks)</h2><table><tr>{head}</tr>{body}</table>"
            f"<p>{h.escape(notes(rows))}</p>{figure}")
