"""The task options, checked in one place: every error names the option and the values it accepts.

Used by `shoulder_bench.load` (and so gymnasium), the dm_control task and the batched environment alike.
"""
from __future__ import annotations

import difflib
import math
import numbers

import numpy as np

# the options of `shoulder_bench.load` / `gymnasium.make` / `make_vec`, with what each accepts
OPTIONS = {
    "split": "'train' or 'test'",
    "seed": "None or an integer",
    "trajectory": "None, a CSV path, an array of degrees per frame or a Trajectory",
    "muscle_model": "'fem' or 'hill'",
    "alpha": "a finite number in [0, 1e6]",
    "omega_max": "a finite number >= 0",
    "tracking_only": "None (the task's default), True or False",
    "init": "'hold' or 'zero'",
    "joint_damping": "a finite number in [0, 10] (N m s/rad on the elevation joint; 0 is the model's)",
    "delay_frames": "an integer in [0, 10] (frames by which the observed angle, velocity and activations are late)",
    "obs_noise_deg": "a finite number >= 0 (Gaussian sigma: deg on the observed angle, deg/s on its velocity)",
}


def plain(value) -> str:
    """`value` as a user typed it: numpy scalars print as plain numbers (nan, not np.float64(nan))."""
    if isinstance(value, np.generic):
        value = value.item()
    return repr(value)


def check_names(given, valid=OPTIONS) -> None:
    """ValueError for option names that are not options, with the closest valid one."""
    unknown = [k for k in given if k not in valid]
    if unknown:
        close = difflib.get_close_matches(str(unknown[0]), valid, n=1)
        hint = f" Did you mean {close[0]!r}?" if close else ""
        raise ValueError(f"unknown option(s) {unknown}.{hint} Valid options: {', '.join(valid)}")


def choice(name: str, value, choices) -> str:
    """`value` if it is one of the strings `choices`, else a ValueError naming the option and the choices."""
    if not isinstance(value, str) or value not in choices:
        raise ValueError(f"{name} must be one of {', '.join(map(repr, choices))}; got {plain(value)}")
    return value


def number(name: str, value, lo: float = 0.0, hi: float = math.inf) -> float:
    """`value` as a float if it is a real number (not a bool), finite and within [lo, hi]."""
    ok = isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_))
    if not ok or not math.isfinite(float(value)) or not lo <= float(value) <= hi:
        wanted = f"a finite number >= {lo:g}" if hi == math.inf else f"a finite number in [{lo:g}, {hi:g}]"
        raise ValueError(f"{name} must be {wanted}; got {plain(value)}")
    return float(value)


def integer(name: str, value, lo: int, hi: int) -> int:
    """`value` as an int if it is an integer (Python's or numpy's, not a bool, not a float) within [lo, hi]."""
    ok = isinstance(value, numbers.Integral) and not isinstance(value, (bool, np.bool_))
    if not ok or not lo <= int(value) <= hi:
        raise ValueError(f"{name} must be an integer in [{lo}, {hi}]; got {plain(value)}")
    return int(value)


def flag(name: str, value, allow_none: bool = True) -> bool | None:
    """A real bool (numpy's too), or None where that means the default; 'no', 0 or 1 are refused."""
    if value is None and allow_none:
        return None
    if not isinstance(value, (bool, np.bool_)):
        wanted = "None, True or False" if allow_none else "True or False"
        raise ValueError(f"{name} must be {wanted}; got {plain(value)}")
    return bool(value)


def seed(value) -> int | None:
    """None or an integer (Python's or numpy's, not a bool) for the episode draws."""
    if value is None:
        return None
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral):
        raise ValueError(f"seed must be None or an integer (e.g. seed=0); got {plain(value)}")
    if int(value) < 0:
        raise ValueError(f"seed must be None or an integer >= 0; got {plain(value)}")
    return int(value)
