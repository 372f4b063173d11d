"""What defines a training run, checked before any work: the algorithm, the task it fits, the frame budget, the
config; and whether a run folder already holds that run, finished."""
from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np

ALGOS = ("ppo", "dqn", "bdq")
DEFAULT_FRAMES = {"ppo": 1_600_000, "dqn": 200_000, "bdq": 500_000}


def algo_module(algo: str):
    """(the algorithm's module, its config class)."""
    if algo == "ppo":
        from shoulder_bench.train import ppo

        return ppo, ppo.PPOConfig
    from shoulder_bench.train import dqn

    return dqn, dqn.DQNConfig


def check_task(task: str, algo: str) -> None:
    """ValueError unless `algo` can learn `task` (PPO: continuous; DQN: discrete, one muscle; BDQ: discrete)."""
    from shoulder_bench.tasks import list_tasks, spec

    muscles, discrete = spec(task)
    want = {"ppo": "a continuous task", "dqn": "a discrete single-muscle task", "bdq": "a discrete task"}[algo]
    fits = {"ppo": lambda m, d: not d, "dqn": lambda m, d: d and len(m) == 1, "bdq": lambda m, d: d}[algo]
    if not fits(muscles, discrete):
        valid = [n for n in list_tasks() if fits(*spec(n))]
        raise ValueError(f"--algo {algo} needs {want}; {task} is not. Valid: {', '.join(valid)}")


def count(name: str, value, low: int = 1) -> int:
    """`value` as an int >= `low`; ValueError naming `name` otherwise."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
        raise ValueError(f"{name} must be an integer >= {low}, got {value!r}")
    return int(value)


def plan(task: str, algo: str, frames: int | None = None, seed: int = 0, overrides: dict | None = None,
         muscle_model: str | None = None, source: str = "config", options: dict | None = None):
    """Check everything that defines a run, before any work: (algorithm module, its config, the run's config.json).
    options: task options of the run (`shoulder-bench tasks --options`; part of its identity), checked here.

    The budget is rounded up to whole iterations (PPO: num_envs x steps_per_env frames; DQN/BDQ: num_envs)."""
    from shoulder_bench.arm import MODEL_VERSION
    from shoulder_bench.model import DEFAULT_MUSCLE_MODEL
    from shoulder_bench.muscle import check_muscle_model
    from shoulder_bench.train.config import build

    if algo not in ALGOS:
        raise ValueError(f"unknown algorithm {algo!r}; choose from {', '.join(ALGOS)}")
    check_task(task, algo)
    asked = count("--frames", DEFAULT_FRAMES[algo] if frames is None else frames)
    seed = count("--seed", seed, low=0)
    muscle_model = muscle_model or DEFAULT_MUSCLE_MODEL
    check_muscle_model(muscle_model)
    from shoulder_bench.tasks import check_options
    from shoulder_bench.tasks.options import COMMAND_LINE

    options = dict(options or {})
    not_here = [k for k in options if k not in COMMAND_LINE]
    if not_here:
        raise ValueError(f"task option(s) {not_here} cannot be set for a run; it takes {', '.join(COMMAND_LINE)}")
    check_options(task, **options)
    module, cls = algo_module(algo)
    overrides = dict(overrides or {})
    if algo == "ppo":
        cfg = build(cls, module.LIMITS, base=module.config_for(task), overrides=overrides, source=source)
    else:
        for key in ("seed", "frames"):
            if key in overrides:
                raise ValueError(f"{source}: set {key} with --{key}, not in the config")
        cfg = build(cls, module.LIMITS, base=module.config_for(task), overrides=overrides, source=source)
    per = module.frames_per_iteration(cfg)
    budget = -(-asked // per) * per
    if algo != "ppo":
        cfg = dataclasses.replace(cfg, seed=seed, frames=budget)
    config = {"task": task, "algo": algo, "seed": seed, "frames": budget, "frames_asked": asked,
              "frames_per_iteration": per, "muscle_model": muscle_model,
              "options": dict(sorted(options.items())),
              "model_version": MODEL_VERSION, "config": dataclasses.asdict(cfg)}
    return module, cfg, config


def finished_metrics(out: Path, config: dict) -> dict | None:
    """metrics.json of the finished run in `out` if it is the run `config` defines, with at least its frames."""
    from shoulder_bench.train.run import check_same_run, identity_of

    try:
        metrics = json.loads((Path(out) / "metrics.json").read_text())
        recorded = json.loads((Path(out) / "config.json").read_text())
    except (OSError, json.JSONDecodeError):
        return None
    if not (Path(out) / "policy.pt").exists() or metrics.get("frames", 0) < config["frames"]:
        return None
    if identity_of(recorded) != identity_of(config):
        check_same_run(recorded, config, Path(out))  # names the field
    return metrics


def init_source(spec: str, task: str, algo: str, muscle_model: str) -> tuple[dict, dict]:
    """What a fine-tune starts from, checked before any work: (the record its identity keeps as `init_from`, the
    state to load). `spec` is an exported policy (policy.pt, a run folder, `pretrained:NAME`) of the same task,
    algorithm and muscle model. From a finished run folder whose checkpoint.pt holds the policy's state (same frame
    count), the algorithm's whole state is loaded (PPO: actor with its action std, critic, optimiser; DQN/BDQ: online
    and target networks, optimiser; not the replay buffer or the counters); otherwise the policy's network alone
    (PPO: the actor and its observation normaliser, which the critic's normaliser also starts from; the action std is
    the config's init_std and the critic is new; DQN/BDQ: the Q-network, as online and target network, with its
    normaliser fitted). The fine-tune's frames count from 0; the record names the source and its SHA-256."""
    import hashlib

    from shoulder_bench.train.policy import load_policy, resolve

    path = resolve(spec)
    policy, meta = load_policy(spec)
    for key, want in (("task", task), ("algo", algo), ("muscle_model", muscle_model)):
        if meta.get(key) != want:
            raise ValueError(f"--init-from {spec}: a policy of {key} {meta.get(key)!r}; a fine-tune of this run needs "
                             f"one of {key} {want!r}")
    record = {"from": str(spec), "sha256": hashlib.sha256(path.read_bytes()).hexdigest(), "frames": meta.get("frames"),
              "options": meta.get("options") or {}, "loads": "policy"}
    state = {"policy": {k: v.detach().clone() for k, v in policy.state_dict().items()}}
    ckpt_path = Path(spec) / "checkpoint.pt" if Path(spec).is_dir() else path.with_name("checkpoint.pt")
    if ckpt_path.is_file():
        from shoulder_bench.train.run import load_checkpoint

        ckpt = load_checkpoint(ckpt_path.parent)
        if ckpt["frames"] == meta.get("frames") and ckpt["config"].get("algo") == algo:
            record.update(loads="checkpoint", checkpoint_sha256=hashlib.sha256(ckpt_path.read_bytes()).hexdigest())
            state["checkpoint"] = ckpt["state"]
    return record, state
