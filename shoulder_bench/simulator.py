"""N shoulders stepped in lockstep, with the muscle law evaluated for the whole batch at every RK4 stage.

MuJoCo integrates the model with RK4 (docs/physics.md), calling the muscle callback at each of the four stages of a
step. Done copy by copy that would mean Python per copy per stage. Here the RK4 stages are formed for the whole batch in
numpy, the force law is evaluated for the whole batch (one compiled kernel call), and MuJoCo supplies the accelerations:
one `mujoco.rollout` call (threads, GIL released) advances every copy by one explicit Euler step with the muscle forces
as fixed-gain controls, and the acceleration is read back from the velocity change. The arithmetic is that of MuJoCo's
`mj_RungeKutta`, so a batched episode reproduces a single-env episode (callback path) to rounding error.

The state is the model's whole qpos (N, nq) and qvel (N, nv): one column for v1's abduction hinge, 11 for the v2
locked variant (10 girdle hinges slaved to the elevation by joint equalities). Hinge and slide joints only, so that
qpos integrates like qvel (MuJoCo's `mj_integratePos` is then qpos + qvel h, as here); free and ball joints (quaternion
positions) are refused. The force law sees one joint's angle and velocity (`joint`).

Constraint solver warmstart: in `mj_step` all four RK4 stages of a step start the solver from `qacc_warmstart`, the
last stage's acceleration of the previous step. With the v2 couplings (equality rows active at every stage) that
choice shows: from a zero warmstart (what `rollout` does without one) the solver stops at its tolerance elsewhere and
a 2 s free fall drifts 1e-9 rad from `mj_step`; carrying the warmstart per copy, as `mj_step` does, it agrees to
rounding (1e-16). Models with equality constraints carry it by default; v1 (none) keeps the zero warmstart.

engine="mujoco" (opt-in): MuJoCo integrates with its own RK4 and evaluates the law in its callbacks, the compiled ones
(`shoulder_bench.native`, GIL-free): one `rollout(nstep=steps_per_frame)` call per frame instead of 4 per step.
Within a frame rollout carries the warmstart from step to step as `mj_step` does; it returns none, so each frame
starts from a zero warmstart: against the numpy engine 2.5e-14 rad over a 20 s episode with the law, 2e-11 rad over a
2 s free fall (the solver's tolerance; tests/test_native.py).
"""
from __future__ import annotations

import copy
from pathlib import Path

import mujoco
import numpy as np
from mujoco import rollout

from shoulder_bench.geometry import forces_as_controls
from shoulder_bench.model import DEFAULT_JOINTS, MODEL_PATH, attach_law, compile_model, install_callbacks

RK4_A = ((0.5,), (0.0, 0.5), (0.0, 0.0, 1.0))  # MuJoCo's RK4 tableau
RK4_B = (1 / 6, 1 / 3, 1 / 3, 1 / 6)
MAX_ACCELERATION = 1e10  # MuJoCo's mjMAXVAL for qacc
ENGINES = ("numpy", "mujoco")
START_TIME = 1e3  # s: every frame's rollout starts at this time (nothing depends on it), so a MuJoCo reset shows
SCALAR_JOINTS = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))


class BatchSimulator:
    """The muscle-driven arm for a batch of `num` copies.

    State: positions qpos (N, nq) and velocities qvel (N, nv) of the whole model (`frame_state`); for a one-joint
    model (v1) also the angle q (N,) and velocity v (N,) (`frame`). Activations (N, n) of `law`'s muscles; `law=None`:
    no muscle force (every actuator control 0), the passive dynamics only.

    path: an MJCF file (default v1's shoulder), or xml: MJCF text (e.g. `mobl.model_xml(locked_plane_deg=0,
    dynamics=True)`). prepare: called with the simulator's own compiled model before anything else touches it (e.g.
    `arm.harden_couplings`); it modifies the model in place. joint: the joint whose angle and velocity the law sees
    (default as `model.attach_law`: `abduction` (v1) if the model has it, else `shoulder_elv` (v2); needed only
    with a law). warmstart: carry MuJoCo's `qacc_warmstart` per copy in
    `self.warmstart` (N, nv) as `mj_step` does (default: iff the model has equality constraints); zero a copy's row
    where its episode restarts (`mj_resetData` does). engine: "numpy" (the RK4 above, default) or "mujoco" (MuJoCo's
    RK4 through the compiled callbacks, one rollout per frame; no warmstart across frames, `warmstart=True` refused).
    """

    def __init__(self, law, num: int, nthread: int = 2, path: Path | str = MODEL_PATH, *, xml: str | None = None,
                 prepare=None, joint: str | None = None, warmstart: bool | None = None, engine: str = "numpy"):
        source = "the MJCF text" if xml is not None else str(path)
        m = compile_model(path, prepare) if xml is None else compile_model(prepare=prepare, xml=xml)
        self.h = float(m.opt.timestep)
        if m.opt.integrator != mujoco.mjtIntegrator.mjINT_RK4:
            raise ValueError(f"{source}: the batched simulator reproduces RK4; the model uses {m.opt.integrator}")
        for j in range(m.njnt):
            if int(m.jnt_type[j]) not in SCALAR_JOINTS:
                kind = mujoco.mjtJoint(m.jnt_type[j]).name.removeprefix("mjJNT_").lower()
                raise ValueError(f"{source}: joint {m.joint(j).name or j!r} is a {kind} joint; the batched simulator "
                                 "integrates qpos like qvel and supports hinge and slide joints only")
        if m.nq != m.nv:  # cannot happen with scalar joints only; the RK4 below relies on it
            raise ValueError(f"{source}: nq = {m.nq} != nv = {m.nv}")
        self.nq = self.nv = m.nq
        names = [m.actuator(i).name for i in range(m.nu)]
        if law is None:
            self.columns = np.zeros(0, dtype=np.int64)
        else:
            missing = [x for x in law.actuators if x not in names]
            if missing:
                raise ValueError(f"{source}: no actuator(s) {missing} for the law's muscles; the model has {names}")
            self.columns = np.array([names.index(x) for x in law.actuators])  # actuator of each law column
        joints = [m.joint(j).name for j in range(m.njnt)]
        # a length-keyed law (tendon_law.TendonLaw, the full shoulder's) reads each tendon's length inside MuJoCo's
        # callbacks: no joint, and only the "mujoco" engine (the numpy RK4 evaluates the law outside MuJoCo)
        by_length = law is not None and getattr(law, "kind", "joint") == "length"
        if by_length and (joint is not None or engine != "mujoco"):
            raise ValueError(f"{source}: a length-keyed law takes no joint and runs on engine='mujoco' only")
        if joint is None and not by_length:  # as model.attach_law: v1's abduction, else v2's shoulder_elv
            joint = next((j for j in DEFAULT_JOINTS if j in joints), None)
        if joint is not None and joint not in joints:
            raise ValueError(f"{source}: no joint {joint!r}; the model has {joints}")
        if law is not None and joint is None and not by_length:
            raise ValueError(f"{source}: the law needs a joint angle; name the joint (joint=...), one of {joints}")
        self.joint = joint
        if engine not in ENGINES:
            raise ValueError(f"engine must be one of {ENGINES}, got {engine!r}")
        self.engine = engine
        # column of the law's angle in qpos / qvel (None without a joint)
        self.qadr = None if joint is None else int(m.joint(joint).qposadr[0])
        self.dadr = None if joint is None else int(m.joint(joint).dofadr[0])
        if engine == "mujoco":  # MuJoCo's RK4 through the compiled callbacks (shoulder_bench.native)
            if law is not None:
                attach_law(m, law, joint)
            install_callbacks(native=True)
            if warmstart:
                raise ValueError("engine='mujoco' cannot carry the warmstart across frames (rollout returns none); "
                                 "within a frame MuJoCo carries it, and each frame starts from zero")
            warmstart = False
            self.model, self.law, self.num = m, law, num
            self.steps_per_frame = int(round(0.1 / self.h))
            self._setup_state(m, num, nthread, warmstart, self.steps_per_frame)
            return
        # the acceleration oracle: muscle forces as plain controls, one explicit Euler step (damping explicit too)
        forces_as_controls(m)
        m.opt.integrator = mujoco.mjtIntegrator.mjINT_EULER
        m.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_EULERDAMP
        self.model, self.law, self.num = m, law, num
        self.steps_per_frame = int(round(0.1 / self.h))
        self._setup_state(m, num, nthread, warmstart, 1)

    def _setup_state(self, m, num: int, nthread: int, warmstart, nstep: int) -> None:
        spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
        nstate = mujoco.mj_stateSize(m, spec)
        d = mujoco.MjData(m)
        probe = np.zeros(nstate)
        # markers: where qpos and qvel sit in the state vector (each contiguous there)
        d.qpos[:], d.qvel[:], d.time = 1e6 + np.arange(m.nq), 2e6 + np.arange(m.nv), 3e6
        mujoco.mj_getState(m, d, probe, spec)
        iq, iv = int(np.flatnonzero(probe == 1e6)[0]), int(np.flatnonzero(probe == 2e6)[0])
        self._it = int(np.flatnonzero(probe == 3e6)[0])
        assert (probe[iq:iq + m.nq] == d.qpos).all() and (probe[iv:iv + m.nv] == d.qvel).all()
        self._iq, self._iv = slice(iq, iq + m.nq), slice(iv, iv + m.nv)
        mujoco.mj_resetData(m, d)
        base = np.zeros(nstate)
        mujoco.mj_getState(m, d, base, spec)
        self._state = np.tile(base, (num, 1))
        self._state[:, self._it] = START_TIME
        self._ctrl = np.zeros((num, nstep, m.nu))
        self._out = np.zeros((num, nstep, nstate))
        self._sens = np.zeros((num, nstep, m.nsensordata))
        self.carry_warmstart = bool(m.neq) if warmstart is None else bool(warmstart)
        self.warmstart = np.zeros((num, m.nv)) if self.carry_warmstart else None
        self._datas = [mujoco.MjData(m) for _ in range(nthread)]
        self._models = [m] * num  # skip_checks=True wants one entry per copy
        self._rollout = rollout.Rollout(nthread=nthread)

    def close(self) -> None:
        self._rollout.close()

    def own_models(self) -> list:
        """One model per copy (copies of `self.model`, made on the first call), for parameters that differ between
        copies (`shoulder_bench.randomization`); every later frame steps copy i with model i."""
        if not self.__dict__.get("_own"):
            self._models = [copy.copy(self.model) for _ in range(self.num)]
            self._own = True
        return self._models

    def acceleration(self, qpos: np.ndarray, qvel: np.ndarray, act) -> np.ndarray:
        """Joint accelerations (N, nv) at states (qpos, qvel) with the muscle forces of activations `act`.

        Where MuJoCo finds the acceleration unstable it resets that copy; the velocity change is then meaningless and
        `self.bad` flags the copy (the single env sees the same event as a MuJoCo warning: a crash)."""
        if self.law is not None:
            self._ctrl[:, 0, self.columns] = -self.law.force(qpos[:, self.qadr], qvel[:, self.dadr], act)  # pull
        self._state[:, self._iq] = qpos
        self._state[:, self._iv] = qvel
        self._rollout.rollout(self._models, self._datas, self._state, self._ctrl, nstep=1, skip_checks=True,
                              initial_warmstart=self.warmstart, state=self._out, sensordata=self._sens)
        acc = (self._out[:, 0, self._iv] - qvel) / self.h
        self.bad |= (~np.isfinite(acc) | (np.abs(acc) > MAX_ACCELERATION)).any(axis=1)
        return acc

    def step(self, qpos: np.ndarray, qvel: np.ndarray, act) -> tuple[np.ndarray, np.ndarray]:
        """One RK4 step of every copy, with MuJoCo's tableau and summation order (hinges: qpos integrates like
        qvel)."""
        h = self.h
        fq, fv = [qvel], [self.acceleration(qpos, qvel, act)]
        for row in RK4_A:
            dq, dv = np.zeros_like(qpos), np.zeros_like(qvel)
            for a, kq, kv in zip(row, fq, fv):
                dq += kq * a
                dv += kv * a
            qi, vi = qpos + dq * h, qvel + dv * h
            fq.append(vi)
            fv.append(self.acceleration(qi, vi, act))
        if self.carry_warmstart:  # mj_step's next warmstart: this step's last-stage acceleration
            self.warmstart[:] = fv[-1]
            self.warmstart[~np.isfinite(fv[-1]).all(axis=1)] = 0.0  # a copy MuJoCo reset (flagged bad)
        dq, dv = np.zeros_like(qpos), np.zeros_like(qvel)
        for b, kq, kv in zip(RK4_B, fq, fv):
            dq += kq * b
            dv += kv * b
        return qpos + dq * h, qvel + dv * h

    def frame_state(self, qpos: np.ndarray, qvel: np.ndarray, act=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Advance every copy by one 0.1 s frame: (qpos (N, nq), qvel (N, nv), failed (N,)). `act`: activations
        (N, n) constant over the frame, or (N, steps_per_frame, n), one row per physics step
        (`shoulder_bench.physiology.frame_plan`); ignored without a law."""
        qpos = np.asarray(qpos, dtype=np.float64)
        qvel = np.asarray(qvel, dtype=np.float64)
        if qpos.shape != (self.num, self.nq) or qvel.shape != (self.num, self.nv):
            raise ValueError(f"qpos {qpos.shape} and qvel {qvel.shape}: expected ({self.num}, {self.nq}) and "
                             f"({self.num}, {self.nv})")
        self.bad = np.zeros(self.num, dtype=bool)
        per_step = act is not None and np.ndim(act) == 3  # (N, steps_per_frame, n): one row per physics step
        if per_step and np.shape(act)[1] != self.steps_per_frame:
            raise ValueError(f"activations {np.shape(act)}: expected (N, n) or (N, {self.steps_per_frame}, n)")
        if self.engine == "mujoco":
            return self._mujoco_frame(qpos, qvel, act, per_step)
        for s in range(self.steps_per_frame):
            qpos, qvel = self.step(qpos, qvel, act[:, s] if per_step else act)
        return qpos, qvel, self.bad

    def _mujoco_frame(self, qpos, qvel, act, per_step=False):
        """engine="mujoco": one `rollout` of steps_per_frame RK4 steps, the law in MuJoCo's callbacks."""
        if self.law is not None:
            act = np.asarray(act, dtype=np.float64)
            self._ctrl[:, :, self.columns] = act[:, :, self.law.muscle_of] if per_step else \
                act[:, None, self.law.muscle_of]
        self._state[:, self._iq] = qpos
        self._state[:, self._iv] = qvel
        self._rollout.rollout(self._models, self._datas, self._state, self._ctrl, nstep=self.steps_per_frame,
                              skip_checks=True, initial_warmstart=self.warmstart, state=self._out,
                              sensordata=self._sens)
        end = self._out[:, -1]
        qpos, qvel = end[:, self._iq].copy(), end[:, self._iv].copy()
        # MuJoCo resets a copy whose acceleration is unstable (the single env's crash warning): its time restarts at 0
        self.bad |= ~(end[:, self._it] > START_TIME) | ~np.isfinite(end).all(axis=1)
        return qpos, qvel, self.bad.copy()

    def frame(self, q: np.ndarray, v: np.ndarray, act=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """`frame_state`; for a one-joint model (v1) q and v may also be the angles and velocities (N,), and then
        (N,) come back: (q, v, failed)."""
        q, v = np.asarray(q), np.asarray(v)
        if q.ndim == 1 and v.ndim == 1:
            if self.nq != 1:
                raise ValueError(f"angles q {q.shape}: the model has {self.nq} joints; give qpos (N, {self.nq}) "
                                 f"and qvel (N, {self.nv}), or use frame_state")
            qpos, qvel, bad = self.frame_state(q[:, None], v[:, None], act)
            return qpos[:, 0], qvel[:, 0], bad
        return self.frame_state(q, v, act)
