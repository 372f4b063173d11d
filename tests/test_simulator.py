"""The batched simulator on the full qpos/qvel: v1 unchanged bit for bit, the v2 locked variant equal to mj_step."""
from __future__ import annotations

import mujoco
import numpy as np
import pytest

from shoulder_bench import arm, statics
from shoulder_bench.authoring import mobl
from shoulder_bench.model import load_model
from shoulder_bench.muscle import ForceLaw
from shoulder_bench.simulator import BatchSimulator

MUSCLES = ("ssp", "isp", "dmi", "ld")
FRAMES = 5


def test_v1_equals_mj_step_on_the_callback_path_to_rounding():
    """v1 through the generalised simulator (its (N,) API and frame_state) against MuJoCo's own RK4. When the simulator
    became multi-DOF, a frozen copy of the one-joint class gave bit-identical results (commit history)."""
    law, n = ForceLaw.load("fem", muscles=MUSCLES), 5
    new = BatchSimulator(law, n)
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
    for _ in range(FRAMES):
        act = np.clip(act + rng.uniform(-0.05, 0.05, act.shape), 0.0, 1.0)
        q, v, bad = new.frame(q, v, act)
        assert q.shape == v.shape == (n,) and not bad.any()
        for i, d in enumerate(datas):
            d.ctrl[ids] = act[i]
            mujoco.mj_step(m, d, new.steps_per_frame)
        ref_q, ref_v = np.array([d.qpos[0] for d in datas]), np.array([d.qvel[0] for d in datas])
        assert np.abs(np.degrees(q - ref_q)).max() <= 1e-9  # the batched-vs-single env tolerance (test_vec_env)
        assert np.abs(np.degrees(v - ref_v)).max() <= 1e-9
    # the same through frame_state with (N, 1) states
    qs, vs, _ = new.frame_state(q[:, None], v[:, None], act)
    q1, v1, _ = new.frame(q, v, act)
    np.testing.assert_array_equal(qs[:, 0], q1)
    np.testing.assert_array_equal(vs[:, 0], v1)
    new.close()


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
    sim = BatchSimulator(None, 3, xml=xml, prepare=arm.harden_couplings, joint="shoulder_elv")
    m = arm.harden_couplings(mujoco.MjModel.from_xml_string(xml))
    np.testing.assert_array_equal(sim.model.dof_invweight0, arm.COUPLING_INVWEIGHT)  # the hook ran on its copy
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


def test_v2_with_the_law_equals_mj_step_through_the_callbacks():
    """The switch-over's premise: the v2 locked variant with the v2 law, mj_step (RK4) through model.py's callbacks
    (law joint shoulder_elv) for 1 s at constant activations, equals BatchSimulator.frame_state to rounding."""
    from shoulder_bench.authoring import hill_v2
    from shoulder_bench.authoring.validate import TASK_PLANE_V2
    from shoulder_bench.model import attach_law, install_callbacks

    law = hill_v2.load_law(TASK_PLANE_V2)
    xml = mobl.model_xml(locked_plane_deg=TASK_PLANE_V2, dynamics=True, actuators=True)
    sim = BatchSimulator(law, 2, xml=xml, prepare=arm.harden_couplings, joint="shoulder_elv")
    m = hill_v2.compile_actuated(TASK_PLANE_V2)
    attach_law(m, law)  # default joint: shoulder_elv (the model has no abduction)
    install_callbacks()
    ids = [m.actuator(x).id for x in law.muscles]
    slope = _slope(m)
    act = np.array([[0.3, 0.1, 0.5, 0.2, 0.2, 0.2], [0.05, 0.6, 0.15, 0.4, 0.0, 0.7]])
    datas = [mujoco.MjData(m) for _ in act]
    for d, e, a in zip(datas, np.radians([40.0, 100.0]), act):
        d.qpos[:] = slope * e
        d.ctrl[ids] = a
    qpos, qvel = np.array([d.qpos for d in datas]), np.zeros((2, m.nv))
    moved = 0.0
    for _ in range(10):  # 1 s
        qpos, qvel, bad = sim.frame_state(qpos, qvel, act)
        for d in datas:
            mujoco.mj_step(m, d, sim.steps_per_frame)
        assert not bad.any()
        np.testing.assert_allclose(qpos, [d.qpos for d in datas], rtol=0, atol=1e-12)
        np.testing.assert_allclose(qvel, [d.qvel for d in datas], rtol=0, atol=1e-12)  # seen: 9e-16, 1.5e-14
        moved = max(moved, np.abs(qvel[:, sim.dadr]).max())
    assert moved > 0.1  # the muscles did move the arm (rad/s), so velocity-dependent forces were exercised
    sim.close()
