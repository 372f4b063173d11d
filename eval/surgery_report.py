"""The re-learning experiment's outputs (`eval.surgery`): summary.json, report.md with its figures, and the
leaderboard's "surgery" section.

Figures per scenario, in `figures/` (PNG):
  <scenario>_tracking.png     test trajectory 0 (the first seed's agents): target and angle of the pre-op agent on the
                              intact shoulder and of the zero-shot, fine-tuned and from-scratch agents post-op (top),
                              each agent's muscle activations (below);
  <scenario>_activations.png  each muscle's share of the summed activation over the test set, per agent (means over
                              seeds, ± std), and below / at or above 45 deg;
  <scenario>_recovery.png     accuracy (pre-op MAE / MAE) against post-op training frames, fine-tune (from the
                              zero-shot point at 0) and from scratch, one line per seed, with the 90 % line and the
                              goal's budget (10 % of the pre-op training frames).

`leaderboard_section.md` is a Markdown section ("## surgery") with one row per scenario, for the leaderboard to
include as it stands (docs/surgery.md); summary.json holds the same rows as `leaderboard_rows`.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from shoulder_bench.eval.surgery_checks import statics_label

KINDS = {"preop": "pre-op (intact)", "zero_shot": "zero-shot (post-op)", "finetune": "fine-tuned (post-op)",
         "scratch": "from scratch (post-op)"}
KIND_COLOURS = {"preop": "tab:blue", "zero_shot": "tab:red", "finetune": "tab:green", "scratch": "tab:gray"}
SECTION_HEAD = ["task", "algorithm", "condition", "pre-op agent", "seeds", "pre-op MAE (intact)", "zero-shot MAE",
                "fine-tuned MAE", "fine-tune frames", "recovered to 90 % (frames)", "scratch MAE (frames)",
                "static reach post-op"]


def name(r: dict) -> str:
    """A scenario's file stem: task_algo_condition."""
    from shoulder_bench.eval.surgery_checks import folder_name

    return f"{r['task']}_{r['algo']}_{folder_name(r['options'])}".replace("+", "-").replace(",", "_").replace("=", "")


def _pm(v, digits=2, pct=False) -> str:
    if v is None:
        return "–"
    m, s = v
    if pct:
        return f"{m:.0%}" + (f" ± {s:.0%}" if s else "")
    return f"{m:.{digits}f}" + (f" ± {s:.{digits}f}" if s else "")


def _frames(n) -> str:
    return "–" if n is None else f"{int(round(n)):,}"


def recovered_text(r: dict, kind: str = "finetune") -> str:
    a = r["mean"].get(kind)
    if a is None:
        return "–"
    if a["frames_to_recovery"] is not None:
        text = f"{a['reached']} seeds, {_frames(a['frames_to_recovery'][0])} frames"
        if a["training_s_to_recovery"]:
            text += f", {a['training_s_to_recovery'][0]:.0f} s"
        return text
    return f"0/{a['reached'].split('/')[1]}; best accuracy {_pm(a['best_accuracy'], pct=True)}"


def leaderboard_rows(summary: dict) -> list[dict]:
    rows = []
    for r in summary["scenarios"]:
        m, f = r["mean"], r["feasibility"]["post_op"]
        reach = statics_label(f) + ("" if f["holds_task_range"] else " (cannot hold the task range)")
        rows.append({"task": r["task"], "algorithm": r["algo"], "condition": r["condition"],
                     "pre-op agent": ", ".join(r["preop_source"]), "seeds": str(len(r["seeds"])),
                     "pre-op MAE (intact)": _pm(m["preop"]["mae_deg"]),
                     "zero-shot MAE": _pm(m["zero_shot"]["mae_deg"]),
                     "fine-tuned MAE": _pm(m["finetune"]["mae_deg"]),
                     "fine-tune frames": _frames(r["finetune_frames"]),
                     "recovered to 90 % (frames)": recovered_text(r),
                     "scratch MAE (frames)": (f"{_pm(m['scratch']['mae_deg'])} ({_frames(r['scratch_frames'])})"
                                              if "scratch" in m else "–"),
                     "static reach post-op": reach})
    return rows


def tables(summary: dict) -> list[dict]:
    """The provenance of each table folder the scenarios ran on (a summary written before the 3-DOF tasks held one)."""
    t = summary["tables"]
    return [t] if isinstance(t, dict) else list(t)


def section_intro(summary: dict) -> str:
    """The "surgery" section's paragraph: what the rows are and which force tables they ran on."""
    labels = []
    for t in tables(summary):
        label = (f"force tables {t['folder']} last changed in commit {t['commit'][:10]} (code at {t['head'][:10]})"
                 if t.get("commit") else f"force tables {t['folder']} (SHA-256 {t['sha256'][:12]})")
        labels.append(label + (" (working tree differs)" if t.get("dirty") else ""))
    return ("The re-learning experiment (issue 13 §3, `shoulder-bench surgery`; docs/surgery.md): the pre-op agent on "
            "the post-op shoulder zero-shot, fine-tuned, and an agent trained post-op from scratch. MAE in deg on the "
            f"task's fixed test set (mean ± std over seeds). {summary['definition']}. Run on {'; '.join(labels)}.")


def section(summary: dict) -> str:
    """The leaderboard's "surgery" section (Markdown)."""
    lines = ["## surgery", "", section_intro(summary), "",
             "| " + " | ".join(SECTION_HEAD) + " |", "|" + "---|" * len(SECTION_HEAD)]
    lines += ["| " + " | ".join(row[h] for h in SECTION_HEAD) + " |" for row in leaderboard_rows(summary)]
    return "\n".join(lines) + "\n"


def one_line(r: dict) -> str:
    m = r["mean"]
    return (f"surgery {r['task']} {r['algo']} {r['condition']}: pre-op {_pm(m['preop']['mae_deg'])} deg intact, "
            f"zero-shot {_pm(m['zero_shot']['mae_deg'])}, fine-tuned {_pm(m['finetune']['mae_deg'])} after "
            f"{r['finetune_frames']:,} frames (recovered to 90 %: {recovered_text(r)})"
            + (f", scratch {_pm(m['scratch']['mae_deg'])}" if "scratch" in m else ""))


def scenario_markdown(r: dict, figures: dict[str, str]) -> str:
    from shoulder_bench.conditions import CONDITIONS

    m = r["mean"]
    parts = [p.strip() for p in r["condition"].split("+")]
    desc = "; ".join(f"{p}: {CONDITIONS[p].description}" for p in parts if p in CONDITIONS)
    removed = (f" Removed (no force): {', '.join(r['removed_muscles'])}; their commanded activation still counts in "
               f"the shares." if r["removed_muscles"] else "")
    out = [f"## {r['task']} · {r['algo'].upper()} · {r['condition']}", "",
           f"{desc}.{removed} Options post-op: `{json.dumps(r['options'])}`. Pre-op agent: "
           f"{', '.join(r['preop_source'])} ({_frames(r['preop_frames'])} training frames). Fine-tune budget "
           f"{r['finetune_frames']:,} frames, from scratch {r['scratch_frames']:,}, evaluated every "
           f"{r['eval_every']:,}. Seeds: {', '.join(str(s['seed']) for s in r['seeds'])}.", "",
           f"Feasibility: {r['feasibility_text']}.", "",
           "| seed | pre-op MAE (intact) | zero-shot MAE (accuracy) | fine-tuned MAE (accuracy) | recovered to 90 % "
           "| best fine-tune accuracy (at frames) | scratch MAE (accuracy) | scratch to 90 % |",
           "|---|---|---|---|---|---|---|---|"]
    for s in r["seeds"]:
        ft, sc = s["finetune"], s.get("scratch")
        rec = ft["recovery"]
        hit = (f"{rec['frames']:,} frames, {rec['training_s']:.0f} s" if rec["reached"] else "not reached")
        srec = sc and sc["recovery"]
        out.append(f"| {s['seed']} | {s['preop']['mae_deg']:.2f} | {s['zero_shot']['mae_deg']:.2f} "
                   f"({s['zero_shot']['accuracy']:.0%}) | {ft['mae_deg']:.2f} ({ft['accuracy']:.0%}) | {hit} | "
                   f"{rec['best_accuracy']:.0%} ({rec['best_at_frames']:,}) | "
                   + (f"{sc['mae_deg']:.2f} ({sc['accuracy']:.0%}) | "
                      + (f"{srec['frames']:,} frames" if srec["reached"] else "not reached") if sc else "– | –")
                   + " |")
    coords = [k for k in KINDS if "coordinate_mae_deg" in m.get(k, {})]
    if coords:
        out += ["", "Each coordinate's MAE (deg, mean over seeds; the orientation MAE above is not their sum): "
                + "; ".join(f"{KINDS[k]} " + " / ".join(f"{c} {_pm(v)}" for c, v in m[k]["coordinate_mae_deg"].items())
                            for k in coords) + "."]
    goal = r["goal"]
    out += ["", f"Goal (issue 13): {RECOVERY_PCT} of the pre-op accuracy within {goal['within_frames']:,.0f} "
                f"fine-tune frames (10 % of the pre-op training frames): met by {goal['met']} seeds.", ""]
    kinds = [k for k in KINDS if k in m]
    out += ["Each muscle's share of the summed activation over the test set (mean over seeds):", "",
            "| muscle | " + " | ".join(KINDS[k] for k in kinds) + " | shift (fine-tuned − pre-op) |",
            "|---|" + "---|" * (len(kinds) + 1)]
    for mus in r["muscles"]:
        shift = r["share_shift_finetune_minus_preop"].get(mus)
        out.append(f"| {mus}{' (removed)' if mus in r['removed_muscles'] else ''} | "
                   + " | ".join(_pm(m[k]["shares"][mus], pct=True) for k in kinds)
                   + f" | {'–' if shift is None else f'{100 * shift[0]:+.1f} points'} |")
    out += [""] + [f"![{k}]({v})" for k, v in figures.items()] + [""]
    return "\n".join(out)


RECOVERY_PCT = "90 %"


def report_markdown(summary: dict, figures: dict[str, dict[str, str]]) -> str:
    labels = []
    for t in tables(summary):
        label = (f"force tables `{t['folder']}` ({', '.join(t['files'])}; SHA-256 {t['sha256'][:12]}), last changed "
                 f"in commit {t['commit']}, code at commit {t['head']}" if t.get("commit")
                 else f"force tables `{t['folder']}` (SHA-256 {t['sha256'][:12]})")
        labels.append(label + (" — the working tree's tables differ from that commit" if t.get("dirty") else ""))
    head = ["# Surgery: the pre-op → post-op re-learning experiment", "",
            f"Run on {'; '.join(labels)}. {summary['definition']}.", ""]
    body = [scenario_markdown(r, figures[name(r)]) for r in summary["scenarios"]]
    return "\n".join(head + body) + "\n" + section(summary).replace("## surgery", "## Leaderboard section")


# --- figures ----------------------------------------------------------------------------------------------------------
def muscle_colours(muscles) -> list:
    """One colour per muscle: the 1-DOF tasks' own (`plots.MUSCLE_COLOURS`), tab20 for the full shoulder's 13."""
    import matplotlib

    from shoulder_bench.eval.plots import MUSCLE_COLOURS

    if len(muscles) <= len(MUSCLE_COLOURS):
        return [MUSCLE_COLOURS.get(m) for m in muscles]
    return [matplotlib.colormaps["tab20"](k % 20) for k in range(len(muscles))]


def _tracking(r: dict, tr: dict):
    """Test trajectory 0: target and angle per agent (one panel per coordinate on the 3-DOF tasks), and each agent's
    activations below."""
    import matplotlib.pyplot as plt
    import matplotlib.ticker

    from shoulder_bench.protocol import FRAME_S

    kinds = [k for k in KINDS if k in tr]
    angle = tr["preop"]["angle_deg"]
    coords = ["abduction"] if angle.ndim == 2 else ["plane of elevation", "elevation", "axial rotation"]
    pick = (lambda x, c: x[0]) if angle.ndim == 2 else (lambda x, c: x[0, :, c])
    fig = plt.figure(figsize=(3.2 * len(kinds) + 1, 3.6 + 2.4 * len(coords)))
    grid = fig.add_gridspec(len(coords) + 1, len(kinds), height_ratios=[3 if len(coords) == 1 else 2] * len(coords)
                            + [2])
    t = (np.arange(angle.shape[1]) + 1) * FRAME_S
    top = None
    for c, label in enumerate(coords):
        ax = fig.add_subplot(grid[c, :], sharex=top)
        top = top or ax
        ax.plot(t, pick(tr["preop"]["target_deg"], c), color="black", lw=1.6, label="target")
        for k in kinds:
            ax.plot(t, pick(tr[k]["angle_deg"], c), color=KIND_COLOURS[k], lw=1.1, label=KINDS[k],
                    ls="--" if k == "zero_shot" else "-")
        ax.set(ylabel=f"{label} (deg)")
        ax.grid(alpha=0.3)
    top.set_title(f"{r['task']} · {r['algo'].upper()} · {r['condition']}: test trajectory 0 (seed "
                  f"{r['seeds'][0]['seed']})")
    top.legend(fontsize=7, loc="upper right")
    colours = muscle_colours(r["muscles"])
    for col, k in enumerate(kinds):
        ax = fig.add_subplot(grid[len(coords), col], sharex=top)
        for j, mus in enumerate(r["muscles"]):
            ax.plot(t, tr[k]["activation"][0, :, j], color=colours[j], lw=1,
                    label=mus + (" (removed)" if mus in r["removed_muscles"] and k != "preop" else ""))
        ax.set(title=KINDS[k], xlabel="time (s)", ylim=(-0.02, 1.02), ylabel="activation" if col == 0 else None)
        ax.xaxis.set_major_locator(matplotlib.ticker.MaxNLocator(5))
        ax.grid(alpha=0.3)
        ax.legend(fontsize=5 if len(r["muscles"]) > 4 else 6, loc="upper right", ncol=1 + len(r["muscles"]) // 7)
    fig.tight_layout()
    return fig


def _activations(r: dict):
    import matplotlib.pyplot as plt

    kinds = [k for k in KINDS if k in r["mean"]]
    muscles = r["muscles"]
    fig, axes = plt.subplots(1, 3, figsize=(14 if len(muscles) <= 4 else 22, 3.8), sharey=True)
    width = 0.8 / len(kinds)
    x = np.arange(len(muscles))
    arm = "elevation" if len(r["seeds"][0]["preop"].get("coordinate_mae_deg") or {}) else "arm"
    parts = (("all", "all frames"), ("early", f"{arm} below 45 deg"), ("late", "at or above 45 deg"))
    top = 1.1 * max(np.nanmax([[s[k]["shares"][part][m] for m in muscles] for s in r["seeds"] if k in s])
                    for k in kinds for part, _ in parts)
    for ax, (part, title) in zip(axes, parts):
        for i, k in enumerate(kinds):
            vals = np.array([[s[k]["shares"][part][m] for m in muscles] for s in r["seeds"] if k in s], dtype=float)
            ax.bar(x + (i - (len(kinds) - 1) / 2) * width, np.nanmean(vals, axis=0), width,
                   yerr=np.nanstd(vals, axis=0) if len(vals) > 1 else None, color=KIND_COLOURS[k], label=KINDS[k])
        if len(muscles) <= 4:
            ax.set_xticks(x, [m + ("\n(removed)" if m in r["removed_muscles"] else "") for m in muscles])
        else:  # the full shoulder: 13 muscles, the shares small
            ax.set_xticks(x, [m + (" (removed)" if m in r["removed_muscles"] else "") for m in muscles], rotation=40,
                          ha="right", fontsize=8)
        ax.set(title=f"share of summed activation: {title}", ylim=(0, 1 if len(muscles) <= 4 else top))
        ax.grid(alpha=0.3, axis="y")
    axes[0].set_ylabel("share")
    axes[0].legend(fontsize=7)
    fig.suptitle(f"{r['task']} · {r['algo'].upper()} · {r['condition']}: activation pattern before / after",
                 fontsize=10)
    fig.tight_layout()
    return fig


def _recovery(r: dict):
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.5, 4.2))
    for s in r["seeds"]:
        for k, ls in (("finetune", "-"), ("scratch", "--")):
            if k in s and s[k]["curve"]:
                pts = s[k]["curve"]
                ax.plot([p["frames"] for p in pts], [p["accuracy"] for p in pts], ls, marker="o", ms=3,
                        color=KIND_COLOURS[k], label=f"{KINDS[k]}, seed {s['seed']}")
    ax.axhline(0.9, color="black", lw=1, ls=":", label="90 % of pre-op accuracy")
    ax.axvline(r["goal"]["within_frames"], color="tab:orange", lw=1, ls=":",
               label="10 % of the pre-op training frames")
    ax.set(xlabel="post-op training frames", ylabel="accuracy = pre-op MAE / MAE (log)", yscale="log",
           title=f"{r['task']} · {r['algo'].upper()} · {r['condition']}: recovery")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=6)
    fig.tight_layout()
    return fig


def finite(obj):
    """`obj` with every non-finite float as None (JSON has no NaN or infinity)."""
    if isinstance(obj, dict):
        return {k: finite(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [finite(v) for v in obj]
    if isinstance(obj, (float, np.floating)):
        return float(obj) if np.isfinite(obj) else None
    if isinstance(obj, np.integer):
        return int(obj)
    return obj


def write(summary: dict, traces: list[dict], out: Path) -> list[Path]:
    """summary.json, report.md, leaderboard_section.md and the figures in `out`, renamed into place together."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from shoulder_bench.eval.plots import replace_all

    out = Path(out)
    jobs, figs, figures = [], [], {}
    for r, tr in zip(summary["scenarios"], traces):
        stem = name(r)
        first = tr[r["seeds"][0]["seed"]]
        figures[stem] = {}
        for label, fig in (("tracking", _tracking(r, first)), ("activations", _activations(r)),
                           ("recovery", _recovery(r))):
            rel = f"figures/{stem}_{label}.png"
            figures[stem][label] = rel
            figs.append(fig)
            jobs.append((out / rel, lambda tmp, fig=fig: fig.savefig(tmp, dpi=110, format="png")))
    summary = summary | {"leaderboard_rows": leaderboard_rows(summary)}
    texts = {"summary.json": json.dumps(finite(summary), indent=1, allow_nan=False) + "\n",
             "report.md": report_markdown(summary, figures), "leaderboard_section.md": section(summary)}
    jobs += [(out / k, lambda tmp, text=v: tmp.write_text(text, encoding="utf-8")) for k, v in texts.items()]
    try:
        return replace_all(jobs)
    finally:
        for fig in figs:
            plt.close(fig)
