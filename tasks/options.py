"""The task options, checked in one place: every error names the option and the values it accepts.

Used by `shoulder_bench.load` (and so gymnasium), the dm_control task and the batched environment alike.
"""
from __future__ import annotations

import ast
import difflib
import math
import numbers

import numpy as np

from shoulder_bench import protocol
from shoulder_bench.model import DEFAULT_MUSCLE_MODEL

# the options of `shoulder_bench.load` / `gymnasium.make` / `make_vec`, with what each accepts
OPTIONS = {
    "split": "'train' or 'test'",
    "seed": "None or an integer",
    "trajectory": "None, a CSV path, an array of degrees per frame or a Trajectory",
    "muscle_model": "'fem' or 'hill'",
    "alpha": "a finite number in [0, 1e6]",
    "omega_max": "a finite number >= 0",
    "tracking_only": "None (the task's default), True or False (1-DOF tasks only)",
    "init": "'hold' or 'zero'",
    "joint_damping": "a finite number in [0, 10] (N m s/rad on the elevation joint; 0 is the model's; 1-DOF tasks "
                     "only)",
    "delay_frames": "an integer in [0, 10] (frames by which the observed angle, velocity and activations are late)",
    "obs_noise_deg": "a finite number >= 0 (Gaussian sigma: deg on the observed angle, deg/s on its velocity)",
    "condition": "None (intact) or a condition of shoulder_bench.conditions (ssp_tear, ssp_partial_tear, "
                 "posterosuperior_tear, deltoid_weakness; compose with '+'); docs/surgery.md",
    "tear_fraction": "None (0.5) or a number in (0, 1): ssp_partial_tear's fraction of supraspinatus strength lost",
    "weakness_fraction": "None (0.5) or a number in (0, 1): deltoid_weakness's fraction of middle-deltoid strength "
                         "lost",
    "activation_dynamics": "False or True: the command is the neural excitation, the activation follows Thelen "
                           "2003's first-order dynamics (15 ms / 50 ms) inside the physics step",
    "randomize": "None/False, True (strength=0.3, mass=0.1, load=0:2) or a dict / text 'strength=X,mass=Y,load=LO:HI' "
                 "(per-episode muscle strength x U[1-X, 1+X] per muscle, humerus mass x U[1-Y, 1+Y], a load of "
                 "U[LO, HI] kg at the elbow; keys left out are not randomised)",
    "fatigue": "False, True or a dict of 3CC-r parameters F, R, r, LD, LR: per-muscle fatigue, the residual "
               "capacity 1 - M_F caps the activation",
    "line_of_action": "'mjcf', 'band' or 'band_fibres' (3-DOF tasks only): 'band' makes the tendons with a band "
                      "table (ssp, isp, ssc, tmi, tma, pec1-3, dpo, dan, ld1-3) act along their FEM footprint sheet's "
                      "line of action, their force read at the band's length (shoulder_bench.band_lines), the others "
                      "(dmi, cor) along their MJCF paths; 'band_fibres' the same, each band tendon's force the mean "
                      "of its band's fibres', each at its own length",
    "tendon": "'rigid' or 'compliant' (3-DOF tasks only): 'compliant' puts the MoBL-ARMS parent's compliant tendon "
              "(F0 at 3.3 % strain) in series with every FEM sheet (shoulder_bench.tendon_compliance)",
}

# each option's default, as `shoulder-bench tasks --options` shows it (None where the task decides)
DEFAULTS = {"split": "train", "seed": None, "trajectory": None, "muscle_model": DEFAULT_MUSCLE_MODEL,
            "alpha": protocol.DEFAULT_ALPHA, "omega_max": protocol.DEFAULT_OMEGA_MAX, "tracking_only": None,
            "init": "hold", "joint_damping": 0.0, "delay_frames": 0, "obs_noise_deg": 0.0, "condition": None,
            "tear_fraction": None, "weakness_fraction": None, "activation_dynamics": False, "randomize": None,
            "fatigue": False, "line_of_action": "mjcf", "tendon": "rigid"}


# the options a command line may set with --option KEY=VALUE (split, seed, trajectory and muscle model have flags of
# their own or are the command's to choose)
COMMAND_LINE = ("alpha", "omega_max", "tracking_only", "init", "joint_damping", "delay_frames", "obs_noise_deg",
                "condition", "tear_fraction", "weakness_fraction", "activation_dynamics", "randomize", "fatigue",
                "line_of_action", "tendon")


def assignments(pairs, flag: str = "--option", valid=COMMAND_LINE) -> dict:
    """{key: value} from `KEY=VALUE` strings; a value reads as a Python literal (1, 0.5, True, None), else as text
    (init=zero). Names are checked here, values by the task (`shoulder_bench.tasks.check_options`)."""
    out = {}
    for text in pairs:
        key, sep, raw = str(text).partition("=")
        key, raw = key.strip(), raw.strip()
        if not sep or not key:
            raise ValueError(f"{flag} {text!r}: expected KEY=VALUE, e.g. {flag} delay_frames=1")
        if key in OPTIONS and key not in valid:
            raise ValueError(f"{flag} {key}: not settable here; options it takes: {', '.join(valid)}")
        check_names([key], valid)
        try:
            out[key] = ast.literal_eval(raw)
        except (ValueError, SyntaxError):
            out[key] = raw
    return out


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
