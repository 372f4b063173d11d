"""Per-episode randomisation of the arm (issue 14 §1, option `randomize`): muscle strength, humerus mass and a hand
load, drawn at every episode start and written into the episode's MuJoCo model, the same way in the dm_control task
(its one model) and the batched simulator (one model per copy, `simulator.BatchSimulator.own_models`).

- strength: muscle k's whole force (active and passive, as `conditions` scale it) times s_k ~ U[1 - x, 1 + x], via
  the `gear` of its actuators (v2's ld: all three bundles by the one s_ld); the muscle's force law is unchanged.
- mass: the humerus' mass and its inertia about its COM times m ~ U[1 - y, 1 + y] (COM and axes unchanged).
- load: a point mass L ~ U[lo, hi] kg at the elbow, the humerus' distal end, MoBL-ARMS' elbow joint centre
  (Holzbaur et al. 2005: the ulna's origin (0.0061, -0.2904, -0.0123) m in the humerus frame, whose origin is the
  glenohumeral centre; the task model's humerus frame is MoBL's). Merged into the humerus body: mass m M0 + L, the
  combined COM, the combined inertia tensor about it (parallel axes), re-diagonalised (principal moments and
  `body_iquat`); `body_subtreemass` of the humerus and its ancestors follows.
Why the model and not an applied force: a load changes the arm's inertia as well as its gravity torque, and an
external force reproduces the inertial part only with the acceleration it would cause (not known before the step).
The reference controller and `statics.holding_activation` (init="hold") keep the nominal arm: an episode starts at
rest with the nominal holding activations, which a randomised arm does not exactly hold.

Option values: None/False (off), True (DEFAULTS), a dict {"strength": x, "mass": y, "load": L or (lo, hi)} or the
same as text "strength=0.3,mass=0.1,load=0:2" (a command line's --option randomize=...). Keys left out are not
randomised (with True, all take their defaults). Draws come from a generator of their own (`rng`), seeded from the
task's seed (copy i of a batched env: seed + i), n + 2 uniforms per episode in a fixed order.
"""
from __future__ import annotations

import math
import numbers
import re
from pathlib import Path

import mujoco
import numpy as np

DEFAULTS = {"strength": 0.3, "mass": 0.1, "load": (0.0, 2.0)}  # +-30 %, +-10 %, 0-2 kg
LIMITS = {"strength": 0.9, "mass": 0.9, "load": 10.0}  # the largest half-width (fractions) and load (kg) accepted
ELBOW_IN_HUMERUS = (0.0061, -0.2904, -0.0123)  # m, MoBL-ARMS' elbow joint centre in the humerus frame
BODY = "humerus"
STREAM = 0x72616E64  # "rand": the draws of seed s are a stream apart from its target and noise draws


def rng(seed: int | None) -> np.random.Generator:
    return np.random.default_rng(None if seed is None else [int(seed), STREAM])


def _real(key: str, v, lo: float, hi: float) -> float:
    ok = isinstance(v, numbers.Real) and not isinstance(v, (bool, np.bool_)) and math.isfinite(float(v))
    if not ok or not lo <= float(v) <= hi:
        raise ValueError(f"randomize {key} must be a number in [{lo:g}, {hi:g}]; got {v!r}")
    return float(v)


def _text(value: str) -> dict:
    out = {}
    for part in value.split(","):
        key, sep, raw = part.partition("=")
        key, raw = key.strip(), raw.strip()
        if not sep or not key or not raw:
            raise ValueError(f"randomize {value!r}: expected KEY=VALUE pairs separated by commas, e.g. "
                             "'strength=0.3,mass=0.1,load=0:2'")
        if ":" in raw:
            lo, _, hi = raw.partition(":")
            parsed = [lo, hi]
        else:
            parsed = [raw]
        try:
            nums = [float(x) for x in parsed]
        except ValueError:
            raise ValueError(f"randomize {key}: {raw!r} is not a number (or lo:hi for the load)") from None
        out[key] = nums[0] if len(nums) == 1 else tuple(nums)
    return out


def option(value) -> dict | None:
    """The checked `randomize` option: None (off) or {"strength": x, "mass": y, "load": (lo, hi)}."""
    if value is None or value is False or (isinstance(value, np.bool_) and not value):
        return None
    if value is True or (isinstance(value, np.bool_) and value):
        return dict(DEFAULTS)
    if isinstance(value, str):
        value = _text(value)
    if not isinstance(value, dict):
        raise ValueError(f"randomize must be None, False, True, a dict with keys {list(DEFAULTS)} or text like "
                         f"'strength=0.3,mass=0.1,load=0:2'; got {value!r}")
    unknown = [k for k in value if k not in DEFAULTS]
    if unknown:
        raise ValueError(f"randomize: unknown key(s) {unknown}; valid keys: {', '.join(DEFAULTS)}")
    out = {"strength": 0.0, "mass": 0.0, "load": (0.0, 0.0)}
    for key in ("strength", "mass"):
        if key in value:
            out[key] = _real(key, value[key], 0.0, LIMITS[key])
    if "load" in value:
        load = value["load"]
        pair = tuple(load) if isinstance(load, (tuple, list)) else (load, load)
        if len(pair) != 2:
            raise ValueError(f"randomize load must be a number (kg) or a pair (lo, hi); got {load!r}")
        lo, hi = (_real("load", x, 0.0, LIMITS["load"]) for x in pair)
        if lo > hi:
            raise ValueError(f"randomize load: lo {lo:g} > hi {hi:g}")
        out["load"] = (lo, hi)
    return out


def draw(generator: np.random.Generator, spec: dict, n: int) -> dict:
    """One episode's arm: {"strength": (n,), "mass_scale": float, "load_kg": float}."""
    z = generator.uniform(-1.0, 1.0, n + 1)
    w = generator.uniform(0.0, 1.0)
    lo, hi = spec["load"]
    return {"strength": 1.0 + spec["strength"] * z[:n], "mass_scale": float(1.0 + spec["mass"] * z[n]),
            "load_kg": float(lo + (hi - lo) * w)}


def groups(m: mujoco.MjModel, actuators: dict, muscles) -> list[list[int]]:
    """Each of `muscles`' actuator ids in model `m` (`actuators`: muscle -> its actuators' names; ld: three), the
    groups a strength draw scales together (`Nominal`)."""
    return [[m.actuator(a).id for a in actuators[k]] for k in muscles]


class Nominal:
    """A model's nominal values of what `apply` changes, read once (before any change)."""

    def __init__(self, m: mujoco.MjModel, actuator_groups):
        self.body = m.body(BODY).id
        self.groups = [np.asarray(g, dtype=int) for g in actuator_groups]  # actuator ids of each muscle
        self.gear = m.actuator_gear[:, 0].copy()
        self.mass = float(m.body_mass[self.body])
        self.ipos = m.body_ipos[self.body].copy()
        self.inertia = m.body_inertia[self.body].copy()
        self.iquat = m.body_iquat[self.body].copy()
        self.subtree = m.body_subtreemass.copy()
        chain, b = [], self.body
        while b > 0:
            chain.append(b)
            b = int(m.body_parentid[b])
        self.chain = np.array(chain)


def _merged(nom: Nominal, scale: float, load: float):
    """(mass, COM, principal moments, iquat) of the humerus scaled by `scale` with `load` kg at the elbow."""
    m_h = scale * nom.mass
    if load == 0.0:
        return m_h, nom.ipos.copy(), scale * nom.inertia, nom.iquat.copy()
    rot = np.zeros(9)
    mujoco.mju_quat2Mat(rot, nom.iquat)
    rot = rot.reshape(3, 3)
    elbow = np.array(ELBOW_IN_HUMERUS)
    total = m_h + load
    com = (m_h * nom.ipos + load * elbow) / total

    def shift(mass, d):
        return mass * (d @ d * np.eye(3) - np.outer(d, d))

    tensor = rot @ np.diag(scale * nom.inertia) @ rot.T + shift(m_h, nom.ipos - com) + shift(load, elbow - com)
    moments, axes = np.linalg.eigh(tensor)
    if np.linalg.det(axes) < 0:
        axes[:, 0] = -axes[:, 0]
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, axes.ravel())
    return total, com, moments, quat


def apply(m: mujoco.MjModel, nom: Nominal, arm: dict | None) -> None:
    """Write one episode's arm (`draw`; None: the nominal arm) into model `m`."""
    strength = np.ones(len(nom.groups)) if arm is None else arm["strength"]
    scale, load = (1.0, 0.0) if arm is None else (arm["mass_scale"], arm["load_kg"])
    gear = nom.gear.copy()
    for ids, s in zip(nom.groups, strength):
        gear[ids] = nom.gear[ids] * s
    m.actuator_gear[:, 0] = gear
    mass, com, moments, quat = _merged(nom, scale, load)
    b = nom.body
    m.body_mass[b], m.body_ipos[b], m.body_inertia[b], m.body_iquat[b] = mass, com, moments, quat
    m.body_subtreemass[:] = nom.subtree
    m.body_subtreemass[nom.chain] = nom.subtree[nom.chain] + (mass - nom.mass)


def physics_only_xml(path) -> str:
    """The MJCF text of `path` without its textures and materials (nothing the physics reads; every physics array of
    the compiled model is unchanged, tests/test_physiology_randomize.py): a per-copy model of the batched simulator
    then takes ~0.16 MB instead of ~0.5 MB (the task model's skybox texture is 0.34 MB)."""
    text = Path(path).read_text()
    text = re.sub(r"<texture\b[^>]*/>", "", text, flags=re.S)
    text = re.sub(r"<material\b[^>]*/>", "", text, flags=re.S)
    return re.sub(r'\smaterial="[^"]*"', "", text)
