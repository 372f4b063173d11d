"""Hand-written controllers: a feedback baseline used by the demo and as a sanity check of the tasks."""
from __future__ import annotations

import numpy as np

from shoulder_bench import protocol
from shoulder_bench.arm import MUSCLES

# sign of each muscle's abduction moment over the working range (ld depresses; isp is ~neutral: left idle)
ELEVATES = {"ssp": 1.0, "isp": 0.0, "dmi": 1.0, "ld": -1.0}


class Feedback:
    """PD on the next-frame target: change of activation = kp * angle error + kd * velocity error, per muscle
    signed by whether it elevates or depresses the arm, clipped to the +-1 %/frame limit."""

    def __init__(self, muscles=MUSCLES, kp: float = 0.002, kd: float = 0.0004):
        self.sign = np.array([ELEVATES[m] for m in muscles])
        self.kp, self.kd = kp, kd

    def __call__(self, obs: dict) -> np.ndarray:
        err = float(obs["target_angle"][0] - obs["angle"][0])
        derr = float(obs["target_velocity"][0] - obs["angular_velocity"][0])
        u = self.kp * err + self.kd * derr
        act = np.asarray(obs["activations"], dtype=float)
        delta = self.sign * u
        # relax an antagonist that works against the move rather than pushing it below zero
        delta = np.where((self.sign * u < 0) & (act <= 0), 0.0, delta)
        return np.clip(delta, -protocol.ACTION_LIMIT, protocol.ACTION_LIMIT)
