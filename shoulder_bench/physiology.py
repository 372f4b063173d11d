"""Muscle physiology options of the tasks (issue 14 §1): activation dynamics and fatigue, one implementation for the
dm_control task and the batched simulator alike (both call `frame_plan` once per frame with (1, n) or (N, n) rows).

Neither law depends on the arm's motion, so a frame's activations are known before its physics runs: `frame_plan`
returns the activation that acts during each physics step of the frame (MuJoCo's ctrl for that step, what the force
law's callbacks read), and the states at the frame's end. The physics steps stay MuJoCo's RK4 in both envs.

Activation dynamics (`activation_dynamics=True`): the command u is the neural excitation and the activation a follows
Thelen (2003, J Biomech Eng 125:70) as written by Millard et al. (2013, J Biomech Eng 135:021005) and MuJoCo's
`muscle` dyntype:
    da/dt = (u - a) / tau,  tau = TAU_ACT (0.5 + 1.5 a) if u > a,  tau = TAU_DEACT / (0.5 + 1.5 a) otherwise,
with TAU_ACT = 15 ms and TAU_DEACT = 50 ms, OpenSim's Thelen2003Muscle defaults (Thelen2003Muscle.cpp,
constructProperties; OpenSim's MuscleFirstOrderActivationDynamicModel multiplies TAU_DEACT by (0.5 + 1.5 a) instead,
and clamps a >= 0.01; here a stays in the protocol's [0, 1]). u is constant within a frame, so a is advanced by the
ODE's exact solution (`activation_after`): x = u - a obeys x e^(-c x) = x0 e^(-c x0) e^(-t / (k TAU_ACT)) while
activating (k = 0.5 + 1.5 u, c = 1.5 / k; Lambert W) and x / (k + 1.5 x) = x0 / (k + 1.5 x0) e^(-k t / TAU_DEACT)
while deactivating (x = a - u); a never crosses u. During physics step s the force sees a at the step's midpoint
(the midpoint rule for the activation's time course; the step start would delay every change by one 50 ms step).
Why not MuJoCo's own `muscle` dyntype: it integrates a inside RK4, and at the tasks' 50 ms step h / tau reaches
50 / 7.5 = 6.7, beyond RK4's stability limit of 2.79 on decaying modes; the exact update is stable at any step.

Fatigue (`fatigue=True`): the three-compartment controller model with rest recovery, 3CC-r (Xia & Frey-Law 2008,
J Biomech 41:3046; Looft, Herkert & Frey-Law 2018, J Biomech 77:16), per muscle. Fractions of the motor-unit pool:
active M_A, resting M_R, fatigued M_F (sum 1) with the target load TL = the activation the muscle is asked for:
    dM_A/dt = C - F M_A,   dM_R/dt = -C + R' M_F,   dM_F/dt = F M_A - R' M_F,
    C = LD (TL - M_A) if M_A < TL and M_R > TL - M_A;  LD M_R if M_A < TL and M_R <= TL - M_A;  LR (TL - M_A) else,
    R' = r R while the muscle rests (TL = 0), R otherwise.
LD = LR = 10 s^-1 (Xia & Frey-Law 2008). Defaults F = 0.0182 s^-1, R = 0.00168 s^-1: the shoulder's fit of
Frey-Law, Looft & Heitsman 2012 (J Biomech 45:1803), read from its abstract (docs/physiology.md says how; set F and R
with `fatigue={"F": ..., "R": ...}`) and r = 15 (Looft & Frey-Law 2020, J Biomech
106:109762: r = 15 predicted shoulder-flexion fatigue better than r = 30 or 3CC without r). The muscle can deliver at
most its residual capacity M_A + M_R = 1 - M_F (the model's predicted strength), so the activation that acts is
min(a, 1 - M_F). (M_A itself would also cap it, but LD = 10 s^-1 makes M_A trail every rise by 0.1 s: a second
activation dynamics, which is the other option's business.) Explicit Euler in FATIGUE_SUBSTEPS sub-steps per physics
step (5 ms at the tasks' 50 ms; LD dt = 0.05), C clipped so that every compartment stays in [0, 1] and M_R = 1 - M_A
- M_F exactly.
"""
from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

import numpy as np

TAU_ACT = 0.015  # s, Thelen 2003 / OpenSim Thelen2003Muscle activation_time_constant
TAU_DEACT = 0.050  # s, deactivation_time_constant
FATIGUE_SUBSTEPS = 10  # explicit Euler sub-steps of the 3CC-r model per physics step
FATIGUE_DEFAULTS = {"F": 0.0182, "R": 0.00168, "r": 15.0, "LD": 10.0, "LR": 10.0}  # s^-1 (r: a multiplier)


@dataclass(frozen=True)
class Fatigue:
    """3CC-r parameters: F, R, LD, LR in s^-1, r the rest recovery multiplier."""

    F: float = FATIGUE_DEFAULTS["F"]
    R: float = FATIGUE_DEFAULTS["R"]
    r: float = FATIGUE_DEFAULTS["r"]
    LD: float = FATIGUE_DEFAULTS["LD"]
    LR: float = FATIGUE_DEFAULTS["LR"]


def fatigue_option(value) -> Fatigue | None:
    """The `fatigue` option: False/None (off), True (the defaults) or a dict overriding some of F, R, r, LD, LR
    (finite numbers > 0, r >= 1); ValueError naming what is wrong."""
    if value is None or value is False or (isinstance(value, np.bool_) and not value):
        return None
    if value is True or (isinstance(value, np.bool_) and value):
        return Fatigue()
    if not isinstance(value, dict):
        raise ValueError(f"fatigue must be False, True or a dict of 3CC-r parameters {sorted(FATIGUE_DEFAULTS)} "
                         f"(e.g. {{'F': 0.01}}); got {value!r}")
    unknown = [k for k in value if k not in FATIGUE_DEFAULTS]
    if unknown:
        raise ValueError(f"fatigue: unknown parameter(s) {unknown}; valid: {', '.join(FATIGUE_DEFAULTS)}")
    out = {}
    for k, v in value.items():
        ok = isinstance(v, numbers.Real) and not isinstance(v, (bool, np.bool_)) and math.isfinite(float(v))
        lo = 1.0 if k == "r" else 0.0
        if not ok or float(v) < lo or (k != "r" and float(v) <= 0.0):
            raise ValueError(f"fatigue {k} must be a finite number {'>= 1' if k == 'r' else '> 0'}; got {v!r}")
        out[k] = float(v)
    return Fatigue(**out)


def activation_after(u, a, t: float) -> np.ndarray:
    """The activation t seconds after `a` at constant excitation `u` (arrays of one shape): the exact solution of
    Thelen's first-order activation dynamics."""
    u = np.clip(np.asarray(u, dtype=float), 0.0, 1.0)
    a = np.clip(np.asarray(a, dtype=float), 0.0, 1.0)
    k = 0.5 + 1.5 * u
    out = u.copy()
    up = u > a
    if up.any():  # activating: x = u - a, x e^(-c x) decays as e^(-t / (k TAU_ACT))
        x0, kk = (u - a)[up], k[up]
        c = 1.5 / kk
        arg = -c * x0 * np.exp(-c * x0 - t / (kk * TAU_ACT))
        from scipy.special import lambertw  # imported here: 0.3 s, and only activation_dynamics comes here

        out[up] = u[up] + lambertw(np.maximum(arg, -math.exp(-1.0)), 0).real / c
    down = ~up & (a > u)
    if down.any():  # deactivating: x = a - u, x / (k + 1.5 x) decays as e^(-k t / TAU_DEACT)
        x0, kk = (a - u)[down], k[down]
        g = x0 / (kk + 1.5 * x0) * np.exp(-kk * t / TAU_DEACT)
        out[down] = u[down] + g * kk / (1.0 - 1.5 * g)
    return out


def activation_rate(u, a) -> np.ndarray:
    """da/dt of Thelen's activation dynamics (the ODE `activation_after` solves; for tests and plots)."""
    u, a = np.clip(u, 0.0, 1.0), np.clip(a, 0.0, 1.0)
    tau = np.where(u > a, TAU_ACT * (0.5 + 1.5 * a), TAU_DEACT / (0.5 + 1.5 * a))
    return (u - a) / tau


def fresh_fatigue(activation) -> np.ndarray:
    """(..., 3) compartments (M_A, M_R, M_F) of rested muscles at `activation`: M_A = a, M_R = 1 - a, M_F = 0."""
    a = np.clip(np.asarray(activation, dtype=float), 0.0, 1.0)
    return np.stack([a, 1.0 - a, np.zeros_like(a)], axis=-1)


def fatigue_after(state, target, t: float, p: Fatigue, substeps: int = FATIGUE_SUBSTEPS) -> np.ndarray:
    """The compartments (..., 3) t seconds after `state` at constant target load `target` (...): 3CC-r, explicit
    Euler in `substeps` steps."""
    ma, mf = state[..., 0].copy(), state[..., 2].copy()
    tl = np.clip(np.asarray(target, dtype=float), 0.0, 1.0)
    dt = t / substeps
    rr = np.where(tl == 0.0, p.r * p.R, p.R)  # 3CC-r: faster recovery at rest
    for _ in range(substeps):
        mr = 1.0 - ma - mf
        below = ma < tl
        c = np.where(below, p.LD * np.where(mr > tl - ma, tl - ma, mr), p.LR * (tl - ma))
        # keep every compartment in [0, 1] over the step (as MyoSuite's CumulativeFatigue does)
        lo = np.maximum(-ma / dt + p.F * ma, (mr - 1.0) / dt + rr * mf)
        hi = np.minimum((1.0 - ma) / dt + p.F * ma, mr / dt + rr * mf)
        c = np.clip(c, lo, hi)
        ma, mf = ma + (c - p.F * ma) * dt, mf + (p.F * ma - rr * mf) * dt
        ma, mf = np.clip(ma, 0.0, 1.0), np.clip(mf, 0.0, 1.0 - np.clip(ma, 0.0, 1.0))
    return np.stack([ma, 1.0 - ma - mf, mf], axis=-1)


def capacity(state) -> np.ndarray:
    """The residual capacity M_A + M_R = 1 - M_F (...): the most activation a fatigued muscle delivers."""
    return 1.0 - np.asarray(state)[..., 2]


def frame_plan(command, activation, fatigue_state, steps: int, h: float, dynamics: bool, fatigue: Fatigue | None):
    """One frame of `steps` physics steps of h seconds at constant `command` (B, n) (the excitation with
    `dynamics`, else the activation itself). Returns (acting (B, steps, n): the activation the force sees in each
    step, activation (B, n) at the frame's end, fatigue state (B, n, 3) at the frame's end (None without fatigue))."""
    command = np.asarray(command, dtype=float)
    a = np.asarray(activation, dtype=float) if dynamics else command
    acting = np.empty((command.shape[0], steps, command.shape[1]))
    state = None if fatigue is None else np.asarray(fatigue_state, dtype=float)
    for s in range(steps):
        if dynamics:
            mid = activation_after(command, a, 0.5 * h)
            a = activation_after(command, mid, 0.5 * h)
        else:
            mid = command
        if state is not None:
            acting[:, s] = np.minimum(mid, capacity(state))
            state = fatigue_after(state, mid, h, fatigue)
        else:
            acting[:, s] = mid
    return acting, a, state


def frame(excitation, activation, fatigue_state, applied, steps: int, h: float, dynamics: bool,
          fatigue: Fatigue | None):
    """One frame of the physiology options for a batch (B, n), from the action's change `applied`: the command is
    the excitation (with `dynamics`) or the activation plus the change, within [0, 1]; then `frame_plan`. Returns
    (acting (B, steps, n), excitation (the command), activation, fatigue state) at the frame's end (the fatigue state
    as given without fatigue). The single envs (with B = 1) and the batched ones call it alike."""
    command = np.clip((excitation if dynamics else activation) + applied, 0.0, 1.0)
    acting, a, state = frame_plan(command, activation, fatigue_state, steps, h, dynamics, fatigue)
    return acting, command, a, fatigue_state if state is None else state
