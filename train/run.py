"""A training run's folder: `runs/<task>/<algo>/<seed>/` with the resolved config, TensorBoard events, the latest
checkpoint (written atomically), the exported policy and `metrics.json`. `--resume` continues from the checkpoint."""
from __future__ import annotations

import json
import os
import time
from collections import deque
from pathlib import Path

import torch
from torch.utils.tensorboard import SummaryWriter
from tqdm import tqdm

CHECKPOINT = "checkpoint.pt"


def write_json(path: Path, obj) -> None:
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(json.dumps(obj, indent=2, default=str) + "\n")
    os.replace(tmp, path)


class Run:
    def __init__(self, out: Path, config: dict, resume: bool):
        self.dir = Path(out)
        self.config = config
        ckpt = self.dir / CHECKPOINT
        if (self.dir / "metrics.json").exists() and not resume:
            raise ValueError(f"{self.dir} holds a finished run; choose another --out (or delete it) to train again")
        if ckpt.exists() and not resume:
            raise ValueError(f"{self.dir} holds a checkpoint; pass --resume to continue it, or choose another --out")
        self.checkpoint = self.load_checkpoint() if resume and ckpt.exists() else None
        if self.checkpoint is not None:
            saved = self.checkpoint["config"]
            for key in ("task", "algo"):
                if saved.get(key) != config.get(key):
                    raise ValueError(f"checkpoint {ckpt} is a {saved.get('algo')} run on {saved.get('task')}, not "
                                     f"{config.get('algo')} on {config.get('task')}")
        self.dir.mkdir(parents=True, exist_ok=True)
        write_json(self.dir / "config.json", config)
        self.frames = 0 if self.checkpoint is None else int(self.checkpoint["frames"])
        self.wall = 0.0 if self.checkpoint is None else float(self.checkpoint.get("wall_s", 0.0))
        self.paper_frames = None if self.checkpoint is None else self.checkpoint.get("frames_to_paper_accuracy")
        self.writer = SummaryWriter(str(self.dir / "tb"), purge_step=self.frames or None)
        self._t0 = time.perf_counter() - self.wall
        self.returns = deque(maxlen=100)
        self.bar = None

    def load_checkpoint(self) -> dict:
        path = self.dir / CHECKPOINT
        try:
            ckpt = torch.load(path, map_location="cpu", weights_only=False)
        except Exception as exc:
            raise ValueError(f"checkpoint {path} is unreadable or corrupt ({exc}); delete it to start over") from exc
        if not isinstance(ckpt, dict) or not {"frames", "config", "state"} <= set(ckpt):
            raise ValueError(f"checkpoint {path} is not a shoulder_bench checkpoint")
        return ckpt

    def save_checkpoint(self, state: dict) -> None:
        path = self.dir / CHECKPOINT
        tmp = path.with_suffix(".tmp")
        torch.save({"frames": self.frames, "config": self.config, "state": state, "wall_s": self.elapsed(),
                    "frames_to_paper_accuracy": self.paper_frames}, tmp)
        os.replace(tmp, path)

    def elapsed(self) -> float:
        return time.perf_counter() - self._t0

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
        if self.bar is not None:
            self.bar.close()
        metrics = {**metrics, "frames": self.frames, "wall_s": round(self.elapsed(), 2),
                   "frames_to_paper_accuracy": self.paper_frames}
        write_json(self.dir / "metrics.json", metrics)
        self.writer.close()
        return metrics
