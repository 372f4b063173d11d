"""A training run's folder: `runs/<task>/<algo>/<seed>/` with the resolved config, TensorBoard events, the latest
checkpoint (written atomically), the exported policy and `metrics.json`.

A run is defined by its identity (`IDENTITY`: task, algorithm, seed, muscle model, task options, model version, the
algorithm's resolved config and, for a fine-tune, the state it starts from, `init_from`: `plan.init_source`), fixed
when it starts; `--resume` refuses any change to it, naming the field, and only the frame budget may grow. One
process writes a folder at a time: `Run` holds an OS file lock on `<run>/.lock` (released by the OS when the process
ends, so a crashed run leaves no stale lock). A run that fails or is interrupted before its first checkpoint leaves
nothing behind; after it, the checkpoint stays for `--resume`, and the TensorBoard events logged past the checkpoint
are dropped when the run resumes.

Wall time: `elapsed()` is the run's wall clock since it started, summed over its attempts (a resume continues from
the checkpoint's count; the time between the kill and the resume, and each process's start-up before the folder is
opened, are not counted); it includes the test-set evaluations. `eval_s` is the part spent evaluating (added by the
caller) and `training_s()` the rest, the training wall time. Both survive a kill/resume as the checkpoint's.
"""
from __future__ import annotations

import json
import os
import shutil
import time
from collections import deque
from pathlib import Path

import numpy as np
import torch
from torch.utils.tensorboard import SummaryWriter
from tqdm import tqdm

from shoulder_bench.locks import LOCK, FolderLock  # noqa: F401 (FolderLock: where callers import it)

CHECKPOINT = "checkpoint.pt"
IDENTITY = ("task", "algo", "seed", "muscle_model", "options", "model_version", "config", "init_from")
BUDGET_FREE = ("frames",)  # algorithm config fields that are the run's budget, not its identity (DQN's `frames`)
# Config fields added after runs were recorded, per algorithm, with the value those runs had (their behaviour then): a
# run recorded without one is the same run as one asking for that value. PPO: torch threads in the update (1), rsl-rl's
# foreach Adam (fused_adam False), a fixed KL target (anneal_kl False), each rollout collected after the update before
# it (overlap_env False), a value network the policy's size (critic_hidden_dims empty); DQN and BDQ: one-step returns
# (n_step 1), the env stepped between the gradient steps (overlap_env False)
DQN_ADDED = {"n_step": 1, "overlap_env": False}
ADDED_FIELDS = {"ppo": {"update_threads": 1, "fused_adam": False, "anneal_kl": False, "overlap_env": False,
                        "critic_hidden_dims": []},
                "dqn": DQN_ADDED, "bdq": DQN_ADDED}


def with_added_fields(algo: str, config: dict) -> dict:
    """An algorithm config as recorded, completed with the `ADDED_FIELDS` it predates."""
    return ADDED_FIELDS.get(algo, {}) | config


def write_json(path: Path, obj) -> None:
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(json.dumps(obj, indent=2, default=str) + "\n")
    os.replace(tmp, path)


def identity_of(config: dict) -> dict:
    ident = {key: config.get(key) for key in IDENTITY}
    ident["options"] = ident["options"] or {}  # runs from before these fields were recorded: no options, model v1
    ident["model_version"] = ident["model_version"] or "1"
    ident["config"] = {k: v for k, v in (ident["config"] or {}).items() if k not in BUDGET_FREE}
    ident["config"] = with_added_fields(ident["algo"], ident["config"])
    return json.loads(json.dumps(ident, default=str))  # tuples as lists: what config.json holds


def check_same_run(recorded: dict, new: dict, where: Path) -> None:
    """ValueError naming the first field of the run's identity (or a shrinking budget) that differs."""
    old, now = identity_of(recorded), identity_of(new)
    for key in IDENTITY:
        if key == "config":
            for field in sorted(set(old[key]) | set(now[key])):
                if old[key].get(field) != now[key].get(field):
                    raise ValueError(f"{where} is a run with config field {field} = {old[key].get(field)!r}; this "
                                     f"command asks for {now[key].get(field)!r}. A run's definition is fixed when it "
                                     f"starts: use another --out for a new run")
        elif old[key] != now[key]:
            raise ValueError(f"{where} is a run with {key} = {old[key]!r}; this command asks for {now[key]!r}. A run's "
                             f"definition is fixed when it starts: use another --out for a new run")
    if int(new["frames"]) < int(recorded.get("frames", 0)):
        raise ValueError(f"{where} is a run with a budget of {int(recorded['frames']):,} frames; --resume may only "
                         f"keep or grow it, not shrink it to {int(new['frames']):,}")


def recorded_config(folder: Path) -> dict | None:
    """The config.json a run folder records, or None."""
    try:
        return json.loads((folder / "config.json").read_text())
    except FileNotFoundError:
        return None
    except (OSError, json.JSONDecodeError) as exc:
        raise ValueError(f"{folder / 'config.json'} is unreadable ({exc}); delete the folder to start over") from exc


def load_checkpoint(folder: Path) -> dict:
    path = folder / CHECKPOINT
    try:
        ckpt = torch.load(path, map_location="cpu", weights_only=False)
    except Exception as exc:
        raise ValueError(f"checkpoint {path} is unreadable or corrupt ({exc}); delete it to start over") from exc
    if not isinstance(ckpt, dict) or not {"frames", "config", "state"} <= set(ckpt):
        raise ValueError(f"checkpoint {path} is not a shoulder_bench checkpoint")
    return ckpt


class Run:
    """Use as a context manager: `with Run(out, config, resume) as run: ...`; the lock is held inside."""

    def __init__(self, out: Path, config: dict, resume: bool):
        self.dir = Path(out)
        self.config = config
        if self.dir.exists() and not self.dir.is_dir():
            raise ValueError(f"--out {self.dir} is a file; give a folder for the run")
        self._created = not self.dir.exists()
        self.dir.mkdir(parents=True, exist_ok=True)
        self.lock = FolderLock(self.dir)
        self._wrote = False  # config.json / tb/ written by this process
        try:
            self._open(resume)
        except BaseException:
            self._discard()
            raise

    def _open(self, resume: bool) -> None:
        has_ckpt = (self.dir / CHECKPOINT).exists()
        if (self.dir / "metrics.json").exists() and not resume:
            raise ValueError(f"{self.dir} holds a finished run; choose another --out (or delete it) to train again")
        if has_ckpt and not resume:
            raise ValueError(f"{self.dir} holds a checkpoint; pass --resume to continue it, or choose another --out")
        self.checkpoint = load_checkpoint(self.dir) if resume and has_ckpt else None
        # what the run records: its checkpoint's config (the state to continue), else config.json
        recorded = self.checkpoint["config"] if self.checkpoint else recorded_config(self.dir) if resume else None
        if recorded is not None:
            check_same_run(recorded, self.config, self.dir)
        self.fresh = self.checkpoint is None
        if self.fresh:  # no checkpoint to continue: start clean, never mixing with a killed attempt's events
            shutil.rmtree(self.dir / "tb", ignore_errors=True)
        self._wrote = True
        write_json(self.dir / "config.json", self.config)
        ckpt = self.checkpoint or {}
        self.frames = int(ckpt.get("frames", 0))
        self.wall = float(ckpt.get("wall_s", 0.0))
        self.paper_frames = ckpt.get("frames_to_paper_accuracy")
        self.eval_s = float(ckpt.get("eval_s", 0.0))  # wall time spent in test-set evaluations
        # first evaluation at or below each accuracy threshold: {"2.0": {"frames", "wall_s"} or None, ...}
        self.to_accuracy = dict(ckpt.get("to_accuracy") or {})
        # every test-set evaluation: {"frames", "training_s", "mae_deg", "rmse_deg", "crashes"} (the learning curve)
        self.evaluations = list(ckpt.get("evaluations") or ())
        # events logged after the checkpoint (steps > its frame count) belong to the lost attempt: purge them
        self.writer = SummaryWriter(str(self.dir / "tb"), purge_step=self.frames + 1 if self.frames else None)
        self._t0 = time.perf_counter() - self.wall
        self.returns = deque(ckpt.get("returns", ()), maxlen=100)
        if "np_rng" in ckpt:
            np.random.set_state(ckpt["np_rng"])
        self.bar = None
        self.env = None  # the training env, whose state (episodes, RNGs) each checkpoint carries
        self.saved = False  # a checkpoint was written by this process

    def __enter__(self) -> Run:
        return self

    def __exit__(self, kind, exc, tb) -> None:
        if self.bar is not None:
            self.bar.close()
        self.writer.close()
        if kind is not None and self.fresh and not self.saved:
            self._discard()  # failed or interrupted before anything worth resuming: leave nothing behind
        else:
            self.lock.release()

    def _discard(self) -> None:
        for name in ("config.json", "config.json.tmp", "tb") if self._wrote else ():
            path = self.dir / name
            shutil.rmtree(path, ignore_errors=True) if path.is_dir() else path.unlink(missing_ok=True)
        self.lock.release()
        if self._created:
            (self.dir / LOCK).unlink(missing_ok=True)
            try:
                self.dir.rmdir()
            except OSError:  # something else was put there meanwhile: leave it
                pass

    def save_checkpoint(self, state: dict) -> None:
        path = self.dir / CHECKPOINT
        tmp = path.with_suffix(".tmp")
        if self.env is not None:
            state = {**state, "env": self.env.state_dict()}
        torch.save({"frames": self.frames, "config": self.config, "state": state, "wall_s": self.elapsed(),
                    "frames_to_paper_accuracy": self.paper_frames, "eval_s": self.eval_s,
                    "to_accuracy": self.to_accuracy, "evaluations": self.evaluations, "returns": list(self.returns),
                    "np_rng": np.random.get_state()}, tmp)
        os.replace(tmp, path)
        self.saved = True

    def elapsed(self) -> float:
        """Wall seconds of the run so far, evaluations included (see the module's docstring)."""
        return time.perf_counter() - self._t0

    def training_s(self) -> float:
        """Wall seconds of the run so far less those spent in test-set evaluations (`eval_s`)."""
        return self.elapsed() - self.eval_s

    def start_progress(self, total: int) -> None:
        self.bar = tqdm(total=total, initial=self.frames, unit="frame", unit_scale=True, dynamic_ncols=True,
                        desc=f"{self.config['algo']} {self.config['task']}")

    def advance(self, frames: int, scalars: dict) -> None:
        """Count frames, log scalars to TensorBoard (x axis: frames) and refresh the progress bar."""
        self.frames += frames
        for key, value in scalars.items():
            if value is not None:
                self.writer.add_scalar(key, float(value), self.frames)
        if self.bar is not None:
            self.bar.update(frames)
            self._fps = scalars.get("perf/fps", getattr(self, "_fps", 0.0))
            post = {"fps": f"{self._fps:,.0f}"}
            if self.returns:
                post["reward"] = f"{sum(self.returns) / len(self.returns):.1f}"
            self.bar.set_postfix(post)

    def finish(self, metrics: dict) -> dict:
        metrics = {**metrics, "frames": self.frames, "wall_s": round(self.elapsed(), 2),
                   "eval_s": round(self.eval_s, 2), "frames_to_paper_accuracy": self.paper_frames,
                   "to_accuracy": self.to_accuracy, "evaluations": self.evaluations}
        write_json(self.dir / "metrics.json", metrics)
        return metrics
