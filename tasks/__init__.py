"""Tasks by name: dm_control environments of the paper's protocol, also as gymnasium ids."""
from __future__ import annotations

import difflib

from shoulder_bench.arm import MUSCLES

# name -> (muscles, discrete, one-line description)
TASKS = {
    "abduction_ssp": (("ssp",), False,
                      "supraspinatus alone, continuous change of activation (+-1 %/frame); paper's PPO-1"),
    "abduction_ssp_discrete": (("ssp",), True,
                               "supraspinatus alone, 21 levels of change (-1..+1 %); paper's DQN-1"),
    "abduction_4m": (MUSCLES, False, "ssp, isp, dmi, ld, continuous changes; paper's PPO-4 with the full reward"),
    "abduction_4m_discrete": (MUSCLES, True, "ssp, isp, dmi, ld, 21 levels each (branching DQN); full reward"),
}


def list_tasks() -> list[str]:
    return list(TASKS)


def describe(name: str) -> str:
    return TASKS[check_name(name)][2]


def check_name(name: str) -> str:
    """`name` if it is a task; KeyError listing the tasks (and the closest name) otherwise."""
    if name not in TASKS:
        close = difflib.get_close_matches(str(name), TASKS, n=1)
        hint = f" Did you mean {close[0]!r}?" if close else ""
        raise KeyError(f"unknown task {name!r}.{hint} Valid names: {', '.join(TASKS)}")
    return name


def load(name: str, split: str = "train", seed=None, trajectory=None, **options):
    """The task `name` as a dm_control Environment.

    split: "train" (10 s targets in [30, 90] deg) or "test" (20 s, [20, 100] deg); seed: the episode draws;
    trajectory: a CSV path, an array of degrees at 0.1 s, or a `Trajectory` to track instead of random targets;
    options: muscle_model ("fem"/"hill"), alpha, omega_max, tracking_only, init ("hold"/"zero"), joint_damping,
    delay_frames, obs_noise_deg (`shoulder_bench.tasks.sensing`), condition (None: intact; ssp_tear, ... composed
    with '+', `shoulder_bench.conditions`) with tear_fraction, weakness_fraction. A bad option raises
    ValueError naming it and what it accepts (`shoulder_bench.tasks.options.OPTIONS`).
    """
    from shoulder_bench.tasks import options as opt
    from shoulder_bench.tasks.abduction import make_env

    opt.check_names(options)
    muscles, discrete, _ = TASKS[check_name(name)]
    return make_env(muscles, discrete=discrete, split=split, seed=seed, trajectory=trajectory, **options)


def check_options(task: str | None = None, /, **options) -> dict:
    """`options` if every name is an option and every value one it accepts (ValueError naming it otherwise), checked
    as the tasks check them, without building a model; for `task`'s muscles if given (a condition may not remove all
    of them), else for all four."""
    from shoulder_bench.tasks import options as opt
    from shoulder_bench.tasks.abduction import Abduction

    opt.check_names(options)
    muscles = MUSCLES if task is None else TASKS[check_name(task)][0]
    Abduction(muscles, **{k: v for k, v in options.items() if k not in ("seed", "trajectory", "muscle_model")})
    return options
