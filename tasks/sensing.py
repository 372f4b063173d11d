"""What the agent senses: options `delay_frames` and `obs_noise_deg`, shared by the dm_control task and the batched
environment so both compute the same observation with the same arithmetic.

- `delay_frames=k`: the observation at frame t shows the arm's state of frame max(t - k, 0), that is the elevation
  angle, its velocity and the activations (the 3-DOF tasks: the three coordinates' angles and velocities); the
  target terms stay current. A buffer of the last k + 1 states is filled with the initial state at every episode
  start.
- `obs_noise_deg=sigma`: the observed angle gets sigma * z1 degrees and the observed velocity sigma * z2 deg/s, with
  (z1, z2) two standard normals drawn per observation delivered (at the reset and at every step, after the delay),
  from a generator of its own seeded from the task's seed (`noise_rng`); rewards and `info` keep the true state. The
  3-DOF tasks draw 2 x 3 normals at once (`draw`): the three angles', then the three velocities'.

Why a frame buffer and not MuJoCo's sensor `delay`: the observation is read from qpos, qvel and ctrl, not from
MuJoCo sensors; MuJoCo's delay counts physics steps (a frame is several) and keeps its history inside mjData, which
the batched simulator does not carry between frames and checkpoints would miss. A buffer of whole frames in the task
is the same few lines in every API and goes into the VecEnv's `state_dict`.
"""
from __future__ import annotations

import numpy as np

MAX_DELAY_FRAMES = 10
NOISE_STREAM = 0x6E6F697365  # "noise": the noise draws of seed s are a stream apart from its target draws


def noise_rng(seed: int | None) -> np.random.Generator:
    """The observation noise generator of a task seeded `seed` (copy i of a batched env: seed + i)."""
    return np.random.default_rng(None if seed is None else [int(seed), NOISE_STREAM])


def state(angle_deg, velocity_deg_s, activations) -> np.ndarray:
    """(B, 2 d + n) sensed state rows: angle(s) (deg), velocity(ies) (deg/s), activations; d = 1 (angles (B,)) or the
    3-DOF tasks' 3 (angles (B, 3))."""
    act = np.atleast_2d(activations)
    return np.concatenate([np.reshape(angle_deg, (len(act), -1)), np.reshape(velocity_deg_s, (len(act), -1)), act],
                          axis=1).astype(float)


def draw(rng: np.random.Generator, dofs: int = 1) -> np.ndarray:
    """(1, 2 dofs) standard normals of one observation's noise: the angles', then the velocities'."""
    return rng.standard_normal((1, 2 * dofs))


def noisy(angle_deg, velocity_deg_s, sigma: float, z):
    """The observed angle(s) and velocity(ies): each plus sigma times its standard normal (z: (B, 2 d) from `draw`,
    or None for none)."""
    if z is None or sigma == 0.0:
        return angle_deg, velocity_deg_s
    z = np.atleast_2d(z)
    d = z.shape[1] // 2
    if d == 1:  # the 1-DOF tasks: angles (B,)
        return angle_deg + sigma * z[:, 0], velocity_deg_s + sigma * z[:, 1]
    return angle_deg + sigma * z[:, :d], velocity_deg_s + sigma * z[:, d:]
