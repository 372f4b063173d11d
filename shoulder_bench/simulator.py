"""N shoulders stepped in lockstep, with the muscle law evaluated for the whole batch at every RK4 stage.

MuJoCo integrates the model with RK4 (docs/physics.md), calling the muscle callback at each of the four stages of a
step. Done copy by copy that would mean Python per copy per stage. Here the RK4 stages are formed for the whole batch in
numpy, the force law is evaluated for the whole batch (one compiled kernel call), and MuJoCo supplies the accelerations:
one `mujoco.rollout` call (threads, GIL released) advances every copy by one explicit Euler step with the muscle forces
as fixed-gain controls, and the acceleration is read back from the velocity change. The arithmetic is that of MuJoCo's
`mj_RungeKutta`, so a batched episode reproduces a single-env episode (callback path) to rounding error.
"""
from __future__ import annotations

import mujoco
import numpy as np
from mujoco import rollout

from shoulder_bench.model import JOINT, MODEL_PATH, compile_model

RK4_A = ((0.5,), (0.0, 0.5), (0.0, 0.0, 1.0))  # MuJoCo's RK4 tableau
RK4_B = (1 / 6, 1 / 3, 1 / 3, 1 / 6)
MAX_ACCELERATION = 1e10  # MuJoCo's mjMAXVAL for qacc


class BatchSimulator:
    """The muscle-driven arm for a batch: angle q (rad), velocity v (rad/s), activations (N, n) of `law`'s muscles."""

    def __init__(self, law, num: int, nthread: int = 2, path=MODEL_PATH):
        m = compile_model(path)
        self.h = float(m.opt.timestep)
        if m.opt.integrator != mujoco.mjtIntegrator.mjINT_RK4:
            raise ValueError(f"{path}: the batched simulator reproduces RK4; the model uses {m.opt.integrator}")
        names = [m.actuator(i).name for i in range(m.nu)]
        self.columns = np.array([names.index(x) for x in law.muscles])  # actuator of each law column
        # the acceleration oracle: muscle forces as plain controls, one explicit Euler step (damping explicit too)
        m.actuator_gaintype[:] = mujoco.mjtGain.mjGAIN_FIXED
        m.actuator_gainprm[:] = 0.0
        m.actuator_gainprm[:, 0] = 1.0
        m.actuator_biastype[:] = mujoco.mjtBias.mjBIAS_NONE
        m.actuator_ctrllimited[:] = 0
        m.opt.integrator = mujoco.mjtIntegrator.mjINT_EULER
        m.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_EULERDAMP
        self.model, self.law, self.num = m, law, num
        self.steps_per_frame = int(round(0.1 / self.h))
        spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
        nstate = mujoco.mj_stateSize(m, spec)
        jnt = m.joint(JOINT)
        d = mujoco.MjData(m)
        probe = np.zeros(nstate)
        d.qpos[jnt.qposadr[0]], d.qvel[jnt.dofadr[0]] = 7.0, 11.0
        mujoco.mj_getState(m, d, probe, spec)
        self._iq, self._iv = int(np.flatnonzero(probe == 7.0)[0]), int(np.flatnonzero(probe == 11.0)[0])
        mujoco.mj_resetData(m, d)
        base = np.zeros(nstate)
        mujoco.mj_getState(m, d, base, spec)
        self._state = np.tile(base, (num, 1))
        self._ctrl = np.zeros((num, 1, m.nu))
        self._out = np.zeros((num, 1, nstate))
        self._sens = np.zeros((num, 1, m.nsensordata))
        self._datas = [mujoco.MjData(m) for _ in range(nthread)]
        self._models = [m] * num  # skip_checks=True wants one entry per copy
        self._rollout = rollout.Rollout(nthread=nthread)

    def close(self) -> None:
        self._rollout.close()

    def acceleration(self, q: np.ndarray, v: np.ndarray, act: np.ndarray) -> np.ndarray:
        """Joint acceleration (N,) at states (q, v) with the muscle forces of activations `act`.

        Where MuJoCo finds the acceleration unstable it resets that copy; the velocity change is then meaningless and
        `self.bad` flags the copy (the single env sees the same event as a MuJoCo warning: a crash)."""
        self._ctrl[:, 0, self.columns] = -self.law.force(q, v, act)  # muscles pull
        self._state[:, self._iq] = q
        self._state[:, self._iv] = v
        self._rollout.rollout(self._models, self._datas, self._state, self._ctrl, nstep=1, skip_checks=True,
                              state=self._out, sensordata=self._sens)
        acc = (self._out[:, 0, self._iv] - v) / self.h
        self.bad |= ~np.isfinite(acc) | (np.abs(acc) > MAX_ACCELERATION)
        return acc

    def step(self, q: np.ndarray, v: np.ndarray, act: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """One RK4 step of every copy, with MuJoCo's tableau and summation order."""
        h = self.h
        fq, fv = [v], [self.acceleration(q, v, act)]
        for row in RK4_A:
            dq, dv = np.zeros_like(q), np.zeros_like(v)
            for a, kq, kv in zip(row, fq, fv):
                dq += kq * a
                dv += kv * a
            qi, vi = q + dq * h, v + dv * h
            fq.append(vi)
            fv.append(self.acceleration(qi, vi, act))
        dq, dv = np.zeros_like(q), np.zeros_like(v)
        for b, kq, kv in zip(RK4_B, fq, fv):
            dq += kq * b
            dv += kv * b
        return q + dq * h, v + dv * h

    def frame(self, q: np.ndarray, v: np.ndarray, act: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Advance every copy by one 0.1 s frame at constant activations: (q, v, failed)."""
        self.bad = np.zeros(len(q), dtype=bool)
        for _ in range(self.steps_per_frame):
            q, v = self.step(q, v, act)
        return q, v, self.bad
