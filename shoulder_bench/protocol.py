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
CRASH_ERROR_DEG = 180.0  # a crash costs 180 deg for every frame left: never better than tracking badly
OBSERVATION_KEYS = ("angle", "angular_velocity", "target_angle", "target_velocity", "activations")


def level_to_delta(index) -> np.ndarray:
    """Discrete level 0..20 -> change of activation -0.01..+0.01."""
    return -ACTION_LIMIT + np.asarray(index, dtype=float) * (2 * ACTION_LIMIT / (LEVELS - 1))


def reward(angle_deg, target_deg, sent, alpha: float, omega_max: float, tracking_only: bool) -> np.ndarray:
    """Equation (1) of the paper, per batch row: -|phi - phi_hat| - alpha sum|omega| (in %) - mean 1{|omega| > max}.

    `sent` is the action the agent sent (before clipping), shape (B, n).
    """
    r = -np.abs(np.atleast_1d(angle_deg) - np.atleast_1d(target_deg)).astype(float)
    if tracking_only:
        return r
    sent = np.atleast_2d(sent)
    return r - alpha * 100.0 * np.abs(sent).sum(axis=1) - (np.abs(sent) > omega_max).mean(axis=1)


def observation(angle_deg, velocity_deg_s, target_deg, target_velocity_deg_s, activations) -> dict[str, np.ndarray]:
    """The state of the paper: phi(t), phi'(t), phi_hat(t+1), phi_hat'(t+1), Omega(t). Rows are batch entries."""
    col = lambda x: np.asarray(x, dtype=float).reshape(-1, 1)  # noqa: E731
    return {"angle": col(angle_deg), "angular_velocity": col(velocity_deg_s), "target_angle": col(target_deg),
            "target_velocity": col(target_velocity_deg_s),
            "activations": np.atleast_2d(np.asarray(activations, dtype=float))}
