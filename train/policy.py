"""Policy files: a TorchScript module mapping float32 observations (B, 4 + n) to actions, plus JSON metadata.

Continuous policies output changes of activation (B, n) within +-0.01; discrete ones output levels 0..20 (B, n).
The metadata (task, algorithm, muscle model, metrics reached) travels inside the file (`_extra_files`).
"""
from __future__ import annotations

import json
import os
from importlib.resources import files
from pathlib import Path

import torch

META = "meta.json"


class ScaledPolicy(torch.nn.Module):
    """Wraps an actor whose outputs live in [-1, 1]: action = scale * clamp(actor(obs), -1, 1)."""

    def __init__(self, actor: torch.nn.Module, scale: float):
        super().__init__()
        self.actor = actor
        self.scale = scale

    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        return self.scale * torch.clamp(self.actor(obs), -1.0, 1.0)


def save_policy(module: torch.nn.Module, path: Path | str, meta: dict) -> Path:
    """Script (or keep, if already scripted) and save atomically with metadata."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    scripted = module if isinstance(module, torch.jit.ScriptModule) else torch.jit.script(module.cpu().eval())
    tmp = path.with_suffix(path.suffix + ".tmp")
    torch.jit.save(scripted, str(tmp), _extra_files={META: json.dumps(meta)})
    os.replace(tmp, path)
    return path


def pretrained_dir() -> Path:
    return Path(str(files("shoulder_bench.train") / "pretrained"))


def resolve(spec: str) -> Path:
    """A policy path, or `pretrained:NAME` for an agent shipped in the package."""
    if spec.startswith("pretrained:"):
        name = spec.split(":", 1)[1]
        path = pretrained_dir() / f"{name}.pt"
        if not path.exists():
            have = sorted(p.stem for p in pretrained_dir().glob("*.pt"))
            raise ValueError(f"no pretrained agent {name!r}; shipped: {', '.join(have) or 'none'}")
        return path
    path = Path(spec)
    if path.is_dir():  # a run folder
        path = path / "policy.pt"
    if not path.exists():
        raise FileNotFoundError(f"policy file {path} does not exist (give a policy.pt, a run folder or "
                                f"pretrained:NAME)")
    return path


def load_policy(spec: str) -> tuple[torch.jit.ScriptModule, dict]:
    """(module, metadata) from a path or `pretrained:NAME`; a corrupt file raises ValueError naming it."""
    path = resolve(spec)
    extra = {META: ""}
    try:
        module = torch.jit.load(str(path), map_location="cpu", _extra_files=extra)
        meta = json.loads(extra[META] or "{}")
    except Exception as exc:
        raise ValueError(f"policy file {path} is not a shoulder_bench policy or is corrupt ({exc})") from exc
    if "task" not in meta:
        raise ValueError(f"policy file {path} has no task metadata; export it with shoulder_bench.train.policy")
    return module.eval(), meta
