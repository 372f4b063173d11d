"""`shoulder-bench plot FIGURE ...`: the paper's figures (Figs. 2-5) for our runs and agents, as PNG and SVG.

- curves RUN...                  reward and test-MAE curves of training runs (Figs. 2, 4)
- trajectory --policy SPEC...    one test trajectory: target, angle and each muscle's activation (Figs. 3, 5)
- errors --policy SPEC...        per-trajectory MAE and RMSE on the test set as box plots, one box per policy (Fig. 3)
- activations --policy SPEC...   activation patterns against the abduction angle over the test set, a row per policy
                                 (Fig. 5)
- paper [--runs DIR]             all of them from the shipped agents (and curves from runs) into one folder

SPEC is a policy file, a run folder, `pretrained:NAME` or `reference` (the model-based controller, on --task).
Every input is checked and every policy loaded before any rollout; each figure is written to a temporary name and
renamed when complete, so a failure leaves nothing behind.
"""
from __future__ import annotations

import os
from functools import partial
from pathlib import Path

import matplotlib
import matplotlib.ticker
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

MUSCLE_COLOURS = {"ssp": "tab:orange", "isp": "tab:green", "dmi": "tab:red", "ld": "tab:purple"}


def png_base64(fig) -> str:
    """`fig` as a base64 PNG (for an html page's data: URL), the figure closed."""
    import base64
    import io

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    plt.close(fig)
    return base64.b64encode(buf.getvalue()).decode()


def checked(out: Path | str) -> Path:
    """The figure's path, checked before any work: a .png, .svg or .pdf name that is not a folder."""
    out = Path(out)
    if out.is_dir():
        raise ValueError(f"--out {out} is a directory; give a file name such as {out / 'figure.png'}")
    if out.suffix.lower() not in (".png", ".svg", ".pdf"):
        raise ValueError(f"--out {out}: give a .png, .svg or .pdf file name")
    return out


def checked_dir(out_dir: Path | str, option: str = "--out-dir") -> Path:
    """An output folder, checked before any work: absent (it is created when writing) or a folder."""
    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise ValueError(f"{option} {out_dir} is an existing file, not a folder; give a folder name")
    return out_dir


def replace_all(contents: list[tuple[Path, object]]) -> list[Path]:
    """Write each (path, writer) pair atomically: writer(tmp) fills a temporary name beside the path, and once all
    are complete they are renamed into place; on any failure the temporary files are removed and nothing is left."""
    tmps = []
    try:
        for path, writer in contents:
            path.parent.mkdir(parents=True, exist_ok=True)
            tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
            tmps.append(tmp)
            writer(tmp)
        for (path, _), tmp in zip(contents, tmps):
            os.replace(tmp, path)
    finally:
        for tmp in tmps:
            tmp.unlink(missing_ok=True)
    return [path for path, _ in contents]


def _paths(out: Path) -> list[Path]:
    return [out] + ([out.with_suffix(".svg")] if out.suffix.lower() != ".svg" else [])


def save_all(figures: list[tuple[object, Path | str]]) -> list[Path]:
    """Write every (figure, out) as `out` and the same figure as SVG beside it, all renamed into place at the end."""
    try:
        jobs = [(path, partial(_savefig, fig, path.suffix[1:].lower()))
                for fig, out in figures for path in _paths(checked(out))]
        return replace_all(jobs)
    finally:
        for fig, _ in figures:
            plt.close(fig)


def _savefig(fig, fmt: str, path: Path) -> None:
    fig.savefig(path, dpi=120, format=fmt)


def save(fig, out: Path | str) -> list[Path]:
    """Write `out` and the same figure as SVG beside it (atomically)."""
    return save_all([(fig, out)])


def _label(spec: str, meta: dict, task: str) -> str:
    if spec == "reference":
        return f"reference · {task}"
    shown = spec.split(":", 1)[1] if spec.startswith("pretrained:") else Path(spec).name
    return f"{meta.get('algo', 'policy').upper()} · {shown}"


def _policies(specs: list[str], task: str | None) -> list[tuple[str, object, dict, str]]:
    """(spec, policy, metadata, task) per policy, all loaded (and so checked) before any rollout."""
    from shoulder_bench.eval.evaluate import policy_for

    return [(spec, *policy_for(spec, task if spec == "reference" else None)) for spec in specs]


def _rollouts(specs: list[str], task: str | None, trajectories) -> list[tuple[str, str, str, dict]]:
    """(label, task, algorithm, recorded evaluation) per policy."""
    from shoulder_bench.eval.evaluate import evaluate

    return [(_label(spec, meta, t), t, meta.get("algo"),
             evaluate(policy, t, trajectories, muscle_model=meta.get("muscle_model"), record=True,
                      options=meta.get("options")))
            for spec, policy, meta, t in _policies(specs, task)]


# --- figures ------------------------------------------------------------------------------------------------------
CURVES = ("train/mean_return", "test/mae_deg")


def scalars(run: Path, tag: str | None = None):
    """The (steps, values) of `tag` in a run's TensorBoard logs ([], [] if never logged); without tag, a dict of
    every tag in CURVES."""
    import logging

    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    logging.getLogger("tensorboard").setLevel(logging.ERROR)  # a resumed run purges its events after the checkpoint
    tb = Path(run) / "tb"
    if not tb.is_dir():
        raise FileNotFoundError(f"run folder {run} has no tb/ folder (TensorBoard logs): not a shoulder-bench run")
    acc = EventAccumulator(str(tb), size_guidance={"scalars": 0})
    acc.Reload()
    have = acc.Tags()["scalars"]

    def series(t):
        events = acc.Scalars(t) if t in have else []
        return [e.step for e in events], [e.value for e in events]

    return series(tag) if tag is not None else {t: series(t) for t in CURVES}


def _curves(run: Path, cfg: dict | None = None) -> tuple[str, dict]:
    """(legend label, the CURVES series) of one run, checked: a clear error naming the run and what is missing.
    cfg: its config.json as `run_config` reads it (read here when not given)."""
    from shoulder_bench.eval.board_columns import options_text
    from shoulder_bench.eval.evaluate import run_config

    cfg = cfg if cfg is not None else run_config(run)
    series = scalars(run)
    if not any(steps for steps, _ in series.values()):
        raise ValueError(f"run folder {run}: tb/ holds none of the training curves ({', '.join(CURVES)}); has the "
                         f"run logged anything yet?")
    shown = f", {options_text(cfg['options'])}" if cfg.get("options") else ""
    return f"{cfg['algo']} {cfg['task']} seed {cfg['seed']}{shown}", series


def plot_curves(runs: list[Path], out: Path) -> list[Path]:
    """Each run's curves, labelled by algorithm, task, seed and task options; runs those leave alike (another config,
    another folder) also by their folder. The paper's PPO-4 accuracy is drawn where a run is of a 1-DOF task."""
    from shoulder_bench.eval.evaluate import run_config
    from shoulder_bench.tasks import TASKS

    checked(out)
    configs = [run_config(run) for run in runs]
    curves = [_curves(Path(run), cfg) for run, cfg in zip(runs, configs)]  # every run checked before drawing
    labels = [label for label, _ in curves]
    curves = [(f"{label} ({run})" if labels.count(label) > 1 else label, series)
              for run, (label, series) in zip(runs, curves)]
    paper = any(cfg["task"] in TASKS for cfg in configs)  # the paper's accuracy is a 1-DOF task's
    return save(_curves_figure(curves, paper), out)


def _curves_figure(curves: list[tuple[str, dict]], paper: bool = True):
    """Training reward and test MAE against frames, a line per run; paper: the paper's PPO-4 test MAE (5.15 deg,
    the 1-DOF abduction task) dashed."""
    fig, (ax_r, ax_e) = plt.subplots(1, 2, figsize=(11, 4))
    for label, series in curves:
        ax_r.plot(*series["train/mean_return"], label=label)
        ax_e.plot(*series["test/mae_deg"], marker="o", label=label)
    ax_r.set(xlabel="frames", ylabel="mean episode return (recent training episodes)", title="training reward")
    if paper:
        ax_e.axhline(5.15, color="gray", ls="--", lw=1, label="paper PPO-4 (their model)")
    ax_e.set(xlabel="frames", ylabel="test-set MAE (deg)", title="fixed test set (100 trajectories)", yscale="log")
    for ax in (ax_r, ax_e):
        ax.xaxis.set_major_formatter(matplotlib.ticker.FuncFormatter(lambda x, _: f"{x / 1e6:g} M"))
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    return fig


def sample_efficiency_figure(panels: dict[str, list[tuple[str, dict]]]):
    """Test MAE against frames, one panel per name in `panels`, each curve (label, {"frames", "mean", "lo", "hi"})
    a line with its band (where lo/hi are finite: several seeds); the paper's PPO-4 accuracy as a dashed line."""
    fig, axes = plt.subplots(1, len(panels), figsize=(6.5 * len(panels), 4.2), squeeze=False)
    for ax, (name, curves) in zip(axes[0], panels.items()):
        for label, c in curves:
            line, = ax.plot(c["frames"], c["mean"], marker="o", ms=3, label=label)
            ok = np.isfinite(c["lo"]) & np.isfinite(c["hi"])
            if ok.any():
                ax.fill_between(c["frames"][ok], c["lo"][ok], c["hi"][ok], color=line.get_color(), alpha=0.2)
        ax.axhline(5.15, color="gray", ls="--", lw=1, label="paper PPO-4 (their model)")
        ax.set(xlabel="training frames", ylabel="test-set MAE (deg)", title=f"sample efficiency, {name}",
               yscale="log")
        ax.xaxis.set_major_formatter(matplotlib.ticker.FuncFormatter(lambda x, _: f"{x / 1e6:g} M"))
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    return fig


def wallclock_figure(results: dict[str, list[list[dict]]], goals=(), title: str = ""):
    """Test MAE against training wall time (evaluations excluded) and against frames, one colour per config: each
    seed a thin line, the median over seeds at each evaluation bold (plotted at the seeds' median wall time).
    results: config -> one `metrics.json` "evaluations" list per seed; goals: (seconds, deg, label) marked on the
    wall-time panel; the thresholds 1 and 0.5 deg dotted."""
    fig, (ax_s, ax_f) = plt.subplots(1, 2, figsize=(12, 4.5), sharey=True)
    for k, (name, seeds) in enumerate(results.items()):
        colour = f"C{k % 10}"
        n = min(len(e) for e in seeds) if seeds else 0
        for evals in seeds:
            mae = [e["mae_deg"] for e in evals]
            ax_s.plot([e["training_s"] for e in evals], mae, color=colour, lw=0.8, alpha=0.35)
            ax_f.plot([e["frames"] for e in evals], mae, color=colour, lw=0.8, alpha=0.35)
        if n:
            at = [np.median(np.array([[e[i][key] for i in range(n)] for e in seeds]), axis=0)
                  for key in ("training_s", "frames", "mae_deg")]
            label = f"{name} ({len(seeds)} seeds)"
            ax_s.plot(at[0], at[2], color=colour, lw=2, label=label)
            ax_f.plot(at[1], at[2], color=colour, lw=2, label=label)
    for seconds, deg, label in goals:
        ax_s.plot([seconds], [deg], marker="X", ms=10, color="black", ls="none")
        ax_s.annotate(label, (seconds, deg), textcoords="offset points", xytext=(6, 6), fontsize=8)
    for ax in (ax_s, ax_f):
        for deg in (1.0, 0.5):
            ax.axhline(deg, color="gray", ls=":", lw=1)
        ax.set(yscale="log")
        ax.grid(alpha=0.3)
    ax_s.set(xlabel="training wall time, evaluations excluded (s)", ylabel="test-set MAE (deg)",
             title=title or "time to accuracy")
    ax_f.set(xlabel="training frames", title="the same against frames (sample efficiency)")
    ax_f.xaxis.set_major_formatter(matplotlib.ticker.FuncFormatter(lambda x, _: f"{x / 1e3:g}k"))
    if ax_f.get_legend_handles_labels()[0]:  # no curve at all: no legend
        ax_f.legend(fontsize=7)
    fig.tight_layout()
    return fig


def plot_trajectory(specs: list[str], out: Path, task: str | None = None, trajectories: str = "test",
                    index: int = 0) -> list[Path]:
    """Per policy, one column: target and angle (top), each muscle's activation (bottom)."""
    return save(_trajectory_figure(specs, out, task, trajectories, index), out)


def _trajectory_figure(specs, out, task=None, trajectories="test", index=0):
    checked(out)
    from shoulder_bench.eval.evaluate import trajectories_for
    from shoulder_bench.protocol import FRAME_S
    from shoulder_bench.tasks import TASKS

    pool = trajectories_for(trajectories)
    if not 0 <= index < len(pool):
        raise ValueError(f"--index {index}: the {trajectories} set has {len(pool)} trajectories (0..{len(pool) - 1})")
    runs = _rollouts(specs, task, [pool[index]])
    fig, axes = plt.subplots(2, len(runs), figsize=(4.2 * len(runs) + 0.5, 5.2), sharex=True, squeeze=False,
                             gridspec_kw={"height_ratios": [3, 2]})
    for col, (label, t, _, m) in enumerate(runs):
        tr = m["trace"]
        time = (np.arange(tr["angle_deg"].shape[1]) + 1) * FRAME_S
        top, bottom = axes[0, col], axes[1, col]
        top.plot(time, tr["target_deg"][0], color="black", lw=1.5, label="target")
        top.plot(time, tr["angle_deg"][0], color="tab:blue", lw=1.2, label="angle")
        top.set(title=f"{label}\nMAE {m['mae_deg']:.2f} deg" + (" · CRASHED" if m["crashes"] else ""),
                ylabel="abduction (deg)" if col == 0 else None)
        for k, muscle in enumerate(TASKS[t][0]):
            bottom.plot(time, tr["activation"][0, :, k], color=MUSCLE_COLOURS[muscle], label=muscle)
        bottom.set(xlabel="time (s)", ylabel="activation" if col == 0 else None, ylim=(-0.02, 1.02))
        for ax in (top, bottom):
            ax.grid(alpha=0.3)
            ax.legend(fontsize=7, loc="upper right")
    fig.suptitle(f"{trajectories} trajectory {index}", fontsize=10)
    fig.tight_layout()
    return fig


def error_boxes(ax_mae, ax_rmse, groups: list[tuple[str, tuple | None, np.ndarray, np.ndarray]]) -> None:
    """Box plots of per-trajectory MAE and RMSE, one box per (label, the paper's (MAE, RMSE) or None, mae, rmse); the
    paper's means as diamonds."""
    labels = [g[0] for g in groups]
    for ax, col, name in ((ax_mae, 2, "MAE"), (ax_rmse, 3, "RMSE")):
        ax.boxplot([g[col] for g in groups], orientation="horizontal", tick_labels=labels, showfliers=True,
                   flierprops={"markersize": 3})
        marked = False
        for y, (_, paper, _, _) in enumerate(groups, start=1):
            if paper:
                ax.plot(paper[col - 2], y, "D", color="gray", ms=6,
                        label=None if marked else "paper mean (their model)")
                marked = True
        ax.set(xscale="log", xlabel=f"per-trajectory {name} (deg), log scale")
        ax.grid(alpha=0.3, axis="x")
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7)
    ax_rmse.tick_params(labelleft=False)


def plot_errors(specs: list[str], out: Path, task: str | None = None) -> list[Path]:
    return save(_errors_figure(specs, out, task), out)


def _errors_figure(specs, out, task=None):
    checked(out)
    from shoulder_bench.eval.evaluate import trajectories_for
    from shoulder_bench.eval.leaderboard import paper_errors

    runs = _rollouts(specs, task, trajectories_for("test"))
    groups = [(label, paper_errors(t, algo), np.array(m["per_trajectory"]["mae_deg"]),
               np.array(m["per_trajectory"]["rmse_deg"])) for label, t, algo, m in runs]
    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 0.45 * len(groups) + 1.6), sharey=True)
    error_boxes(a, b, groups)
    a.invert_yaxis()  # the first policy on top
    fig.suptitle("fixed test set: 100 trajectories of 20 s", fontsize=10)
    fig.tight_layout()
    return fig


def plot_activations(specs: list[str] | str, out: Path, task: str | None = None, bin_deg: float = 5.0) -> list[Path]:
    """Per policy, one row: mean activation of each muscle against the angle (left), and each muscle's share of the
    sum (right)."""
    return save(_activations_figure([specs] if isinstance(specs, str) else list(specs), out, task, bin_deg), out)


def _activations_figure(specs: list[str], out: Path, task: str | None = None, bin_deg: float = 5.0):
    checked(out)
    from shoulder_bench.eval.evaluate import trajectories_for
    from shoulder_bench.eval.measures import EARLY_DEG
    from shoulder_bench.tasks import TASKS

    runs = _rollouts(specs, task, trajectories_for("test"))
    fig, axes = plt.subplots(len(runs), 2, figsize=(11, 4 * len(runs)), squeeze=False)
    for (label, t, _, m), (left, right) in zip(runs, axes):
        muscles = TASKS[t][0]
        tr = m["trace"]
        ok = ~np.isnan(tr["angle_deg"])
        q, a = tr["angle_deg"][ok], tr["activation"][ok]
        edges = np.arange(np.floor(q.min() / bin_deg) * bin_deg, q.max() + bin_deg, bin_deg)
        which = np.digitize(q, edges) - 1
        used = [b for b in range(len(edges) - 1) if np.count_nonzero(which == b) >= 20]
        centres = np.array([edges[b] + bin_deg / 2 for b in used])
        mean = np.array([a[which == b].mean(axis=0) for b in used])
        std = np.array([a[which == b].std(axis=0) for b in used])
        for k, muscle in enumerate(muscles):
            c = MUSCLE_COLOURS[muscle]
            left.plot(centres, mean[:, k], color=c, label=muscle)
            left.fill_between(centres, mean[:, k] - std[:, k], mean[:, k] + std[:, k], color=c, alpha=0.15)
        share = mean / np.maximum(mean.sum(axis=1, keepdims=True), 1e-12)
        right.stackplot(centres, share.T, labels=list(muscles), colors=[MUSCLE_COLOURS[x] for x in muscles],
                        alpha=0.8)
        left.set(xlabel="abduction angle (deg)", ylabel="activation (mean ± std over frames)",
                 title=f"{label}: activation against angle (test set)")
        right.set(xlabel="abduction angle (deg)", ylabel="share of summed activation", ylim=(0, 1),
                  title="each muscle's share")
        for ax in (left, right):
            ax.axvline(EARLY_DEG, color="black", ls=":", lw=1)
            ax.grid(alpha=0.3)
            ax.legend(fontsize=7, loc="upper left")
    fig.tight_layout()
    return fig


PAPER_TRAJECTORY = ["pretrained:dqn_ssp", "pretrained:ppo_ssp", "pretrained:ppo_4m", "pretrained:bdq_4m"]
PAPER_ERRORS = ["pretrained:dqn_ssp", "pretrained:ppo_ssp", "pretrained:bdq_4m", "pretrained:ppo_4m", "reference"]


def curve_runs(runs: Path | str) -> list[Path]:
    """The seed-0 runs under `runs` (runs/<task>/<algo>/0) whose curves `plot paper` draws, checked before any work."""
    runs = Path(runs)
    if not runs.is_dir():
        raise FileNotFoundError(f"--runs {runs}: " + ("no such folder" if not runs.exists() else "not a folder")
                                + "; give a folder of runs (runs/<task>/<algo>/<seed>)")
    found = sorted(p.parent for p in runs.glob("*/*/0/config.json") if (p.parent / "tb").is_dir())
    if not found:
        raise FileNotFoundError(f"--runs {runs} holds no seed-0 runs with TensorBoard logs (runs/<task>/<algo>/0/tb)")
    return found


def paper_figures(out_dir: Path, runs: Path | None = None) -> list[Path]:
    """The paper-style set from the shipped agents: Fig. 3 (DQN and PPO, one muscle, and PPO-4 on the same target),
    the error distributions, Fig. 5's activation patterns, and training curves when runs are given. Every input is
    checked first and the figures are written together at the end: a failure writes none."""
    out_dir = checked_dir(out_dir)
    found = curve_runs(runs) if runs is not None else []
    curves = [_curves(run) for run in found]  # every run's config and logs checked before any rollout
    _policies(sorted(set(PAPER_TRAJECTORY + PAPER_ERRORS)), None)  # every shipped agent loads
    figures = [(_trajectory_figure(PAPER_TRAJECTORY, out_dir / "trajectory.png"), out_dir / "trajectory.png")]
    figures.append((_errors_figure(PAPER_ERRORS, out_dir / "errors.png"), out_dir / "errors.png"))
    figures.append((_activations_figure(["pretrained:ppo_4m"], out_dir / "activations.png"),
                    out_dir / "activations.png"))
    if curves:
        figures.append((_curves_figure(curves), out_dir / "curves.png"))
    return save_all(figures)


