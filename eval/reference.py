"""The reference controller (no learning): computed torque plus feedback, distributed over the muscles by static
optimisation, under the agents' constraints.

Each frame: the desired joint acceleration is the target's, corrected by PD feedback on the next-frame target,
  alpha = kv (phi_hat'(t+1) - phi'(t)) + kp (phi_hat(t+1) - phi(t))     (per 0.1 s frame, in rad/s^2)
the inverse dynamics of the MuJoCo model gives the muscle torque that produces it,
  tau = M(phi) alpha + b phi' - tau_gravity(phi)   (M: the reduced inertia along the girdle coupling, from MuJoCo;
                                                    b: the reduced joint damping)
and `statics.distribute` finds the activations with minimum sum of squares that produce tau at rest, within
[a(t) - 0.01, a(t) + 0.01] and [0, 1]: the same limits the agents have. The action is the change of activation.
It is a model-based baseline on the leaderboard and a check that the model is controllable.
"""
from __future__ import annotations

import numpy as np
import torch

from shoulder_bench import protocol, statics
from shoulder_bench.arm import arm_for
from shoulder_bench.model import DEFAULT_MUSCLE_MODEL
from shoulder_bench.tasks import TASKS, check_name


class ReferenceController:
    """policy(obs (B, 4 + n) float32 tensor) -> changes of activation (B, n), for `evaluate`."""

    def __init__(self, task: str, muscle_model: str = DEFAULT_MUSCLE_MODEL, kp: float = 60.0, kv: float = 14.0,
                 joint_damping: float | None = None, condition: str | None = None, **fractions):
        """condition, fractions (tear_fraction, weakness_fraction): the task options' shoulder condition
        (`shoulder_bench.conditions`): the controller plans with the same conditioned law the task simulates."""
        muscles, discrete, _ = TASKS[check_name(task)]
        if discrete:
            raise ValueError(f"the reference controller acts continuously; use {task.replace('_discrete', '')}")
        self.arm = arm_for(condition)  # the condition's geometry (ld_transfer: its model and tables)
        self.law = self.arm.load_law(muscle_model, muscles, condition, **fractions)
        # reduced along the coupling (linear couplings: constant); joint_damping: the task option's, if set
        self.damping = self.arm.damping() if joint_damping is None else float(joint_damping)
        self.kp, self.kv = kp, kv
        self.muscle_model = muscle_model

    def __call__(self, obs: torch.Tensor) -> torch.Tensor:
        x = obs.detach().cpu().numpy().astype(float)
        phi, dphi, target, dtarget = (np.radians(x[:, k]) for k in range(4))
        act = x[:, 4:]
        alpha = self.kv * (dtarget - dphi) + self.kp * (target - phi)
        tau = self.arm.inertia(phi) * alpha + self.damping * dphi - statics.gravity_torque(phi)
        lo = np.clip(act - protocol.ACTION_LIMIT, 0.0, 1.0)
        hi = np.clip(act + protocol.ACTION_LIMIT, 0.0, 1.0)
        new = statics.distribute(self.law, phi, tau, upper=hi, lower=lo)
        return torch.as_tensor(new - act, dtype=torch.float32)
