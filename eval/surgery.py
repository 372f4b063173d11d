"""The re-learning experiment (issue 13 §3): `shoulder-bench surgery --task T --condition C`.

Per scenario (task, algorithm, condition) and seed:
  pre-op     the shipped agent of the task and algorithm (`--pretrained`), a finished run (`--preop-run DIR`: one run
             for every seed, or DIR/<seed>/ per seed), or one trained now on the intact shoulder (`--frames`);
  zero-shot  the pre-op agent evaluated on the post-op shoulder (task option condition=C), the task's fixed test set
             (`tasks.fixed_test_set`: the paper's on the 1-DOF tasks, the 3-DOF one on track_3dof);
  fine-tune  the pre-op policy trained on, post-op (`experiment.train(..., init_from=...)`: a run of its own whose
             identity records the state it starts from), evaluated every `eval_every` frames;
  scratch    an agent trained post-op from a random initialisation, by default on the fine-tune's frame budget;
  activation each muscle's share of the summed activation over the test set (all frames, and below / at or above
             45 deg: `measures.early_late_share`) for the pre-op agent on the intact shoulder and for the zero-shot,
             fine-tuned and scratch agents post-op.

Accuracy (docs/surgery.md): accuracy = MAE_pre / MAE, MAE_pre the pre-op agent's test-set MAE on the intact shoulder
(measured here, on the same 100 trajectories) and MAE the agent's post-op test-set MAE; the pre-op agent on the
intact shoulder has accuracy 1. The fine-tune "recovers" at the first evaluation with accuracy >= 0.9 (MAE <=
MAE_pre / 0.9): its frames and training wall time (evaluations excluded) are recorded, else the best accuracy
reached and where. Frames are the fine-tune's own (from 0); the issue's goal is recovery within 10 % of the pre-op
agent's training frames.

Checked before any work: the task, algorithm, condition (unknown and not-yet-available conditions, ones that remove a
muscle the task needs), the pre-op source, and that the post-op muscles can hold the arm still at every angle of the
task's test range (1-DOF: 20-100 deg; `statics.static_capacity` against `statics.gravity_torque`, 0.1 deg grid;
3-DOF: every pose of the test box on a 10 deg grid, `statics_full.Statics.held`): where they cannot, the post-op
shoulder cannot physically do the task, which is an error naming the angles (poses) unless `allow_unreachable` (then
the report says so).

Writes to `out`: per scenario the run folders `<task>/<algo>/preop|<condition>/{finetune,scratch}/<seed>` (each a
normal run folder, resumed when the command runs again), `summary.json`, `report.md` with figures in `figures/`, and
`leaderboard_section.md`, the "surgery" section for the leaderboard (`eval/surgery_report.py`).
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from shoulder_bench.eval.surgery_checks import (
    FRACTION_OPTIONS,
    check_preop,
    condition_options,
    feasibility,
    feasibility_text,
    folder_name,
    preop_budget,
    preop_run_for,
    shipped_agent,
    table_folders,
    tables_provenance,
)

RECOVERY = 0.9  # recover 90 % of the pre-op accuracy
GOAL_SHARE = 0.10  # ... within 10 % of the pre-op training frames (issue 13)
CURVE_POINTS = 8  # default fine-tune / scratch evaluations over the budget
DEFAULT_ALGO = {"abduction_ssp": "ppo", "abduction_4m": "ppo", "abduction_ssp_discrete": "dqn",
                "abduction_4m_discrete": "bdq", "track_3dof": "ppo", "track_3dof_discrete": "bdq",
                "elevate_scapular_plane_12m": "ppo"}
# a fine-tune of a Q-learner starts from a good greedy policy: explore little and learn from the start, not with the
# from-scratch schedule (100 % random actions for the first 10k frames, then epsilon from 1.0 over 100k frames)
QLEARNING_FINETUNE = {"eps_start": 0.1, "eps_end": 0.02, "learning_starts": 1_000}


# --- measures ---------------------------------------------------------------------------------------------------------
def shares(trace: dict, muscles) -> dict:
    """Each muscle's share of the summed activation over the recorded test set: overall, below 45 deg (early) and
    at or above (late) of abduction (1-DOF tasks) or elevation (3-DOF tasks)."""
    from shoulder_bench.eval.measures import early_late_share

    angle = trace["angle_deg"] if trace["angle_deg"].ndim == 2 else trace["angle_deg"][..., 1]  # (B, T, 3): elevation
    a = trace["activation"][~np.isnan(angle)]
    total = a.sum()
    out = {"all": {m: float(a[:, k].sum() / total) if total > 0 else float("nan") for k, m in enumerate(muscles)},
           "early": {}, "late": {}}
    for m in muscles:
        out["early"][m], out["late"][m] = early_late_share(angle, trace["activation"], muscles, (m,))
    return out


def accuracy(preop_mae: float, mae: float) -> float:
    return float(preop_mae / mae) if mae > 0 else float("inf")


def curve(evaluations: list[dict], preop_mae: float, start: dict | None = None) -> list[dict]:
    """The recovery curve: (frames, training s, MAE, accuracy) per evaluation, one point per frame count (the last;
    the final evaluation repeats the last periodic one), `start` (the zero-shot point at frame 0) first."""
    points = {}
    for e in ([start] if start else []) + list(evaluations):
        points[int(e["frames"])] = {"frames": int(e["frames"]), "training_s": float(e.get("training_s", 0.0)),
                                    "mae_deg": float(e["mae_deg"]), "crashes": int(e.get("crashes", 0)),
                                    "accuracy": accuracy(preop_mae, float(e["mae_deg"]))}
    return [points[k] for k in sorted(points)]


def recovery(points: list[dict], target: float = RECOVERY) -> dict:
    """The first point with accuracy >= target (frames, training wall s), or None; and the best point."""
    hit = next((p for p in points if p["accuracy"] >= target), None)
    best = max(points, key=lambda p: p["accuracy"]) if points else None
    return {"target_accuracy": target, "reached": hit is not None,
            "frames": hit and hit["frames"], "training_s": hit and hit["training_s"],
            "best_accuracy": best and best["accuracy"], "best_at_frames": best and best["frames"],
            "best_mae_deg": best and best["mae_deg"]}


def _evaluation(policy, task, test, meta, options) -> tuple[dict, dict]:
    """(the metrics without the trace, the trace) of one recorded test-set evaluation."""
    from shoulder_bench.eval.evaluate import evaluate

    m = evaluate(policy, task, test, muscle_model=meta.get("muscle_model"), record=True, options=options)
    trace = m.pop("trace")
    keys = ("mae_deg", "rmse_deg", "crashes", "n_trajectories", "coordinate_mae_deg")  # the last: 3-DOF tasks
    return {k: m[k] for k in keys if k in m}, trace


def _mean_std(values) -> list[float] | None:
    v = np.array([x for x in values if x is not None and np.isfinite(x)], dtype=float)
    return [float(v.mean()), float(v.std())] if v.size else None


# --- the experiment ---------------------------------------------------------------------------------------------------
def plan(tasks, conditions, algo=None, seeds=(0,), frames=None, finetune_frames=None, scratch_frames=None,
         pretrained=False, preop_run=None, muscle_model=None, fractions=None, allow_unreachable=False,
         eval_every=None) -> list[dict]:
    """Every scenario (task x condition), checked before any work."""
    from shoulder_bench.model import DEFAULT_MUSCLE_MODEL
    from shoulder_bench.muscle import check_muscle_model
    from shoulder_bench.tasks import check_name
    from shoulder_bench.train.plan import ALGOS, check_task, count

    if pretrained and preop_run is not None:
        raise ValueError("give --pretrained or --preop-run, not both")
    if frames is not None and (pretrained or preop_run is not None):
        raise ValueError("--frames is the budget of a pre-op agent trained here; with --pretrained or --preop-run the "
                         "pre-op agent is given (--finetune-frames and --scratch-frames set the post-op budgets)")
    seeds = [count("--seeds", s, low=0) for s in seeds]
    if not seeds or len(set(seeds)) != len(seeds):
        raise ValueError(f"--seeds: give one or more distinct seeds, got {seeds}")
    if algo is not None and algo not in ALGOS:
        raise ValueError(f"unknown algorithm {algo!r}; choose from {', '.join(ALGOS)}")
    muscle_model = muscle_model or DEFAULT_MUSCLE_MODEL
    check_muscle_model(muscle_model)
    fractions = dict(fractions or {})
    bad = [k for k in fractions if k not in FRACTION_OPTIONS]
    if bad:
        raise ValueError(f"--option {bad[0]}: surgery takes only the conditions' fractions "
                         f"({', '.join(FRACTION_OPTIONS)}); the other task options are the pre-op agent's own")
    for name, value in (("--finetune-frames", finetune_frames), ("--eval-every", eval_every), ("--frames", frames)):
        if value is not None:
            count(name, value)
    if scratch_frames is not None:
        count("--scratch-frames", scratch_frames, low=0)
    tasks, conditions = list(tasks), list(conditions)
    if not tasks or not conditions:
        raise ValueError("give at least one --task and one --condition")
    for f in fractions:
        if not any(f in condition_options(check_name(t), c, fractions) for t in tasks for c in conditions):
            raise ValueError(f"--option {f} applies to none of the conditions {', '.join(conditions)}")
    scenarios = []
    for task in tasks:
        task = check_name(task)
        a = algo or DEFAULT_ALGO[task]
        check_task(task, a)
        if pretrained:
            specs = {s: shipped_agent(task, a) for s in seeds}
        elif preop_run is not None:
            specs = {s: str(preop_run_for(Path(preop_run), s)) for s in seeds}
        else:
            specs = {s: None for s in seeds}
        metas = {s: check_preop(spec, task, a, muscle_model) for s, spec in specs.items() if spec is not None}
        intact = feasibility(task, None, muscle_model)
        for condition in conditions:
            options = condition_options(task, condition, fractions)
            post = feasibility(task, options, muscle_model)
            if not post["holds_task_range"] and not allow_unreachable:
                raise ValueError(f"--condition {condition} on {task}: {feasibility_text(post, intact)}. "
                                 f"--allow-unreachable runs it anyway (the report says so)")
            scenarios.append({"task": task, "algo": a, "condition": condition, "options": options,
                              "folder": folder_name(options), "seeds": seeds, "preop_specs": specs,
                              "preop_metas": metas, "muscle_model": muscle_model,
                              "feasibility": {"intact": intact, "post_op": post}})
    for sc in scenarios:
        ref = next(iter(sc["preop_metas"].values()), None)
        if ref is not None:  # a given pre-op agent: its own training frames
            sc["preop_frames"], sc["frames"] = int(ref.get("frames") or 0), None
        else:  # trained here
            sc["preop_frames"] = sc["frames"] = int(frames or preop_budget(sc["task"], sc["algo"]))
        pre_frames = sc["preop_frames"]
        sc["finetune_frames"] = int(finetune_frames or max(1, math.ceil(GOAL_SHARE * pre_frames)))
        sc["scratch_frames"] = int(sc["finetune_frames"] if scratch_frames is None else scratch_frames)
        sc["eval_every"] = int(eval_every or max(1, math.ceil(sc["finetune_frames"] / CURVE_POINTS)))
    return scenarios


def _finetune_config(sc: dict, out: Path, config: Path | None) -> Path | None:
    """The fine-tune's algorithm config file: the user's overrides, and for DQN/BDQ the fine-tune's exploration
    (`QLEARNING_FINETUNE`, unless the user's config sets those fields), written into the scenario folder."""
    from shoulder_bench.train.config import read_overrides
    from shoulder_bench.train.plan import algo_module

    if sc["algo"] == "ppo":
        return config
    overrides = read_overrides(config, algo_module(sc["algo"])[1])
    path = out / "finetune_config.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(QLEARNING_FINETUNE | overrides, indent=2) + "\n")
    return path


def run_scenario(sc: dict, out: Path, config: Path | None = None, progress: bool = True) -> tuple[dict, dict]:
    """One scenario, every seed: (its summary, the recorded traces for the figures)."""
    from shoulder_bench.eval.evaluate import policy_for
    from shoulder_bench.eval.experiment import train
    from shoulder_bench.tasks import fixed_test_set
    from shoulder_bench.tasks import spec as task_spec

    task, algo, muscles = sc["task"], sc["algo"], task_spec(sc["task"])[0]
    base = Path(out) / task / algo
    where = base / sc["folder"]
    test = fixed_test_set(task)
    say = print if progress else (lambda *a, **k: None)
    ft_config = _finetune_config(sc, where, config)
    seeds, traces, preop_done = [], {}, {}
    for seed in sc["seeds"]:
        spec = sc["preop_specs"][seed]
        if spec is None:  # train the pre-op agent here, on the intact shoulder
            run = base / "preop" / str(seed)
            say(f"[{task} {algo} seed {seed}] pre-op: training {sc['frames']:,} frames on the intact shoulder -> {run}")
            train(task, algo, sc["frames"], seed, run, resume=True, config=config, muscle_model=sc["muscle_model"])
            spec = str(run)
        policy, meta, _ = policy_for(spec)
        base_options = dict(meta.get("options") or {})
        post_options = base_options | sc["options"]
        if spec not in preop_done:  # the pre-op agent, intact and zero-shot post-op (once per agent)
            say(f"[{task} {algo} seed {seed}] pre-op agent {spec}: test set, intact and {sc['condition']} (zero-shot)")
            pre, pre_trace = _evaluation(policy, task, test, meta, base_options)
            zero, zero_trace = _evaluation(policy, task, test, meta, post_options)
            preop_done[spec] = (pre, pre_trace, zero, zero_trace)
        pre, pre_trace, zero, zero_trace = preop_done[spec]
        record = {"seed": seed, "preop": {"agent": spec, "frames": meta.get("frames"), **pre,
                                          "shares": shares(pre_trace, muscles)},
                  "zero_shot": {**zero, "accuracy": accuracy(pre["mae_deg"], zero["mae_deg"]),
                                "shares": shares(zero_trace, muscles)}}
        traces[seed] = {"preop": pre_trace, "zero_shot": zero_trace}
        kinds = [("finetune", sc["finetune_frames"], spec, ft_config)]
        if sc["scratch_frames"]:
            kinds.append(("scratch", sc["scratch_frames"], None, config))
        for kind, frames, init, cfg in kinds:
            run = where / kind / str(seed)
            say(f"[{task} {algo} seed {seed}] {kind}: {frames:,} frames post-op ({sc['condition']}) -> {run}")
            m = train(task, algo, frames, seed, run, resume=True, config=cfg, muscle_model=sc["muscle_model"],
                      eval_every=sc["eval_every"], options=post_options, init_from=init)
            p, pmeta, _ = policy_for(str(run))
            final, trace = _evaluation(p, task, test, pmeta, post_options)
            start = {"frames": 0, "training_s": 0.0, **zero} if kind == "finetune" else None
            points = curve(m.get("evaluations") or [], pre["mae_deg"], start)
            record[kind] = {"run": str(run), "frames": m["frames"], "wall_s": m["wall_s"], **final,
                            "accuracy": accuracy(pre["mae_deg"], final["mae_deg"]), "curve": points,
                            "recovery": recovery(points), "to_accuracy": m.get("to_accuracy"),
                            "shares": shares(trace, muscles)}
            traces[seed][kind] = trace
        seeds.append(record)
    return summarise(sc, seeds), traces


def summarise(sc: dict, seeds: list[dict]) -> dict:
    """The scenario's summary: its setting, the per-seed records and their means ± std over seeds."""
    from shoulder_bench.conditions import factors
    from shoulder_bench.tasks import spec

    muscles = spec(sc["task"])[0]
    removed = [m for m, f in factors(sc["options"]["condition"], muscles,
                                     **{k: sc["options"][k] for k in FRACTION_OPTIONS if k in sc["options"]}).items()
               if f == 0.0]
    agg = {}
    for kind in ("preop", "zero_shot", "finetune", "scratch"):
        rows = [s[kind] for s in seeds if kind in s]
        if not rows:
            continue
        agg[kind] = {"mae_deg": _mean_std(r["mae_deg"] for r in rows),
                     "accuracy": _mean_std(r.get("accuracy", 1.0) for r in rows),
                     "shares": {m: _mean_std(r["shares"]["all"][m] for r in rows) for m in muscles},
                     "crashes": sum(r["crashes"] for r in rows)}
        if "coordinate_mae_deg" in rows[0]:  # the 3-DOF tasks: each coordinate's MAE
            agg[kind]["coordinate_mae_deg"] = {c: _mean_std(r["coordinate_mae_deg"][c] for r in rows)
                                               for c in rows[0]["coordinate_mae_deg"]}
        if kind in ("finetune", "scratch"):
            rec = [r["recovery"] for r in rows]
            agg[kind]["reached"] = f"{sum(r['reached'] for r in rec)}/{len(rec)}"
            agg[kind]["frames_to_recovery"] = _mean_std(r["frames"] for r in rec if r["reached"])
            agg[kind]["training_s_to_recovery"] = _mean_std(r["training_s"] for r in rec if r["reached"])
            agg[kind]["best_accuracy"] = _mean_std(r["best_accuracy"] for r in rec)
    shift = {m: _mean_std(s["finetune"]["shares"]["all"][m] - s["preop"]["shares"]["all"][m] for s in seeds)
             for m in muscles} if all("finetune" in s for s in seeds) else {}
    goal = sc["preop_frames"] * GOAL_SHARE

    def ran(kind: str, asked: int) -> int:  # the budget as run (rounded up to whole iterations)
        return max((s[kind]["frames"] for s in seeds if kind in s), default=asked)

    hits = [s["finetune"]["recovery"] for s in seeds if "finetune" in s]
    return {"task": sc["task"], "algo": sc["algo"], "condition": sc["condition"], "options": sc["options"],
            "muscles": list(muscles), "removed_muscles": removed, "muscle_model": sc["muscle_model"],
            "preop_source": sorted(set(s["preop"]["agent"] for s in seeds)),
            "preop_frames": sc["preop_frames"], "finetune_frames": ran("finetune", sc["finetune_frames"]),
            "scratch_frames": ran("scratch", sc["scratch_frames"]), "eval_every": sc["eval_every"],
            "frames_asked": {"finetune": sc["finetune_frames"], "scratch": sc["scratch_frames"]},
            "feasibility": sc["feasibility"], "feasibility_text": feasibility_text(sc["feasibility"]["post_op"],
                                                                                   sc["feasibility"]["intact"]),
            "goal": {"recovery_accuracy": RECOVERY, "within_frames": goal,
                     "met": f"{sum(bool(h['reached'] and h['frames'] <= goal) for h in hits)}/{len(hits)}"},
            "seeds": seeds, "mean": agg, "share_shift_finetune_minus_preop": shift}


def surgery(tasks, conditions, algo=None, seeds=(0,), frames=None, finetune_frames=None, scratch_frames=None,
            pretrained=False, preop_run=None, out: Path | str = "runs/surgery", config=None, muscle_model=None,
            fractions=None, allow_unreachable=False, eval_every=None, progress: bool = True) -> dict:
    """The experiment for every task x condition; writes summary.json, report.md, figures/ and
    leaderboard_section.md in `out` and returns the summary."""
    from shoulder_bench.eval import surgery_report
    from shoulder_bench.eval.plots import checked_dir

    if isinstance(tasks, str):
        tasks = [tasks]
    if isinstance(conditions, str):
        conditions = [conditions]
    out = checked_dir(out, "--out")
    if config is not None and not Path(config).is_file():
        raise FileNotFoundError(f"--config {config}: no such file")
    scenarios = plan(tasks, conditions, algo, seeds, frames, finetune_frames, scratch_frames, pretrained, preop_run,
                     muscle_model, fractions, allow_unreachable, eval_every)
    results, traces = [], []
    for sc in scenarios:
        summary, tr = run_scenario(sc, out, config, progress)
        results.append(summary)
        traces.append(tr)
    tables = [tables_provenance(f, sc["muscle_model"]) for sc in scenarios
              for f in table_folders(sc["task"], sc["condition"])]
    summary = {"definition": ACCURACY_DEFINITION, "tables": [t for k, t in enumerate(tables) if t not in tables[:k]],
               "scenarios": results}
    paths = surgery_report.write(summary, traces, out)
    if progress:
        for r in results:
            print(surgery_report.one_line(r))
        print("wrote " + ", ".join(str(p) for p in paths))
    return summary


ACCURACY_DEFINITION = (f"accuracy = MAE_pre / MAE on the task's fixed test set (100 trajectories; on the 3-DOF tasks "
                       f"the MAE of the humerus orientation), MAE_pre the pre-op agent's "
                       f"MAE on the intact shoulder; recovered = the first evaluation with accuracy >= {RECOVERY:g} "
                       f"(MAE <= MAE_pre / {RECOVERY:g}); the goal: within {GOAL_SHARE:.0%} of the pre-op agent's "
                       f"training frames")
