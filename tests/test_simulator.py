"""The batched simulator on the full qpos/qvel: v1 unchanged bit for bit, the v2 locked variant equal to mj_step."""
from __future__ import annotations

import mujoco
import numpy as np
import pytest
from mujoco import rollout

from shoulder_bench import mobl, statics
from shoulder_bench.model import JOINT, MODEL_PATH, compile_model, load_model
from shoulder_bench.muscle import ForceLaw
from shoulder_bench.simulator import RK4_A, RK4_B, BatchSimulator

MUSCLES = ("ssp", "isp", "dmi", "ld")
FRAMES = 5


class _V1Simulator:
    """The batched simulator before it carried the whole state (one joint, q and v (N,)): the reference arithmetic."""

    def __init__(self, law, num: int, nthread: int = 2):
        m = compile_model(MODEL_PATH)
        self.h = float(m.opt.timestep)
        names = [m.actuator(i).name for i in range(m.nu)]
        self.columns = np.array([names.index(x) for x in law.muscles])
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
        self._models = [m] * num
        self._rollout = rollout.Rollout(nthread=nthread)

    def acceleration(self, q, v, act):
        self._ctrl[:, 0, self.columns] = -self.law.force(q, v, act)
        self._state[:, self._iq] = q
        self._state[:, self._iv] = v
        self._rollout.rollout(self._models, self._datas, self._state, self._ctrl, nstep=1, skip_checks=True,
                              state=self._out, sensordata=self._sens)
        acc = (self._out[:, 0, self._iv] - v) / self.h
        self.bad |= ~np.isfinite(acc) | (np.abs(acc) > 1e10)
        return acc

    def step(self, q, v, act):
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

    def frame(self, q, v, act):
        self.bad = np.zeros(len(q), dtype=bool)
        for _ in range(self.steps_per_frame):
            q, v = self.step(q, v, act)
        return q, v, self.bad

    def close(self):
        self._rollout.close()


def test_v1_is_the_old_arithmetic_bit_for_bit_and_mj_step_to_rounding():
    law, n = ForceLaw.load("fem", muscles=MUSCLES), 5
    new, old = BatchSimulator(law, n), _V1Simulator(law, n)
    assert (new.nq, new.nv, new.carry_warmstart) == (1, 1, False)
    m = load_model("fem", muscles=MUSCLES)  # the single env's path: the muscle law in MuJoCo's callbacks
    ids = [m.actuator(x).id for x in MUSCLES]
    datas = [mujoco.MjData(m) for _ in range(n)]
    rng = np.random.default_rng(3)
    start = rng.uniform(20, 100, n)
    q, v = np.radians(start), rng.uniform(-1, 1, n)
    act = statics.holding_activation(law, start)
    for d, qi, vi in zip(datas, q, v):
        d.qpos[0], d.qvel[0] = qi, vi
    q_old, v_old = q.copy(), v.copy()
    for _ in range(FRAMES):
        act = np.clip(act + rng.uniform(-0.05, 0.05, act.shape), 0.0, 1.0)
        q, v, bad = new.frame(q, v, act)
        q_old, v_old, bad_old = old.frame(q_old, v_old, act)
        assert q.shape == v.shape == (n,)
        np.testing.assert_array_equal(q, q_old)  # bit-identical
        np.testing.assert_array_equal(v, v_old)
        assert not bad.any() and not bad_old.any()
        for i, d in enumerate(datas):
            d.ctrl[ids] = act[i]
            mujoco.mj_step(m, d, new.steps_per_frame)
        ref_q, ref_v = np.array([d.qpos[0] for d in datas]), np.array([d.qvel[0] for d in datas])
        assert np.abs(np.degrees(q - ref_q)).max() <= 1e-9  # the batched-vs-single env tolerance (test_vec_env)
        assert np.abs(np.degrees(v - ref_v)).max() <= 1e-9
    # the same through frame_state with (N, 1) states
    qs, vs, _ = new.frame_state(q[:, None], v[:, None], act)
    q1, v1, _ = old.frame(q, v, act)
    np.testing.assert_array_equal(qs[:, 0], q1)
    np.testing.assert_array_equal(vs[:, 0], v1)
    new.close()
    old.close()


def _slope(m: mujoco.MjModel) -> np.ndarray:
    """qpos per radian of elevation: the polycoef prescription (linear through qpos0 = 0)."""
    slope = np.zeros(m.nv)
    slope[m.joint("shoulder_elv").dofadr[0]] = 1.0
    for e in range(m.neq):
        assert m.eq_type[e] == mujoco.mjtEq.mjEQ_JOINT and m.eq_data[e, 0] == 0 and not m.eq_data[e, 2:5].any()
        slope[m.jnt_dofadr[m.eq_obj1id[e]]] = m.eq_data[e, 1]
    return slope


@pytest.mark.parametrize("plane", [0.0, 30.0])
def test_v2_locked_free_fall_equals_mj_step(plane):
    xml = mobl.model_xml(locked_plane_deg=plane, dynamics=True)
    sim = BatchSimulator(None, 3, xml=xml, prepare=mobl.harden_couplings, joint="shoulder_elv")
    m = mobl.harden_couplings(mujoco.MjModel.from_xml_string(xml))
    np.testing.assert_array_equal(sim.model.dof_invweight0, mobl.COUPLING_INVWEIGHT)  # the hook ran on its copy
    assert (sim.nq, sim.nv, m.nq, sim.carry_warmstart) == (11, 11, 11, True)
    slope = _slope(m)
    start = np.radians([90.0, 60.0, 120.0])  # copy 0: the free fall from 90 deg; the others keep copies apart
    datas = [mujoco.MjData(m) for _ in start]
    for d, e in zip(datas, start):
        d.qpos[:] = slope * e
    qpos, qvel = np.array([d.qpos for d in datas]), np.zeros((3, m.nv))
    lag, lowest = 0.0, np.inf
    for _ in range(20):  # 2 s
        qpos, qvel, bad = sim.frame_state(qpos, qvel)
        for d in datas:
            mujoco.mj_step(m, d, sim.steps_per_frame)
        assert not bad.any()
        np.testing.assert_allclose(qpos, [d.qpos for d in datas], rtol=0, atol=1e-12)  # 1e-9 without warmstart
        np.testing.assert_allclose(qvel, [d.qvel for d in datas], rtol=0, atol=1e-12)
        elv = qpos[:, sim.qadr]
        lag, lowest = max(lag, np.abs(qpos - elv[:, None] * slope).max()), min(lowest, elv[0])
    assert np.degrees(lag) < 1e-4  # the girdle on the prescription
    assert np.degrees(lowest) < 0  # it did fall through the side onto the soft limit
    with pytest.raises(ValueError, match="11 joints"):
        sim.frame(qpos[:, 0], qvel[:, 0])
    sim.close()


@pytest.mark.parametrize("joint", ["free", "ball"])
def test_free_and_ball_joints_are_refused(joint):
    xml = (f'<mujoco><option integrator="RK4"/><worldbody><body><joint name="j" type="{joint}"/>'
           '<geom size="0.1"/></body></worldbody></mujoco>')
    with pytest.raises(ValueError, match=f"joint 'j' is a {joint} joint; .* hinge and slide joints only"):
        BatchSimulator(None, 2, xml=xml)
