"""The leaderboard's columns (issue 14 §3; definitions in docs/ranking.md): one policy scored on the paper test set
(recorded), the combing profile and any further suites; the seeds of one setting pooled into a row with 95 % bootstrap
intervals (`eval.stats`); the rows ranked; the runs' evaluation histories as sample-efficiency curves; the table's
titles, cells and CSV.

- Test MAE / RMSE: with two or more seeds the mean over seeds and the bootstrap interval of that mean over seeds; with
  one (a shipped agent, the reference controller, a single run) the value and the interval over the trajectories
  (whole trajectories resampled, frames weighted). `ci_over` says which, with n.
- Success, effort, smoothness, co-contraction: `eval.measures` on the recorded test set, the mean (and std) over seeds.
- Frames and wall time to 5.15, 2 and 1 deg: from each run's metrics.json (`frames_to_paper_accuracy`, `to_accuracy`),
  the mean over the seeds that reached the threshold, with how many did; absent where no seed recorded them.
- Generalisation gap on suite S: S's MAE minus the paper test MAE, per seed, then the mean over seeds.
- Rank: within the rows of one muscle set (one muscle, four muscles; continuous and discrete actions compete), by
  success rate (higher first), then test MAE (lower first), then effort (lower first).
"""
from __future__ import annotations

import csv
import io
import json
from pathlib import Path

import numpy as np

from shoulder_bench.eval.evaluate import CONDITION_OPTIONS
from shoulder_bench.eval.measures import measures, successes, tracking_error
from shoulder_bench.eval.stats import bootstrap_ci, error_ci, mean_ci

PAIRS = ("combing_mae", "combing_rmse", "success", "effort", "sawtooth_per_s", "mean_abs_delta", "co_contraction",
         "wall_s", "early_share", "late_share")  # (mean, std) over seeds
THRESHOLDS = ("5.15", "2.0", "1.0")  # deg: frames (and wall time, for 2 and 1) to the first evaluation at or below
CURVE_BOOT = 2000
TEXT = ("rank", "task", "algo", "muscle_model", "options", "model_version", "variant", "source", "seeds", "ci_over",
        "crashes")  # the CSV's plain columns; then the intervals, (mean, std) pairs, thresholds and suites
CI = ("test_mae", "test_rmse")  # (value, low, high)


def law_for(task: str, muscle_model: str | None, options: dict | None):
    """The force law the task runs with (its muscles, muscle model and shoulder condition)."""
    from shoulder_bench.arm import arm_for
    from shoulder_bench.model import DEFAULT_MUSCLE_MODEL
    from shoulder_bench.tasks import TASKS

    cond = {k: v for k, v in (options or {}).items() if k in CONDITION_OPTIONS and v is not None}
    return arm_for(cond.get("condition")).load_law(muscle_model or DEFAULT_MUSCLE_MODEL, TASKS[task][0], **cond)


def suite_label(spec: str) -> str:
    """A suite's name on the board: the name, or a hidden folder's own name."""
    from shoulder_bench.eval.suites import SUITES

    return spec if spec in SUITES else f"hidden {Path(spec).name}"


def columns(t: dict, c: dict, suites: dict, test, task: str, muscle_model, options: dict | None) -> dict:
    """One policy's columns from its evaluations (`evaluate`): t on the test set, recorded (errors, success,
    measures), c on combing, suites {spec: evaluation}; test the test set's trajectories."""
    from shoulder_bench.tasks import TASKS

    frames = np.array([tr.frames for tr in test])
    err = tracking_error(t["trace"], frames)
    return {"test_mae": t["mae_deg"], "test_rmse": t["rmse_deg"],
            "crashes": t["crashes"] + c["crashes"] + sum(s["crashes"] for s in suites.values()),
            "combing_mae": c["mae_deg"], "combing_rmse": c["rmse_deg"],
            "success": float(successes(err, frames).mean()), "abs_sum": np.nansum(err, axis=1),
            "sq_sum": np.nansum(err ** 2, axis=1), "frames": frames,
            **measures(t["trace"], TASKS[task][0], law_for(task, muscle_model, options)),
            "per_trajectory": t["per_trajectory"], "suites": {k: s["mae_deg"] for k, s in suites.items()}}


def accuracy_of(metrics: dict) -> dict:
    """Per threshold of THRESHOLDS: None (not recorded by this run), {} (recorded, not reached) or {"frames",
    "wall_s"} (wall None where not recorded)."""
    out = {}
    paper = metrics.get("frames_to_paper_accuracy")
    out["5.15"] = None if "frames_to_paper_accuracy" not in metrics else {} if paper is None else {
        "frames": paper, "wall_s": None}
    to = metrics.get("to_accuracy")
    for key in THRESHOLDS[1:]:
        out[key] = None if not isinstance(to, dict) else dict(to.get(key) or {})
    return out


def history(run: Path, metrics: dict) -> tuple[list[int], list[float]] | None:
    """A run's test MAE against frames: metrics.json's `evaluations` (every test-set evaluation, the final one
    included) where the run records them, else its TensorBoard `test/mae_deg` (one point per evaluation during
    training) and the final evaluation (metrics.json's frames and mae_deg); None if neither holds any."""
    from shoulder_bench.eval.plots import scalars

    recorded = metrics.get("evaluations")
    if isinstance(recorded, list) and recorded:
        points = sorted((int(p["frames"]), float(p["mae_deg"])) for p in recorded)
        return [f for f, _ in points], [v for _, v in points]
    steps, values = scalars(run, "test/mae_deg") if (Path(run) / "tb").is_dir() else ([], [])
    steps, values = list(steps), list(values)
    final = metrics.get("frames"), metrics.get("mae_deg")
    if steps and None not in final and final[0] > steps[-1]:
        steps.append(int(final[0]))
        values.append(float(final[1]))
    return (steps, values) if steps else None


def curve_band(histories: list[tuple[list, list]], seed: int = 0) -> dict | None:
    """Seeds' histories on one frame grid (the union of their evaluation frames inside the range all cover, each
    interpolated linearly): {"frames", "mean", "lo", "hi", "n"}; lo/hi the 95 % bootstrap interval of the mean over
    seeds (NaN with one seed)."""
    histories = [h for h in histories if h is not None]
    if not histories:
        return None
    lo_f, hi_f = max(h[0][0] for h in histories), min(h[0][-1] for h in histories)
    grid = np.array(sorted({f for h in histories for f in h[0] if lo_f <= f <= hi_f}), dtype=float)
    if not grid.size:
        return None
    ys = np.stack([np.interp(grid, h[0], h[1]) for h in histories])
    band = np.array([bootstrap_ci(col, n_boot=CURVE_BOOT, seed=seed) for col in ys.T])
    return {"frames": grid, "mean": ys.mean(axis=0), "lo": band[:, 0], "hi": band[:, 1], "n": len(histories)}


def _mean_std(values) -> tuple[float, float]:
    v = np.array([x for x in values if x is not None], dtype=float)
    v = v[np.isfinite(v)]
    return (float(v.mean()), float(v.std())) if v.size else (float("nan"), float("nan"))


def _to(entries: list[dict], key: str) -> dict:
    """Frames / wall to one threshold over seeds: mean over those that reached it; `reached` k and `of` m (the seeds
    that recorded it; 0: no record)."""
    recorded = [e["accuracy"][key] for e in entries if e["accuracy"].get(key) is not None]
    hit = [r for r in recorded if r]
    walls = [r["wall_s"] for r in hit if r.get("wall_s") is not None]
    return {"frames": float(np.mean([r["frames"] for r in hit])) if hit else float("nan"),
            "wall_s": float(np.mean(walls)) if walls else float("nan"), "reached": len(hit), "of": len(recorded)}


def aggregate(entries: list[dict], suites: list[str]) -> dict:
    """The row columns of the seeds `entries` (score() plus "accuracy", "history", "wall_s" each)."""
    n = len(entries)
    row = {"seeds": n, "crashes": sum(e["crashes"] for e in entries)}
    if n >= 2:
        for k in ("test_mae", "test_rmse"):
            row[k] = mean_ci([e[k] for e in entries])[:3]
        row["ci_over"] = f"{n} seeds"
    else:
        e = entries[0]
        ci = error_ci(e["abs_sum"], e["sq_sum"], e["frames"])
        row["test_mae"], row["test_rmse"] = ci["mae"][:3], ci["rmse"][:3]
        row["ci_over"] = f"{len(e['frames'])} trajectories"
    for k in PAIRS:
        row[k] = _mean_std(e.get(k) for e in entries)
    for spec in suites:
        row[f"suite:{spec}"] = _mean_std(e["suites"][spec] for e in entries)
        row[f"gap:{spec}"] = _mean_std(e["suites"][spec] - e["test_mae"] for e in entries)
    for key in THRESHOLDS:
        row[f"to:{key}"] = _to(entries, key)
    row["curve"] = curve_band([e.get("history") for e in entries])
    row["per_trajectory_mae"] = [x for e in entries for x in e["per_trajectory"]["mae_deg"]]
    row["per_trajectory_rmse"] = [x for e in entries for x in e["per_trajectory"]["rmse_deg"]]
    return row


def rank_key(row: dict) -> tuple[float, float, float]:
    """Success (higher first), then test MAE (lower first), then effort (lower first); NaN last."""
    def last(x: float) -> float:
        return x if np.isfinite(x) else np.inf

    return last(-row["success"][0]), last(row["test_mae"][0]), last(row["effort"][0])


def ranked(rows: list[dict]) -> list[dict]:
    """The scored rows in rank order within each muscle set (`rank` 1, 2, ... set on each), sets in the order they
    first appear; a stable sort, so ties keep their order."""
    from shoulder_bench.tasks import TASKS

    sets: dict[tuple, list[dict]] = {}
    for r in rows:
        sets.setdefault(tuple(TASKS[r["task"]][0]), []).append(r)
    out = []
    for group in sets.values():
        for k, r in enumerate(sorted(group, key=rank_key), start=1):
            out.append(r | {"rank": k})
    return out


# --- the table: titles, cells and CSV --------------------------------------------------------------------------------
def options_text(options) -> str:
    """Task options as `key=value, ...`; "default" for none."""
    if not isinstance(options, dict):
        return str(options)
    return ", ".join(f"{k}={v}" for k, v in sorted(options.items())) or "default"


def _pair(value, digits: int = 2) -> str:
    m, s = value
    if not np.isfinite(m):
        return "–"
    return f"{m:.{digits}f} ± {s:.{digits}f}" if s else f"{m:.{digits}f}"


def _ci(value, digits: int = 2) -> str:
    m, lo, hi = value
    if not np.isfinite(m):
        return "–"
    return f"{m:.{digits}f} [{lo:.{digits}f}, {hi:.{digits}f}]" if np.isfinite(lo) else f"{m:.{digits}f}"


def _pct(value) -> str:
    m, s = value
    return "–" if not np.isfinite(m) else f"{m:.0%} ± {s:.0%}" if s else f"{m:.0%}"


def frames_text(frames: float) -> str:
    return f"{frames / 1e6:.2f} M" if frames >= 1e5 else f"{frames:,.0f}"


def to_text(t: dict) -> str:
    """Frames (and wall time) to a threshold, with the seeds reaching it; '–' where no seed recorded it."""
    if not t["of"]:
        return "–"
    if not t["reached"]:
        return f"– (0/{t['of']})"
    w = t["wall_s"]
    wall = "" if not np.isfinite(w) else f" · {w:.1f} s" if w < 100 else f" · {w:.0f} s"
    return f"{frames_text(t['frames'])}{wall} ({t['reached']}/{t['of']})"


def head(variant: bool, suites=()) -> list[str]:
    """The Markdown / HTML column titles; the variant column only where some row has one; per suite beyond `paper`
    its MAE and its gap."""
    labels = [suite_label(s) for s in suites]
    return (HEAD[:6] + (["variant"] if variant else []) + HEAD[6:]
            + [t for name in labels for t in (f"{name} MAE (deg)", f"gap {name} − paper (deg)")])


def cells(row: dict, variant: bool = False) -> list[str]:
    """The Markdown / HTML cells of one row (head(variant, row's suites) order)."""
    paper = row["source"].startswith("paper")  # the paper's rows (sources are "runs: DIR", "shipped agent", ...)
    setting = [str(row["rank"]), row["task"], row["algo"], row["muscle_model"],
               options_text(row["options"]) if not paper else "", row["model_version"]]
    setting += [row["variant"]] if variant else []
    if paper:
        blank = [""] * (HEAD.index("combing MAE (deg, synthetic)") - 12)  # after the 6 setting and 6 error cells
        return setting + [row["source"], "", "", _ci(row["test_mae"]), _ci(row["test_rmse"]), ""] + blank + [
            _pair(row["combing_mae"]), _pair(row["combing_rmse"]), ""] + ["", ""] * len(row["suites"])
    early, late = row["early_share"][0], row["late_share"][0]
    return setting + [row["source"], str(row["seeds"]), _pct(row["success"]), _ci(row["test_mae"]),
                      _ci(row["test_rmse"]), row["ci_over"], _pair(row["effort"], 3), _pair(row["sawtooth_per_s"]),
                      _pair(row["mean_abs_delta"], 4), _pct(row["co_contraction"]), str(row["crashes"]),
                      *(to_text(row[f"to:{k}"]) for k in THRESHOLDS), _pair(row["wall_s"], 0),
                      _pair(row["combing_mae"]), _pair(row["combing_rmse"]),
                      f"{early:.0%} / {late:.0%}" if np.isfinite(early) else "–"] + [
        x for spec in row["suites"] for x in (_pair(row[f"suite:{spec}"]), _pair(row[f"gap:{spec}"]))]


HEAD = ["rank", "task", "algorithm", "muscle model", "options", "model version", "source", "seeds", "success",
        "test MAE (deg) [95% CI]", "test RMSE (deg) [95% CI]", "CI over", "effort (Σa² per frame)",
        "saw-tooth (sign changes/s)", "mean abs Δa per frame", "co-contraction", "crashes",
        "to 5.15 deg: frames (seeds)", "to 2 deg: frames · wall", "to 1 deg: frames · wall", "wall (s)",
        "combing MAE (deg, synthetic)", "combing RMSE (deg, synthetic)", "ssp+isp share <45 / >=45 deg"]
NOTES = ("Fixed test set (the `paper` suite): 100 trajectories of 20 s, every policy evaluated when the board was "
         "built. Rank: within each muscle set, by success rate (higher first), then test MAE, then effort (lower "
         "first). Success: the share of test trajectories whose tracking error stays under 2 deg on at least 90 % of "
         "their frames (frames after a crash fail). Test MAE / RMSE: with several seeds the mean over seeds and its "
         "95 % bootstrap interval over seeds; with one, the interval over trajectories (CI over says which, with n). "
         "Effort: mean sum of squared activations per frame. Saw-tooth: sign changes of delta-activation per second "
         "and muscle; mean abs Δa: mean |change of activation| per frame and muscle. Co-contraction: the share of the "
         "summed activation in muscles whose isometric torque opposes the net muscle torque. Frames (and training "
         "wall time) to 5.15 / 2 / 1 deg test MAE: from the runs' records, over the seeds that reached it (–: not "
         "recorded). Gap: a suite's MAE minus the paper test MAE, per seed. Other columns: mean ± std over seeds. "
         "Combing: a **synthetic** profile (the paper's in-vivo recording is not public). Paper rows: their ArtiSynth "
         "FEM model, not this one. ssp+isp share: their part of the summed activation with the arm below 45 deg / at "
         "or above. Definitions: docs/ranking.md.")


def csv_text(rows: list[dict]) -> str:
    """The board as CSV: plain columns, each interval as _mean/_lo/_hi, each other measure as _mean/_std, frames and
    wall time to each threshold with the seeds reaching it, each suite's MAE and gap."""
    suites = rows[0]["suites"] if rows else []
    pairs = PAIRS + tuple(f"{kind}:{s}" for s in suites for kind in ("suite", "gap"))
    names = {f"{kind}:{s}": f"{kind}_{suite_label(s).replace(' ', '_')}_mae" if kind == "suite" else
             f"gap_{suite_label(s).replace(' ', '_')}" for s in suites for kind in ("suite", "gap")}
    buf = io.StringIO()
    w = csv.writer(buf)
    w.writerow(list(TEXT) + [f"{c}_{x}" for c in CI for x in ("mean", "lo", "hi")]
               + [f"{names.get(c, c)}_{x}" for c in pairs for x in ("mean", "std")]
               + [f"{x}_{k.replace('.0', '')}deg" for k in THRESHOLDS
                  for x in ("frames_to", "wall_s_to", "seeds_reaching")])
    for r in rows:
        text = r | {"options": json.dumps(r["options"], sort_keys=True) if isinstance(r["options"], dict) else ""}
        to = [r.get(f"to:{k}") for k in THRESHOLDS]
        w.writerow([text[c] for c in TEXT] + [v for c in CI for v in r[c]]
                   + [v for c in pairs for v in (r[c] if isinstance(r.get(c), tuple) else ("", ""))]
                   + [v for t in to for v in ((t["frames"], t["wall_s"], f"{t['reached']}/{t['of']}" if t["of"]
                                               else "") if t else ("", "", ""))])
    return buf.getvalue()
