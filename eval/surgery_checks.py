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
    """What the muscles of `task` can hold under the condition of `options` (None: intact). 1-DOF tasks: the static
    reach from hanging (`statics.reach_on_grid`, as the condition report gives it), the angles of the task's test range
    (the test split's 20-100 deg) at which they cannot hold the arm still, and whether they hold all of it. 3-DOF
    tasks (`feasibility3`): the poses of the task's test box they cannot hold."""
    from shoulder_bench import statics
    from shoulder_bench.arm import RANGE_DEG, arm_for
    from shoulder_bench.tasks import is_3dof, spec
    from shoulder_bench.trajectory import SPLITS

    cond = {k: v for k, v in (options or {}).items() if k in ("condition", *FRACTION_OPTIONS)}
    if is_3dof(task):
        return feasibility3(task, cond, muscle_model)
    law = arm_for(cond.get("condition")).load_law(muscle_model, spec(task)[0], **cond)  # ld_transfer: its geometry
    deg = np.round(np.arange(0.0, RANGE_DEG[1], 0.1), 1)
    q = np.radians(deg)
    cap, grav = statics.static_capacity(law, q), statics.gravity_torque(q)
    lo, hi = SPLITS["test"]["range_deg"]
    held = cap >= -grav
    inside = (deg >= lo - 1e-9) & (deg <= hi + 1e-9)
    return {"static_reach_deg": statics.reach_on_grid(deg, cap, grav, RANGE_DEG[1]),
            "not_held_deg": intervals(deg, ~held), "not_held_in_range_deg": intervals(deg[inside], ~held[inside]),
            "task_range_deg": [lo, hi], "holds_task_range": bool(held[inside].all())}


GRID3_DEG = 10.0  # the 3-DOF test box's grid (benchmarks/workspace_3dof.py's)


def target_poses(task: str) -> tuple[np.ndarray, list]:
    """(poses (P, 3) deg, their box [[lo, hi]] per coordinate) of a 3-DOF task's test targets: track_3dof's test
    box (`trajectory3.SPLITS`) on a GRID3_DEG grid; the scapular-plane task's elevations (the 1-DOF test range, 1 deg
    steps) in the scapular plane at rotation 0."""
    import itertools

    from shoulder_bench import trajectory, trajectory3
    from shoulder_bench.tasks import TASKS_3DOF
    from shoulder_bench.tasks.track3d import SCAPULAR_PLANE_DEG

    if TASKS_3DOF[task][2].get("workspace") == "scapular_plane":
        lo, hi = trajectory.SPLITS["test"]["range_deg"]
        box = [[SCAPULAR_PLANE_DEG] * 2, [lo, hi], [0.0, 0.0]]
        steps = [np.array([SCAPULAR_PLANE_DEG]), np.arange(lo, hi + 0.5), np.array([0.0])]
    else:
        box = [list(r) for r in trajectory3.SPLITS["test"]["range_deg"]]
        steps = [np.arange(a, b + GRID3_DEG / 2, GRID3_DEG) for a, b in box]
    return np.array(list(itertools.product(*steps)), dtype=float), box


def feasibility3(task: str, cond: dict, muscle_model: str) -> dict:
    """The poses of a 3-DOF task's test box (`target_poses`) the muscles cannot hold still against gravity under the
    condition `cond` (static optimisation, `statics_full.Statics.held`)."""
    from shoulder_bench.statics_full import Statics
    from shoulder_bench.tasks import spec
    from shoulder_bench.tasks.track3d import condition_law

    poses, box = target_poses(task)
    held, _ = Statics(*condition_law(muscles=spec(task)[0], muscle_model=muscle_model, **cond)).held(poses)
    return {"task_range_deg": box, "grid_step_deg": GRID3_DEG, "poses": len(poses), "held": int(held.sum()),
            "not_held_poses_deg": poses[~held].round(1).tolist(), "holds_task_range": bool(held.all())}


def statics_label(f: dict) -> str:
    """A feasibility in a few words (the leaderboard's column): the static reach (1-DOF) or the test-box poses held."""
    if "poses" in f:
        return f"{f['held']}/{f['poses']} test-box poses held"
    return "none" if f["static_reach_deg"] is None else f"{f['static_reach_deg']:.1f} deg"


def feasibility_text(f: dict, intact: dict | None = None) -> str:
    if "poses" in f:
        return feasibility3_text(f, intact)
    lo, hi = f["task_range_deg"]
    reach = statics_label(f)
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


def feasibility3_text(f: dict, intact: dict | None = None) -> str:
    box = ", ".join(f"{c} {a:g}" + (f"-{b:g}" if b != a else "")
                    for c, (a, b) in zip(("plane", "elevation", "rotation"), f["task_range_deg"]))
    how = (f"{box} deg, {f['grid_step_deg']:g} deg grid; static optimisation, statics_full.Statics.held")
    if f["holds_task_range"]:
        return f"the post-op muscles hold the arm still at all {f['poses']} poses of the task's test box ({how})"
    shown = ", ".join("(" + ", ".join(f"{x:g}" for x in p) + ")" for p in f["not_held_poses_deg"][:6])
    more = f" and {len(f['not_held_poses_deg']) - 6} more" if len(f["not_held_poses_deg"]) > 6 else ""
    text = (f"the post-op muscles cannot hold the arm still at {f['poses'] - f['held']} of the {f['poses']} poses of "
            f"the task's test box ({how}; not held, plane/elevation/rotation deg: {shown}{more}): the post-op "
            f"shoulder cannot physically follow every test target")
    if intact is not None and not intact["holds_task_range"]:
        text += f" (nor can the intact one: it holds {intact['held']}/{intact['poses']})"
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


def table_folders(task: str, condition: str | None = None) -> list[Path]:
    """The force tables' folders `task` runs on under `condition`: the 1-DOF arm's or the full shoulder's, and a
    rerouting condition's own (ld_transfer's)."""
    from shoulder_bench import arm, conditions, full_arm
    from shoulder_bench.tasks import is_3dof

    geometries = full_arm.GEOMETRIES if is_3dof(task) else arm.GEOMETRIES
    geometry = conditions.geometry(condition)
    return [full_arm.TABLE_FOLDER if is_3dof(task) else arm.TABLE_FOLDER] + (
        [] if geometry is None else [geometries[geometry]["tables"]])


def tables_provenance(folder: Path, muscle_model: str) -> dict:
    """Which force tables in `folder` an experiment ran on: the folder, the SHA-256 of their files together, the git
    commit that last changed them and HEAD, and whether the working tree differs from HEAD there (None outside
    git)."""
    folder = Path(folder).resolve()
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
