"""Evaluate a policy on target trajectories: MAE and RMSE in degrees, per trajectory and overall, and crashes.

All trajectories run as one batch (`make_vec` with one target per copy). A crash ends that trajectory; its remaining
frames count with the crash error of 180 deg, so a policy can never look better by crashing.
"""
from __future__ import annotations

import time
import zipfile
from pathlib import Path

import numpy as np
import torch

from shoulder_bench import protocol
from shoulder_bench.trajectory import Trajectory, load_csv, load_test_set

CSV_COLUMNS = "time_s,angle_deg[,trajectory]"
TRAJECTORY_SETS = f"test (the fixed 100), combing (synthetic) or a CSV file with columns {CSV_COLUMNS}"


def check_csv(path: Path | str, option: str = "--trajectories", valid: str = TRAJECTORY_SETS) -> Path:
    """`path` as a trajectory CSV, checked before any work: an existing file, not a folder."""
    path = Path(path)
    if path.is_dir():
        raise ValueError(f"{option} {path} is a directory; give a CSV file with columns {CSV_COLUMNS}")
    if not path.exists():
        raise FileNotFoundError(f"{option} {path}: no such trajectory file; give {valid}")
    return path


def trajectories_for(spec: str, option: str = "--trajectories", task: str | None = None) -> list:
    """"test" (the fixed 100), "combing" (synthetic, when shipped) or a CSV path; for a 3-DOF `task` the 3-DOF test
    set, an ADL name (`trajectory3.ADL`) or a 3-DOF CSV file (time_s, plane_deg, elevation_deg, rotation_deg)."""
    from shoulder_bench.tasks import is_3dof

    if task is not None and is_3dof(task):
        from shoulder_bench import trajectory3

        if spec == "test":
            return trajectory3.load_test_set()
        if spec in trajectory3.ADL:
            return [trajectory3.ADL[spec]()]
        path = Path(spec)
        if path.is_dir() or not path.exists():
            raise FileNotFoundError(f"{option} {spec}: give test, one of {', '.join(trajectory3.ADL)} or a CSV file "
                                    f"with columns time_s,{','.join(trajectory3.COLUMNS)}")
        return trajectory3.load_csv(path)
    if spec == "test":
        return load_test_set()
    if spec == "combing":
        from shoulder_bench.trajectory import combing

        return [combing()]
    return load_csv(check_csv(spec, option))


def run_config(run: Path | str) -> dict:
    """A training run's config.json (task, algo, seed, frames, muscle_model, config[, options, model_version]),
    checked: a clear error naming the folder and what is missing or wrong."""
    import json

    run = Path(run)
    if not run.is_dir():
        raise FileNotFoundError(f"run folder {run} does not exist" if not run.exists() else
                                f"{run} is not a run folder (runs/<task>/<algo>/<seed>/)")
    path = run / "config.json"
    if not path.is_file():
        raise FileNotFoundError(f"run folder {run} has no config.json: not a shoulder-bench run")
    try:
        cfg = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ValueError(f"{path} is unreadable or not valid JSON ({exc})") from None
    missing = [k for k in ("task", "algo", "seed") if not isinstance(cfg, dict) or k not in cfg]
    if missing:
        raise ValueError(f"{path} lacks {', '.join(missing)}: not a config.json written by shoulder-bench train")
    return cfg


def check_policy_file(spec: str) -> Path:
    """The file behind a policy spec, checked to be an exported (TorchScript) policy rather than, say, a training
    checkpoint or some other file; the loader still checks its contents."""
    from shoulder_bench.train.policy import resolve

    folder = Path(spec)
    if folder.is_dir() and not (folder / "policy.pt").exists() and (folder / "checkpoint.pt").exists():
        raise FileNotFoundError(f"run folder {folder} has no policy.pt yet, only a training checkpoint: the run has "
                                f"not finished (shoulder-bench train --resume --out {folder} ... continues it)")
    path = resolve(spec)
    fix = "give a run folder, its policy.pt, pretrained:NAME or reference"
    try:
        with zipfile.ZipFile(path) as z:
            names = z.namelist()
    except (zipfile.BadZipFile, OSError):
        raise ValueError(f"policy file {path} is not a policy (not a TorchScript file written by shoulder-bench "
                         f"train); {fix}") from None
    if not any(n.endswith("/constants.pkl") for n in names):
        what = "a training checkpoint" if any(n.endswith("/data.pkl") for n in names) else "not a TorchScript policy"
        raise ValueError(f"policy file {path} is {what}, not an exported policy (shoulder-bench train writes that as "
                         f"policy.pt when the run finishes); {fix}")
    return path


CONDITION_OPTIONS = ("condition", "tear_fraction", "weakness_fraction")  # what the reference controller plans with


def law_options(options: dict | None) -> dict:
    """The task options of a 3-DOF run that decide its muscles' forces: the law's (`track3d.LAW_OPTIONS`: line of
    action, tendon) and the shoulder condition; what the reference controller plans with and the board's torques are
    computed with."""
    from shoulder_bench.tasks.track3d import LAW_OPTIONS

    return {k: v for k, v in (options or {}).items() if k in LAW_OPTIONS + CONDITION_OPTIONS}


def policy_for(spec: str, task: str | None = None, options: dict | None = None) -> tuple[object, dict, str]:
    """(policy, metadata, task) for a policy file, run folder, `pretrained:NAME` or `reference` (the model-based
    controller, on `task`, default abduction_4m, planning with the shoulder condition of the task `options`, if any).
    A trained policy runs on the task it was trained on."""
    from shoulder_bench.tasks import check_name

    if spec == "reference":
        from shoulder_bench.eval.reference import ReferenceController
        from shoulder_bench.tasks import is_3dof

        task = check_name(task or "abduction_4m")
        if is_3dof(task):
            from shoulder_bench.eval.reference3 import ReferenceController3

            # it plans with the muscles' law (line of action, tendon) and the condition the task simulates
            return ReferenceController3(task, **law_options(options)), {"task": task, "algo": "reference"}, task
        cond = {k: v for k, v in (options or {}).items() if k in CONDITION_OPTIONS}
        return ReferenceController(task, **cond), {"task": task, "algo": "reference"}, task
    from shoulder_bench.train.policy import load_policy

    check_policy_file(spec)
    policy, meta = load_policy(spec)
    if task is not None and check_name(task) != meta.get("task"):
        raise ValueError(f"policy {spec} was trained on {meta.get('task')!r}, not {task!r}; pass --task "
                         f"{meta.get('task')} or leave --task out")
    return policy, meta, check_name(meta["task"])


def evaluate(policy, task: str, trajectories: list[Trajectory], muscle_model: str | None = None,
             record: bool = False, options: dict | None = None, seed: int = 0) -> dict:
    """Roll out `policy` (float32 obs -> actions) greedily on every trajectory; return the metrics (the tracking
    error: |angle - target| on the 1-DOF tasks, the humerus orientation error on the 3-DOF ones).

    record=True adds "trace": angle_deg, target_deg (B, T) and activation (B, T, n) after each frame, NaN after a
    trajectory's end or crash; on the 3-DOF tasks angle_deg and target_deg are (B, T, 3) (plane, elevation,
    rotation) and "error_deg" (B, T) is the orientation error the score is made of. options: further task options
    (alpha, init, ...), as the policy was trained with.
    Trajectory k runs as a copy seeded seed + k: its draws (randomize, obs_noise_deg) are fixed by the seed."""
    import shoulder_bench

    options = dict(options or {}) | ({} if muscle_model is None else {"muscle_model": muscle_model})
    venv = shoulder_bench.make_vec(task, len(trajectories), seed=seed, trajectory=list(trajectories), **options)
    from shoulder_bench.tasks import is_3dof

    n = len(trajectories)
    frames = venv.episode_frames.copy()
    err = np.full((n, int(frames.max())), np.nan)
    per_coordinate = is_3dof(task)  # the 3-DOF tasks: also each coordinate's error
    coord = np.full((n, int(frames.max()), 3), np.nan) if per_coordinate else None
    crashed = np.zeros(n, dtype=bool)
    active = np.ones(n, dtype=bool)
    obs = venv.observation_tensor()  # not rsl-rl's TensorDict: evaluation imports no tensordict (Lockstep)
    if record:
        coords = err.shape + (3,) if per_coordinate else err.shape
        trace = {"angle_deg": np.full(coords, np.nan), "target_deg": np.full(coords, np.nan),
                 "activation": np.full(err.shape + (venv.n,), np.nan)}
        if per_coordinate:
            trace["error_deg"] = np.full(err.shape, np.nan)
    with torch.inference_mode():
        for k in range(int(frames.max())):
            action = policy(obs)
            _, done, _ = venv.advance(action)
            obs = venv.observation_tensor()
            e = venv.last_error_deg
            now_crashed = active & venv.last_crashed
            err[active & ~now_crashed, k] = e[active & ~now_crashed]
            if per_coordinate:
                coord[active & ~now_crashed, k] = venv.last_coordinate_error_deg[active & ~now_crashed]
            if record:
                live = active & ~now_crashed
                trace["angle_deg"][live, k] = venv.last_angle_deg[live]
                trace["target_deg"][live, k] = venv.last_target_deg[live]
                trace["activation"][live, k] = venv.last_activation[live]
                if per_coordinate:
                    trace["error_deg"][live, k] = e[live]
            for i in np.flatnonzero(now_crashed):
                err[i, k:frames[i]] = protocol.CRASH_ERROR_DEG
            crashed |= now_crashed
            active &= ~done
            if not active.any():
                break
    venv.close()
    per_mae = np.array([np.nanmean(err[i, :frames[i]]) for i in range(n)])
    per_rmse = np.array([np.sqrt(np.nanmean(err[i, :frames[i]] ** 2)) for i in range(n)])
    flat = np.concatenate([err[i, :frames[i]] for i in range(n)])
    out = {"mae_deg": float(np.mean(flat)), "rmse_deg": float(np.sqrt(np.mean(flat ** 2))),
           "n_trajectories": n, "crashes": int(crashed.sum()), "frames": int(frames.sum()),
           "per_trajectory": {"mae_deg": per_mae.round(4).tolist(), "rmse_deg": per_rmse.round(4).tolist(),
                              "crashed": crashed.tolist()}}
    if per_coordinate:  # crashed frames excluded (the orientation MAE carries the crash penalty)
        from shoulder_bench.full_arm import COORDINATE_LABELS, COORDINATES

        out["coordinate_mae_deg"] = {COORDINATE_LABELS[c]: float(np.nanmean(coord[..., k]))
                                     for k, c in enumerate(COORDINATES)}
    if record:
        out["trace"] = trace
    return out


def inference_latency_ms(policy, obs_dim: int, repeats: int = 2000) -> float:
    """Mean time (ms) of one policy call at batch 1 on this CPU, after a warm-up."""
    x = torch.zeros(1, obs_dim)
    with torch.inference_mode():
        for _ in range(50):
            policy(x)
        t = time.perf_counter()
        for _ in range(repeats):
            policy(x)
    return (time.perf_counter() - t) / repeats * 1000
