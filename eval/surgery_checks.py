"""Checks and sources of the re-learning experiment (`eval.surgery`): the post-op task options, whether the post-op
shoulder can hold the arm over the task's test range (`feasibility`), the pre-op agent's source and budget, and the
force tables' provenance. Split from `eval/surgery.py` (one concept each: this file decides what may run)."""
from __future__ import annotations

import hashlib
import subprocess
from pathlib import Path

import numpy as np

FRACTION_OPTIONS = ("tear_fraction", "weakness_fraction")


# --- checks -----------------------------------------------------------------------------------------------------------
def condition_options(task: str, condition: str, fractions: dict | None = None) -> dict:
    """The post-op task options of `condition` on `task` ({"condition": C} and the fractions it uses), checked: an
    unknown or not-yet-available condition, or one that removes a muscle the task needs, is a ValueError."""
    from shoulder_bench.conditions import CONDITIONS, NOT_YET, names
    from shoulder_bench.tasks import check_options

    valid = f"available: {', '.join(CONDITIONS)} (compose with '+')" + ("; not available yet: " + "; ".join(
        f"{k} ({v.split(':')[0]})" for k, v in NOT_YET.items()) if NOT_YET else "")
    try:
        parts = names(condition)
    except ValueError as exc:
        raise ValueError(f"--condition {condition!r}: {exc}. {valid}") from None
    if not parts:
        raise ValueError(f"--condition: give the post-op condition; {valid}")
    used = {opt for p in parts for opt in CONDITIONS[p].scales.values()}
    options = {"condition": condition} | {k: v for k, v in (fractions or {}).items() if k in used}
    try:
        check_options(task, **options)
    except ValueError as exc:
        raise ValueError(f"--condition {condition} on {task}: {exc}") from None
    return options


def intervals(deg: np.ndarray, mask: np.ndarray) -> list[list[float]]:
    """[[first, last], ...] of the runs of True in `mask` over the grid `deg`."""
    edges = np.diff(np.concatenate([[0], np.asarray(mask, dtype=np.int8), [0]]))
    starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
    return [[round(float(deg[a]), 1), round(float(deg[b]), 1)] for a, b in zip(starts, stops)]


def feasibility(task: str, options: dict | None, muscle_model: str) -> dict:
    """What the muscles of `task` can hold under the condition of `options` (None: intact): the static reach from
    hanging (`statics.reach_on_grid`, as the condition report gives it), the angles of the task's test range (the
    test split's 20-100 deg) at which they cannot hold the arm still, and whether they hold all of it."""
    from shoulder_bench import statics
    from shoulder_bench.arm import RANGE_DEG, arm_for
    from shoulder_bench.tasks import TASKS
    from shoulder_bench.trajectory import SPLITS

    cond = {k: v for k, v in (options or {}).items() if k in ("condition", *FRACTION_OPTIONS)}
    law = arm_for(cond.get("condition")).load_law(muscle_model, TASKS[task][0], **cond)  # ld_transfer: its geometry
    deg = np.round(np.arange(0.0, RANGE_DEG[1], 0.1), 1)
    q = np.radians(deg)
    cap, grav = statics.static_capacity(law, q), statics.gravity_torque(q)
    lo, hi = SPLITS["test"]["range_deg"]
    held = cap >= -grav
    inside = (deg >= lo - 1e-9) & (deg <= hi + 1e-9)
    return {"static_reach_deg": statics.reach_on_grid(deg, cap, grav, RANGE_DEG[1]),
            "not_held_deg": intervals(deg, ~held), "not_held_in_range_deg": intervals(deg[inside], ~held[inside]),
            "task_range_deg": [lo, hi], "holds_task_range": bool(held[inside].all())}


def feasibility_text(f: dict, intact: dict | None = None) -> str:
    lo, hi = f["task_range_deg"]
    reach = "none" if f["static_reach_deg"] is None else f"{f['static_reach_deg']:.1f} deg"
    if f["holds_task_range"]:
        below = [iv for iv in f["not_held_deg"] if iv[1] < lo]
        extra = (f"; it cannot hold {', '.join(f'{a:g}-{b:g}' for a, b in below)} deg, below the range, which the "
                 f"episodes never need (they start at rest on the first target)" if below else "")
        return (f"the post-op muscles hold the arm still at every angle of the task's {lo:g}-{hi:g} deg test range "
                f"(static reach from hanging {reach}{extra})")
    where = ", ".join(f"{a:g}-{b:g}" for a, b in f["not_held_in_range_deg"])
    text = (f"the post-op muscles cannot hold the arm still at {where} deg of the task's {lo:g}-{hi:g} deg test "
            f"range (static reach from hanging {reach}; statics.static_capacity against statics.gravity_torque, "
            f"0.1 deg grid): the post-op shoulder cannot physically do the task")
    if intact is not None and not intact["holds_task_range"]:
        text += (" (nor can the intact one: it cannot hold "
                 + ", ".join(f"{a:g}-{b:g}" for a, b in intact["not_held_in_range_deg"]) + " deg)")
    return text


def shipped_agent(task: str, algo: str) -> str:
    """`pretrained:NAME` of the shipped agent of `task` and `algo` (train/pretrained/); ValueError naming those
    shipped otherwise."""
    from shoulder_bench.train.policy import load_policy, pretrained_dir

    have = []
    for p in sorted(pretrained_dir().glob("*.pt")):
        _, meta = load_policy(f"pretrained:{p.stem}")
        have.append(f"{p.stem} ({meta.get('algo')} on {meta.get('task')})")
        if meta.get("task") == task and meta.get("algo") == algo:
            return f"pretrained:{p.stem}"
    raise ValueError(f"--pretrained: no shipped agent of {algo} on {task}; shipped: {', '.join(have) or 'none'}. "
                     f"Train one pre-op (leave --pretrained out) or give --preop-run DIR")


def preop_run_for(folder: Path, seed: int) -> Path:
    """The pre-op run of `seed` in `folder`: the folder itself when it is a finished run, else `folder/<seed>`."""
    folder = Path(folder)
    if (folder / "policy.pt").is_file():
        return folder
    if (folder / str(seed) / "policy.pt").is_file():
        return folder / str(seed)
    if not folder.exists():
        raise FileNotFoundError(f"--preop-run {folder}: no such folder")
    if not folder.is_dir():
        raise ValueError(f"--preop-run {folder} is a file; give a finished run folder (policy.pt inside) or a folder "
                         f"of runs per seed (DIR/<seed>/)")
    raise FileNotFoundError(f"--preop-run {folder}: neither a finished run (policy.pt) nor a folder of runs per seed "
                            f"holding {folder / str(seed) / 'policy.pt'}")


def check_preop(spec: str, task: str, algo: str, muscle_model: str | None) -> dict:
    """The pre-op policy's metadata, checked: its task and algorithm, an intact (no condition) shoulder."""
    from shoulder_bench.eval.evaluate import check_policy_file
    from shoulder_bench.train.policy import load_policy

    check_policy_file(spec)
    _, meta = load_policy(spec)
    if meta.get("task") != task or meta.get("algo") != algo:
        raise ValueError(f"pre-op agent {spec} is {meta.get('algo')} on {meta.get('task')}, not {algo} on {task}")
    if muscle_model is not None and meta.get("muscle_model") != muscle_model:
        raise ValueError(f"pre-op agent {spec} uses the {meta.get('muscle_model')} muscle model, not {muscle_model}")
    cond = {k: v for k, v in (meta.get("options") or {}).items() if k in ("condition", *FRACTION_OPTIONS)}
    if any(v is not None for v in cond.values()):
        raise ValueError(f"pre-op agent {spec} was trained with {cond}: the pre-op agent must be trained on the intact "
                         f"shoulder (condition None)")
    return meta


def preop_budget(task: str, algo: str) -> int:
    """Frames for a pre-op agent trained here: the shipped agents' budget (`shoulder-bench reproduce`), else
    `shoulder-bench train`'s default."""
    from shoulder_bench.eval.reproduce import EXPERIMENTS
    from shoulder_bench.train.plan import DEFAULT_FRAMES

    return next((f for t, a, f, _ in EXPERIMENTS.values() if (t, a) == (task, algo)), DEFAULT_FRAMES[algo])


def folder_name(options: dict) -> str:
    """A scenario's folder: the condition and any fraction (`ssp_partial_tear,tear_fraction=0.3`)."""
    return ",".join([options["condition"]] + [f"{k}={options[k]}" for k in FRACTION_OPTIONS if k in options])


def tables_provenance(muscle_model: str) -> dict:
    """Which force tables the experiment ran on: their folder, the SHA-256 of their files together, the git commit
    that last changed them and HEAD, and whether the working tree differs from HEAD there (None outside git)."""
    from shoulder_bench.arm import TABLE_FOLDER

    folder = Path(TABLE_FOLDER).resolve()
    files = sorted(folder.glob(f"*_{muscle_model}.npz"))
    digest = hashlib.sha256(b"".join(hashlib.sha256(f.read_bytes()).digest() for f in files)).hexdigest()
    out = {"folder": folder.name, "files": [f.name for f in files], "sha256": digest,
           "commit": None, "head": None, "dirty": None}

    def git(*args) -> str | None:
        try:
            r = subprocess.run(["git", *args], cwd=folder, capture_output=True, text=True, timeout=20)
        except (OSError, subprocess.SubprocessError):
            return None
        return r.stdout.strip() if r.returncode == 0 else None

    names = [str(f) for f in files]
    out["head"] = git("rev-parse", "HEAD")
    if out["head"]:
        out["commit"] = git("log", "-1", "--format=%H", "--", *names) or None
        status = git("status", "--porcelain", "--", *names)
        out["dirty"] = None if status is None else bool(status)
    return out
