"""The paper's control protocol, written once in array form: actions, observation and reward.

Used by the dm_control task, the gymnasium adapter and the batched environment alike.
"""
from __future__ import annotations

import numpy as np

FRAME_S = 0.1
ACTION_LIMIT = 0.01  # max change of activation per frame (1 %)
LEVELS = 21  # discrete actions: -1, -0.9, ..., +1 %
DEFAULT_ALPHA = 0.1  # reward per percent-point of activation change (the paper leaves alpha open)
DEFAULT_OMEGA_MAX = 0.009  # |omega| above this counts as a "bang-bang" extreme (the paper leaves it open)
MAX_ALPHA = 1e6  # the largest alpha accepted: with REWARD_ACTION_CAP it keeps every reward finite
REWARD_ACTION_CAP = 1.0  # the reward sees |omega| up to the whole activation range: finite for any finite action
VALID_MARGIN_DEG = 5.0  # the arm beyond the joint limits by more than this = the simulation has failed (a crash)
CRASH_ERROR_DEG = 180.0  # a crash costs 180 deg for every frame left: never better than tracking badly
OBSERVATION_KEYS = ("angle", "angular_velocity", "target_angle", "target_velocity", "activations")


def level_to_delta(index) -> np.ndarray:
    """Discrete level 0..20 -> change of activation -0.01..+0.01."""
    return -ACTION_LIMIT + np.asarray(index, dtype=float) * (2 * ACTION_LIMIT / (LEVELS - 1))


def reward(angle_deg, target_deg, sent, alpha: float, omega_max: float, tracking_only: bool) -> np.ndarray:
    """Equation (1) of the paper, per batch row: -|phi - phi_hat| - alpha sum|omega| (in %) - mean 1{|omega| > max}.

    `sent` is the action the agent sent (before clipping to +-ACTION_LIMIT), shape (B, n); the penalty sees it capped
    at +-REWARD_ACTION_CAP (a change of the whole activation range), so a finite action gives a finite reward.
    """
    r = -np.abs(np.atleast_1d(angle_deg) - np.atleast_1d(target_deg)).astype(float)
    if tracking_only:
        return r
    mag = np.minimum(np.abs(np.atleast_2d(sent)), REWARD_ACTION_CAP)
    return r - alpha * 100.0 * mag.sum(axis=1) - np.count_nonzero(mag > omega_max, axis=1) / mag.shape[1]


def observation(angle_deg, velocity_deg_s, target_deg, target_velocity_deg_s, activations) -> dict[str, np.ndarray]:
    """The state of the paper: phi(t), phi'(t), phi_hat(t+1), phi_hat'(t+1), Omega(t). Rows are batch entries."""
    col = lambda x: np.asarray(x, dtype=float).reshape(-1, 1)  # noqa: E731
    return {"angle": col(angle_deg), "angular_velocity": col(velocity_deg_s), "target_angle": col(target_deg),
            "target_velocity": col(target_velocity_deg_s),
            "activations": np.atleast_2d(np.asarray(activations, dtype=float))}


def flatten(observation: dict) -> np.ndarray:
    """One observation dict (a dm_control time step's) as a flat float32 vector in OBSERVATION_KEYS order: what the
    gymnasium env returns and what policies take."""
    return np.concatenate([np.ravel(observation[k]) for k in OBSERVATION_KEYS]).astype(np.float32)


def to_delta(action, n: int, discrete: bool, batch: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(applied, sent) changes of activation, each (B, n), from actions; ValueError for a wrong shape or NaN/inf.

    Continuous: finite values outside +-ACTION_LIMIT are clipped (`sent` keeps them for the reward). Discrete: integer
    levels 0..LEVELS-1. `batch=None` means a single action of shape (n,) (or () for one discrete muscle).
    """
    a = np.asarray(action)
    rows = 1 if batch is None else batch
    single_shapes = ((n,), (1, n)) + (((), (1,)) if discrete and n == 1 else ())
    ok_shape = a.shape in single_shapes if batch is None else a.shape in ((batch, n),) + (((batch,),) if n == 1 else ())
    where = "" if batch is None else f" for {batch} environments"
    if discrete:
        expected = f"{'an integer' if n == 1 else f'{n} integers'} in 0..{LEVELS - 1} per environment"
        if not ok_shape or not np.issubdtype(a.dtype, np.number):
            raise ValueError(f"action of shape {a.shape}: expected {expected}{where}")
        flat = a.reshape(rows, n).astype(float)
        if not np.all(np.isfinite(flat)) or np.any(flat != np.round(flat)) or np.any((flat < 0) | (flat >= LEVELS)):
            raise ValueError(f"action {np.asarray(action).tolist()}: expected {expected} (0..{LEVELS - 1})")
        d = level_to_delta(flat.astype(np.int64))
        return d, d
    if not ok_shape or not np.issubdtype(a.dtype, np.number):
        raise ValueError(f"action of shape {a.shape}: expected shape ({n},){where}, one change of activation per "
                         f"muscle within +-{ACTION_LIMIT}")
    sent = a.reshape(rows, n).astype(float)
    if not np.all(np.isfinite(sent)):
        raise ValueError(f"action {np.asarray(action).tolist()} is not finite: expected {n} numbers within "
                         f"+-{ACTION_LIMIT} (finite values outside are clipped)")
    return np.clip(sent, -ACTION_LIMIT, ACTION_LIMIT), sent
