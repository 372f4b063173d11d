"""The reference controller of the 3-DOF tasks (no learning): computed torque in the three coordinates plus PD
feedback, distributed over the thirteen muscles by static optimisation, under the agents' ±1 %/frame limit.

Each frame, per copy: the desired coordinate accelerations
  alpha = kv (q_hat'(t+1) - q'(t)) + kp (q_hat(t+1) - q(t))          (rad/s^2; plane, elevation, rotation)
the reduced inverse dynamics of the MuJoCo model on the couplings,
  tau = S^T M(q) S alpha + S^T qfrc_bias(q, S q')                    (gravity and velocity terms)
and `statics_full.Statics.distribute` the activations within [a - 0.01, a + 0.01] and [0, 1] of least effort that
produce tau, the force law at the tendons' current lengths and lengthening rates: the task's law (its line of action
and shoulder condition, `tasks.track3d.condition_law`). As the 1-DOF reference (`eval.reference`): a model-based
baseline on the board and a check that the model is controllable.
"""
from __future__ import annotations

import mujoco
import numpy as np
import torch

from shoulder_bench import protocol
from shoulder_bench.statics_full import Statics
from shoulder_bench.tasks import TASKS_3DOF, check_name


class ReferenceController3:
    """policy(obs (B, 25) float32 tensor) -> changes of activation (B, 13), for `evaluate`."""

    def __init__(self, task: str, muscle_model: str = "fem", kp: float = 60.0, kv: float = 14.0,
                 line_of_action: str = "mjcf", condition: str | None = None, tear_fraction: float | None = None,
                 weakness_fraction: float | None = None, tendon: str = "rigid", **options):
        from shoulder_bench.tasks.track3d import condition_law

        muscles, discrete, _, _ = TASKS_3DOF[check_name(task)]
        if discrete:
            raise ValueError(f"the reference controller acts continuously; use {task.replace('_discrete', '')}")
        # it plans with the arms the muscles act along and the shoulder's condition, as the task simulates them
        self.law, self.pose = condition_law(condition, muscles, tear_fraction, weakness_fraction, muscle_model,
                                            line_of_action, tendon)
        self.statics = Statics(self.law, self.pose)
        self.kp, self.kv = kp, kv
        self.muscle_model = muscle_model
        self._d = mujoco.MjData(self.pose.m)

    def _plan(self, q_deg, dq, target, dtarget, act) -> np.ndarray:
        m, d, pose = self.pose.m, self._d, self.pose
        S = pose.slopes(q_deg)
        d.qpos[:] = pose.qpos(q_deg)[0]
        d.qvel[:] = S @ dq
        mujoco.mj_forward(m, d)
        full = np.zeros((m.nv, m.nv))
        mujoco.mj_fullM(m, d, full)
        alpha = self.kv * (dtarget - dq) + self.kp * (target - np.radians(q_deg))
        tau = S.T @ full @ S @ alpha + S.T @ d.qfrc_bias
        ids = [m.actuator(t).id for t in self.law.actuators]
        L, r = self.law.geometry(pose, q_deg, act)  # the arms at the present activations (band level tables)
        v = self.law.lengthening_rates(q_deg, dq, d.actuator_velocity[ids], act)[0]  # the bands' along their line
        lo = np.clip(act - protocol.ACTION_LIMIT, 0.0, 1.0)
        hi = np.clip(act + protocol.ACTION_LIMIT, 0.0, 1.0)
        fibres = self.law.departures(q_deg)  # line_of_action="band_fibres": each band's fibres at their lengths
        return self.statics.distribute(L[0], r[0], v, tau, act, lo, hi, None if fibres is None else fibres[0])

    def __call__(self, obs: torch.Tensor) -> torch.Tensor:
        x = obs.detach().cpu().numpy().astype(float)
        act = x[:, 12:]
        new = np.array([self._plan(x[b, 0:3], np.radians(x[b, 3:6]), np.radians(x[b, 6:9]), np.radians(x[b, 9:12]),
                                   act[b]) for b in range(len(x))])
        return torch.as_tensor(new - act, dtype=torch.float32)
