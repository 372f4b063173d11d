"""The MJCF, the callback and the force law it applies."""
import copy

import mujoco
import numpy as np
import pytest

import shoulder_bench
from shoulder_bench import arm
from shoulder_bench.authoring import anatomy, mjcf
from shoulder_bench.model import (
    MODEL_PATH,
    attach_law,
    compile_model,
    install_callbacks,
    law_of,
    load_model,
    moment_arms,
)
from shoulder_bench.muscle import ForceLaw


def test_shipped_mjcf_is_generated_from_anatomy():
    assert MODEL_PATH.read_text() == mjcf.model_xml(), "run `python -m shoulder_bench.authoring.mjcf`"


def test_model_structure():
    m = compile_model()
    assert m.njnt == 1 and m.joint(0).name == "abduction"
    assert np.allclose(np.degrees(m.jnt_range[0]), anatomy.JOINT_RANGE_DEG)
    assert m.jnt_range[0, 0] <= 0 and np.degrees(m.jnt_range[0, 1]) >= 150
    hum = m.body("humerus")
    assert hum.mass[0] == pytest.approx(2.0) and np.allclose(hum.inertia, anatomy.HUMERUS_INERTIA)
    assert [m.actuator(i).name for i in range(m.nu)] == list(anatomy.MUSCLES)
    assert np.all(m.actuator_gaintype == mujoco.mjtGain.mjGAIN_USER)
    assert np.all(m.actuator_biastype == mujoco.mjtBias.mjBIAS_USER)
    for name in ("thorax", "clavicle", "scapula", "humerus"):
        assert m.geom(name).type == mujoco.mjtGeom.mjGEOM_MESH


def test_moment_arm_signs_follow_anatomy():
    r = moment_arms(np.array([10.0, 45.0, 90.0]))
    assert np.all(r["dmi"] > 0.02) and np.all(r["ssp"][:2] > 0.01)  # elevators
    assert np.all(r["ld"][1:] < -0.02)  # depressor above 30 deg
    assert np.all(np.abs(r["isp"]) < 0.01)  # small


def test_ssp_and_dmi_paths_do_not_cut_through_the_humeral_head():
    """Sample each path segment of the wrapped muscles; no point may lie inside the head sphere."""
    m = compile_model()
    d = mujoco.MjData(m)
    for angle in np.radians([-10, 0, 30, 60, 90, 120, 150]):
        d.qpos[0] = angle
        mujoco.mj_forward(m, d)
        for name in ("ssp", "dmi", "isp"):
            t = m.tendon(name).id
            adr, num = d.ten_wrapadr[t], d.ten_wrapnum[t]
            pts = d.wrap_xpos.reshape(-1, 3)[adr:adr + num]
            obj = d.wrap_obj.ravel()[adr:adr + num]
            assert num >= 3
            for k, (a, b) in enumerate(zip(pts[:-1], pts[1:])):
                if obj[k] >= 0 and obj[k + 1] >= 0:
                    continue  # two tangent points on the head: the path is the arc between them, on the surface
                s = np.linspace(0, 1, 50)[:, None]
                seg = a + s * (b - a)
                assert np.linalg.norm(seg, axis=1).min() >= anatomy.HUMERAL_HEAD_RADIUS - 1e-4, (name, angle)


def test_callback_applies_the_tabled_force():
    m = load_model("hill")
    law = law_of(m)
    d = mujoco.MjData(m)
    rng = np.random.default_rng(0)
    for _ in range(20):
        d.qpos[0] = np.radians(rng.uniform(-10, 160))
        d.qvel[0] = rng.uniform(-3, 3)
        d.ctrl[:] = rng.uniform(0, 1, size=4)
        mujoco.mj_forward(m, d)
        expected = law.force(d.qpos[:1].copy(), d.qvel[:1].copy(), d.ctrl[None, :].copy())[0]
        assert np.allclose(-d.actuator_force, expected, rtol=1e-12, atol=1e-9)


def test_compiling_with_the_callback_installed_and_several_models():
    """compile_model works while callbacks are installed; two models keep their own laws; copies keep theirs."""
    m_all = load_model("hill")
    m_ssp = compile_model()
    attach_law(m_ssp, ForceLaw.load("hill", muscles=("ssp",)))
    install_callbacks()
    m_copy = copy.copy(m_all)
    forces = []
    for m in (m_all, m_ssp, m_copy):
        d = mujoco.MjData(m)
        d.qpos[0] = 0.7
        d.ctrl[:] = 0.3
        mujoco.mj_forward(m, d)
        forces.append(d.actuator_force.copy())
    assert np.all(forces[0] < 0)
    assert forces[1][0] == pytest.approx(forces[0][0]) and np.all(forces[1][1:] == 0)  # other muscles absent
    assert np.array_equal(forces[2], forces[0])


def test_unknown_model_gets_zero_force_not_an_exception():
    m = compile_model()  # no law attached: actuator_user law id 0
    install_callbacks()
    d = mujoco.MjData(m)
    d.ctrl[:] = 1.0
    mujoco.mj_forward(m, d)
    assert np.all(d.actuator_force == 0)


def test_model_path_is_public():
    assert shoulder_bench.MODEL_PATH.exists() and shoulder_bench.MODEL_PATH.name == "shoulder.xml"


def test_moment_arms_are_continuous():
    """No wrap flips: on a 0.25 deg grid the moment arms change by less than 0.5 mm per step."""
    fine = np.arange(-10.0, 160.0 + 1e-9, 0.25)
    for name, r in moment_arms(fine).items():
        assert np.abs(np.diff(r)).max() < 5e-4, name


def test_compiled_model_equals_a_plain_compile():
    """compile_model (user actuators compiled as fixed ones, then switched back) gives MuJoCo's own model exactly."""
    saved = mujoco.get_mjcb_act_gain(), mujoco.get_mjcb_act_bias()
    mujoco.set_mjcb_act_gain(None)
    mujoco.set_mjcb_act_bias(None)
    try:
        plain = mujoco.MjModel.from_xml_path(str(shoulder_bench.SCENE_PATH))
    finally:
        mujoco.set_mjcb_act_gain(saved[0])
        mujoco.set_mjcb_act_bias(saved[1])
    ours = compile_model(shoulder_bench.SCENE_PATH)
    compared = 0
    for name in dir(plain):
        a = getattr(plain, name, None) if not name.startswith("_") else None
        if isinstance(a, np.ndarray):
            assert np.array_equal(a, getattr(ours, name), equal_nan=True), name
            compared += 1
    assert compared > 100 and np.all(ours.actuator_gaintype == mujoco.mjtGain.mjGAIN_USER)
    assert str(ours.opt) == str(plain.opt)


def test_building_and_stepping_in_8_threads_at_once():
    """8 threads build an environment and step it at the same moment, 4 times: no engine error, the same result."""
    import threading

    action = np.array([0.005, 0.0, 0.005, -0.005])
    ref = shoulder_bench.load("abduction_4m", seed=0)
    ref.reset()
    expected = ref.step(action).observation["angle"][0]
    def build_and_step(start, results, errors):
        try:
            start.wait()
            env = shoulder_bench.load("abduction_4m", seed=0)
            env.reset()
            results.append(env.step(action).observation["angle"][0])
        except Exception as exc:  # noqa: BLE001 - collected and reported by the assertion below
            errors.append(repr(exc))

    for _ in range(4):
        start, results, errors = threading.Barrier(8), [], []
        threads = [threading.Thread(target=build_and_step, args=(start, results, errors)) for _ in range(8)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        assert errors == [] and len(results) == 8
        assert np.allclose(results, expected, rtol=0, atol=1e-9)


def test_compile_model_from_text_with_a_prepare_hook():
    """xml= compiles MJCF text as a file would be (user actuators kept user); prepare runs on the compiled model."""
    from shoulder_bench.authoring import mobl

    xml = mobl.model_xml(locked_plane_deg=0, dynamics=True, actuators=True)
    seen = []
    ours = compile_model(xml=xml, prepare=seen.append)
    assert len(seen) == 1 and seen[0] is ours
    assert np.all(ours.actuator_gaintype == mujoco.mjtGain.mjGAIN_USER)
    assert np.all(ours.actuator_biastype == mujoco.mjtBias.mjBIAS_USER)
    saved = mujoco.get_mjcb_act_gain(), mujoco.get_mjcb_act_bias()
    mujoco.set_mjcb_act_gain(None)
    mujoco.set_mjcb_act_bias(None)
    try:
        plain = mujoco.MjModel.from_xml_string(xml)
    finally:
        mujoco.set_mjcb_act_gain(saved[0])
        mujoco.set_mjcb_act_bias(saved[1])
    for name in ("actuator_gaintype", "actuator_biastype", "actuator_user", "actuator_trnid", "eq_data", "qpos0"):
        assert np.array_equal(getattr(ours, name), getattr(plain, name)), name


def _v2_locked():
    from shoulder_bench.authoring import mobl

    xml = mobl.model_xml(locked_plane_deg=0, dynamics=True, actuators=True)
    return compile_model(xml=xml, prepare=arm.harden_couplings)


def test_the_law_joint_is_chosen_per_model():
    """v1: abduction; v2 (no abduction): shoulder_elv; the callback reads each model's own joint; a model with
    neither (or an unknown name) is refused, naming its joints."""
    from shoulder_bench import model
    from shoulder_bench.authoring import hill_v2

    v1, v2 = load_model("hill"), _v2_locked()
    law2 = hill_v2.load_law(0)
    attach_law(v2, law2)
    install_callbacks()
    assert law_of(v2) is law2 and law_of(v1).muscles == anatomy.MUSCLES
    e2 = model._model_entry(v2)
    elv = v2.joint("shoulder_elv")
    assert (e2.qadr, e2.vadr) == (int(elv.qposadr[0]), int(elv.dofadr[0])) and e2.qadr != 0
    assert (model._model_entry(v1).qadr, model._model_entry(v1).vadr) == (0, 0)
    d = mujoco.MjData(v2)
    d.qpos[elv.qposadr[0]] = 0.9
    d.ctrl[:] = 0.4
    mujoco.mj_forward(v2, d)
    gain, bias = law2.gain_bias(np.array([0.9]), np.zeros(1), np.full((1, 6), 0.4))
    np.testing.assert_allclose(d.actuator_force, -(gain[0] * 0.4 + bias[0]), rtol=1e-12)
    with pytest.raises(ValueError, match="no joint 'abduction'.*shoulder_elv"):
        attach_law(v2, law2, joint="abduction")
    bare = compile_model(xml='<mujoco><worldbody><body><joint name="hinge"/><geom size="0.1" mass="1"/></body>'
                             '</worldbody><actuator><general name="ssp" joint="hinge"/></actuator></mujoco>')
    with pytest.raises(ValueError, match=r"none of the law joints.*\['hinge'\]"):
        attach_law(bare, ForceLaw.load("hill", muscles=("ssp",)))
