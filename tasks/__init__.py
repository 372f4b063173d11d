"""Tasks by name: dm_control environments of the paper's protocol, also as gymnasium ids."""
from __future__ import annotations

import difflib

from shoulder_bench.arm import MUSCLES
from shoulder_bench.full_arm import MUSCLES as FULL_MUSCLES

# name -> (muscles, discrete, one-line description)
TASKS = {
    "abduction_ssp": (("ssp",), False,
                      "supraspinatus alone, continuous change of activation (+-1 %/frame); paper's PPO-1"),
    "abduction_ssp_discrete": (("ssp",), True,
                               "supraspinatus alone, 21 levels of change (-1..+1 %); paper's DQN-1"),
    "abduction_4m": (MUSCLES, False, "ssp, isp, dmi, ld, continuous changes; paper's PPO-4 with the full reward"),
    "abduction_4m_discrete": (MUSCLES, True, "ssp, isp, dmi, ld, 21 levels each (branching DQN); full reward"),
}
# The full shoulder's tasks (tasks/track3d.py, docs/tasks_3dof.md): name -> (muscles, discrete, options, description)
TASKS_3DOF = {
    "track_3dof": (FULL_MUSCLES, False, {}, "13 muscles, 3-DOF targets (plane, elevation, rotation), continuous "
                   "changes; reward on the humerus orientation error"),
    "track_3dof_discrete": (FULL_MUSCLES, True, {}, "13 muscles, 3-DOF targets, 21 levels each (branching DQN)"),
    "elevate_scapular_plane_12m": (FULL_MUSCLES, False, {"workspace": "scapular_plane"},
                                   "13 muscles, the paper's abduction targets in the scapular plane (30 deg) at "
                                   "rotation 0, plane and rotation held; continuous changes"),
}


def list_tasks() -> list[str]:
    return [*TASKS, *TASKS_3DOF]


def describe(name: str) -> str:
    name = check_name(name)
    return TASKS[name][2] if name in TASKS else TASKS_3DOF[name][3]


def is_3dof(name: str) -> bool:
    return check_name(name) in TASKS_3DOF


def spec(name: str) -> tuple[tuple[str, ...], bool]:
    """(muscles, discrete) of any task, 1-DOF or 3-DOF."""
    name = check_name(name)
    return tuple(TASKS[name][0] if name in TASKS else TASKS_3DOF[name][0]), \
        bool(TASKS[name][1] if name in TASKS else TASKS_3DOF[name][1])


def fixed_test_set(name: str) -> list:
    """The fixed test set of a task: the 100 1-DOF trajectories, the 100 3-DOF ones (`trajectory3`), or for the
    scapular-plane task the 1-DOF ones as elevations in the scapular plane at rotation 0 (`track3d.scapular`)."""
    from shoulder_bench.trajectory import load_test_set

    if is_3dof(name):
        from shoulder_bench.tasks.track3d import scapular
        from shoulder_bench.trajectory3 import load_test_set as load3

        if TASKS_3DOF[name][2].get("workspace") == "scapular_plane":
            return [scapular(t.angle_deg, name=t.name) for t in load_test_set()]
        return load3()
    return load_test_set()


def check_name(name: str) -> str:
    """`name` if it is a task; KeyError listing the tasks (and the closest name) otherwise."""
    if name not in TASKS and name not in TASKS_3DOF:
        close = difflib.get_close_matches(str(name), list_tasks(), n=1)
        hint = f" Did you mean {close[0]!r}?" if close else ""
        raise KeyError(f"unknown task {name!r}.{hint} Valid names: {', '.join(list_tasks())}")
    return name


def load(name: str, split: str = "train", seed=None, trajectory=None, **options):
    """The task `name` as a dm_control Environment.

    split: "train" (10 s targets in [30, 90] deg) or "test" (20 s, [20, 100] deg); seed: the episode draws;
    trajectory: a CSV path, an array of degrees at 0.1 s, or a `Trajectory` to track instead of random targets;
    options: muscle_model ("fem"/"hill"), alpha, omega_max, tracking_only, init ("hold"/"zero"), joint_damping,
    delay_frames, obs_noise_deg (`shoulder_bench.tasks.sensing`), condition (None: intact; ssp_tear, ... composed
    with '+', `shoulder_bench.conditions`) with tear_fraction, weakness_fraction. A bad option raises
    ValueError naming it and what it accepts (`shoulder_bench.tasks.options.OPTIONS`).

    The 3-DOF tasks (TASKS_3DOF, `shoulder_bench.tasks.track3d`): trajectory also an ADL name
    (`trajectory3.ADL`) or (K, 3) degrees; options alpha, omega_max, init, workspace.
    """
    from shoulder_bench.tasks import options as opt
    from shoulder_bench.tasks.abduction import make_env

    if is_3dof(name):  # the full shoulder's tasks: their own options (track3d.OPTIONS)
        from shoulder_bench.tasks import track3d

        muscles, discrete, preset, _ = TASKS_3DOF[name]
        return track3d.make_env(muscles, discrete=discrete, split=split, seed=seed, trajectory=trajectory,
                                **{**preset, **options})
    opt.check_names(options)
    muscles, discrete, _ = TASKS[check_name(name)]
    return make_env(muscles, discrete=discrete, split=split, seed=seed, trajectory=trajectory, **options)


def check_options(task: str | None = None, /, **options) -> dict:
    """`options` if every name is an option and every value one it accepts (ValueError naming it otherwise), checked
    as the tasks check them, without building a model; for `task`'s muscles if given (a condition may not remove all
    of them), else for all four."""
    from shoulder_bench.tasks import options as opt
    from shoulder_bench.tasks.abduction import Abduction

    if task is not None and is_3dof(task):
        from shoulder_bench.tasks.track3d import Track3D

        Track3D(**{**TASKS_3DOF[task][2], **{k: v for k, v in options.items() if k not in ("seed", "trajectory",
                                                                                           "muscle_model")}})
        return options
    opt.check_names(options)
    muscles = MUSCLES if task is None else TASKS[check_name(task)][0]
    Abduction(muscles, **{k: v for k, v in options.items() if k not in ("seed", "trajectory", "muscle_model")})
    return options
