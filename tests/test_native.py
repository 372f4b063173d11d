"""The compiled muscle callbacks (shoulder_bench.native) against the Python ones: episodes, threads, odd models."""
import copy
import ctypes

import mujoco
import numpy as np
import pytest
from mujoco import rollout

import shoulder_bench
from shoulder_bench import arm, full_arm, native
from shoulder_bench.model import attach_law, compile_model, install_callbacks, installed_callbacks, load_model
from shoulder_bench.muscle import ForceLaw
from shoulder_bench.tasks import TASKS


@pytest.fixture(autouse=True)
def _restore_default_callbacks():
    yield
    install_callbacks()


def test_offsets_are_found_and_native_is_the_default():
    assert native.AVAILABLE, native.REASON
    assert set(native.OFFSETS) == {"actuator_user", "actuator_gear", "nuser_actuator", "nu", "qpos", "qvel", "ctrl",
                                   "actuator_length", "actuator_velocity", "qfrc_passive"}
    assert native.find_offsets() == native.OFFSETS  # the same again, from fresh probes
    install_callbacks()
    assert installed_callbacks() == "native" and mujoco.get_mjcb_act_gain() is native.GAIN
    assert mujoco.get_mjcb_passive() is native.PASSIVE
    m = mujoco.MjModel.from_xml_path(str(full_arm.MODEL_FILE))
    assert native.model_nu(m) == m.nu == 15
    gear = int.from_bytes(ctypes.string_at(m._address + native.OFFSETS["actuator_gear"], 8), "little")
    assert gear == m.actuator_gear.ctypes.data  # the field the passive callback reads a band tendon's gear from


def _episode(name: str, use_native: bool) -> np.ndarray:
    install_callbacks(native=use_native)
    env = shoulder_bench.load(name, split="test", seed=5)
    rng = np.random.default_rng(11)
    spec = env.action_spec()
    ts = env.reset()
    states = []
    while not ts.last():
        if TASKS[name][1]:
            action = rng.integers(0, 21, size=spec.shape) if spec.shape else int(rng.integers(0, 21))
        else:
            action = rng.uniform(spec.minimum, spec.maximum, size=spec.shape)
        ts = env.step(action)
        states.append(np.concatenate([env.physics.data.qpos, env.physics.data.qvel]))  # rad, rad/s
    return np.array(states)


@pytest.mark.parametrize("name", list(TASKS))
def test_a_20_s_episode_of_every_task_is_the_same_with_both_callbacks(name):
    compiled, python = _episode(name, True), _episode(name, False)
    assert len(compiled) == 200  # 20 s: the episode ran to its end, no crash
    np.testing.assert_allclose(compiled, python, rtol=0, atol=1e-12)  # seen: bit for bit
    elv = arm.compile_arm().joint(arm.JOINT).qposadr[0]
    assert np.ptp(compiled[:, elv]) > 0.05  # rad: the arm moved


def _task_model():
    m = arm.compile_arm()
    law = arm.arm().load_law("fem", arm.MUSCLES)
    attach_law(m, law)
    return m, law


def test_rollout_in_two_threads_equals_mj_step_per_copy():
    """mujoco.rollout (nthread=2, GIL released) through the compiled callback equals mj_step copy by copy."""
    m, _ = _task_model()
    install_callbacks(native=True)
    rng = np.random.default_rng(2)
    n, nstep = 6, 20
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    qpos = arm.arm().qpos(np.radians(rng.uniform(20, 100, n)))
    ctrl = np.zeros((n, nstep, m.nu))
    for acts in arm.ACTUATORS.values():
        level = rng.uniform(0, 0.6, (n, nstep))
        for a in acts:
            ctrl[:, :, m.actuator(a).id] = level
    state0 = np.zeros((n, mujoco.mj_stateSize(m, spec)))
    expected = np.zeros((n, nstep, state0.shape[1]))
    d = mujoco.MjData(m)
    for i in range(n):
        mujoco.mj_resetData(m, d)
        d.qpos[:] = qpos[i]
        mujoco.mj_getState(m, d, state0[i], spec)
        for t in range(nstep):
            d.ctrl[:] = ctrl[i, t]
            mujoco.mj_step(m, d)
            mujoco.mj_getState(m, d, expected[i, t], spec)
    with rollout.Rollout(nthread=2) as r:
        state, _ = r.rollout([m] * n, [mujoco.MjData(m) for _ in range(2)], state0, ctrl)
    np.testing.assert_array_equal(state, expected)
    assert np.abs(np.diff(expected[:, :, 1], axis=1)).max() > 1e-3  # time moves; the arm too (below)
    iv = mujoco.mj_stateSize(m, mujoco.mjtState.mjSTATE_TIME) + m.nq
    assert np.abs(expected[:, -1, iv:iv + m.nv]).max() > 0.05


def _forces(m, qpos, qvel, ctrl):
    d = mujoco.MjData(m)
    d.qpos[:], d.qvel[:], d.ctrl[:] = qpos, qvel, ctrl
    mujoco.mj_forward(m, d)
    return d.actuator_force.copy()


def test_two_models_with_different_laws_each_get_their_own_forces():
    v1 = load_model("hill")
    v1_ssp = compile_model()
    ssp = ForceLaw.load("fem", muscles=("ssp",))
    attach_law(v1_ssp, ssp)
    v2, law2 = _task_model()
    install_callbacks(native=True)
    rng = np.random.default_rng(4)
    for _ in range(30):
        q, v = rng.uniform(-0.5, 3.0), rng.uniform(-5, 5)
        act = rng.uniform(0, 1, 4)
        hill4 = ForceLaw.load("hill")
        f1 = _forces(v1, [q], [v], act)
        np.testing.assert_allclose(-f1, hill4.force(np.array([q]), np.array([v]), act[None])[0], rtol=1e-13)
        f_ssp = _forces(copy.copy(v1_ssp), [q], [v], act)  # a copy keeps its model's law
        assert f_ssp[0] == pytest.approx(-ssp.force(np.array([q]), np.array([v]), act[None, :1])[0, 0], rel=1e-13)
        assert np.all(f_ssp[1:] == 0)  # isp, dmi, ld: no law column
        qpos = arm.arm().qpos(q)[0]
        ctrl = np.repeat(act, [len(a) for a in arm.ACTUATORS.values()])
        f2 = _forces(v2, qpos, np.zeros(v2.nv) + 0.0, ctrl)
        expected = law2.force(np.array([q]), np.zeros(1), act[None])[0]
        np.testing.assert_allclose(-f2, expected, rtol=1e-13, atol=1e-12)
        install_callbacks(native=False)
        assert np.array_equal(_forces(v2, qpos, np.zeros(v2.nv), ctrl), f2)
        assert np.array_equal(_forces(v1, [q], [v], act), f1)
        install_callbacks(native=True)


USER_XML = ('<mujoco><size nuser_actuator="{nuser}"/><worldbody><body><joint name="abduction"/>'
            '<geom size="0.1" mass="1"/></body></worldbody><actuator>{acts}</actuator></mujoco>')


@pytest.mark.parametrize("user", ["0 0", "1e9 0", "-3 0", "2.5 0", "nan 0", "LAW -1", "LAW 7", "LAW 0.5", "LAW nan"])
def test_an_actuator_without_a_law_gets_zero_force(user):
    """No law id (0), an id no law has, a non-integer or NaN id, a column outside the law: 0, no crash."""
    law = ForceLaw.load("hill", muscles=("ssp",))
    other = compile_model(xml=USER_XML.format(nuser=2, acts='<general name="ssp" joint="abduction" '
                                                             'gaintype="user" biastype="user"/>'))
    attach_law(other, law)  # registers a law id; the model under test then names it (or not)
    lid = int(other.actuator_user[0, 0])
    acts = ('<general name="ssp" joint="abduction" gaintype="user" biastype="user" user="{}"/>'
            '<general name="isp" joint="abduction" gaintype="user" biastype="user" user="{}"/>')
    m = compile_model(xml=USER_XML.format(nuser=2, acts=acts.format(user.replace("LAW", str(lid)), f"{lid} 0")))
    install_callbacks(native=True)
    f = _forces(m, [0.5], [0.3], [0.7, 0.7])
    assert f[0] == 0.0
    assert f[1] == pytest.approx(_forces(other, [0.5], [0.3], [0.7])[0], rel=1e-14) and f[1] < 0  # a valid row


@pytest.mark.parametrize("nuser", [0, 1])
def test_a_model_with_too_few_user_columns_gets_zero_force(nuser):
    m = compile_model(xml=USER_XML.format(nuser=nuser, acts='<general joint="abduction" gaintype="user" '
                                                            'biastype="user"/>'))
    install_callbacks(native=True)
    assert np.all(_forces(m, [0.5], [0.3], [0.7]) == 0.0)


def test_the_registry_grows_while_old_laws_keep_working():
    m = load_model("hill")
    before = _forces(m, [0.4], [1.0], [0.3, 0.2, 0.5, 0.1])
    capacity = len(native._TABLES[-1])
    law = ForceLaw.load("hill", muscles=("dmi",))
    extra = [compile_model() for _ in range(3)]
    for k in range(capacity + 5 - int(m.actuator_user[0, 0])):
        attach_law(extra[k % 3], law)
    assert len(native._TABLES[-1]) > capacity
    install_callbacks(native=True)
    assert np.array_equal(_forces(m, [0.4], [1.0], [0.3, 0.2, 0.5, 0.1]), before)
    f = _forces(extra[0], [0.4], [1.0], [0.3, 0.2, 0.5, 0.1])
    assert f[2] < 0 and np.all(f[[0, 1, 3]] == 0)


def _engines(law, n):
    from shoulder_bench.simulator import BatchSimulator

    return {e: BatchSimulator(law, n, path=arm.MODEL_FILE, prepare=arm.harden_couplings, engine=e)
            for e in ("numpy", "mujoco")}


def test_the_mujoco_engine_matches_the_numpy_rk4_on_a_frame_and_a_20_s_episode():
    """engine="mujoco" (one rollout per frame, MuJoCo's RK4, the compiled callback) against the numpy RK4: to rounding
    (seen: 1.8e-15 after a frame, 2.5e-14 rad after 20 s; each frame starts from a zero warmstart)."""
    law = arm.arm().load_law("fem", arm.MUSCLES)
    n, frames = 6, 200
    sims = _engines(law, n)
    rng = np.random.default_rng(0)
    acts = np.clip(0.2 + np.cumsum(rng.uniform(-0.01, 0.01, (frames, n, 4)), axis=0), 0, 1)
    start = (arm.arm().qpos(np.radians(rng.uniform(30, 90, n))), np.zeros((n, sims["numpy"].nv)))
    states = dict.fromkeys(sims, start)
    for f in range(frames):
        for e, sim in sims.items():
            q, v, bad = sim.frame_state(*states[e], acts[f])
            assert not bad.any()
            states[e] = (q, v)
        tol = 1e-14 if f == 0 else 1e-12
        np.testing.assert_allclose(states["mujoco"][0], states["numpy"][0], rtol=0, atol=tol)
        np.testing.assert_allclose(states["mujoco"][1], states["numpy"][1], rtol=0, atol=10 * tol)
    assert np.ptp(states["numpy"][0][:, sims["numpy"].qadr]) > 0.1
    passive = _engines(None, 2)  # free fall from 150 deg: the couplings' solver tolerance shows (seen: 2e-11 rad)
    states = dict.fromkeys(passive, (arm.arm().qpos(np.radians([150.0, 120.0])), np.zeros((2, sims["numpy"].nv))))
    for _ in range(20):
        states = {e: sim.frame_state(*states[e])[:2] for e, sim in passive.items()}
    np.testing.assert_allclose(states["mujoco"][0], states["numpy"][0], rtol=0, atol=1e-9)
    for sim in (*sims.values(), *passive.values()):
        sim.close()
