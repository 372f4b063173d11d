"""The physiology options on the 3-DOF tasks (issue 12 §4): `randomize` (each episode's muscle strengths through the
actuators' gear, on the band's line of action too; the humerus mass; a load at the elbow), `activation_dynamics` and
`fatigue` (the 1-DOF tasks' per-step activation path), the same in the single env and the batched one, restored
exactly from a saved state."""
import copy

import mujoco
import numpy as np
import pytest

import shoulder_bench
from shoulder_bench import full_arm, randomization
from shoulder_bench.model import attach_law, install_callbacks
from shoulder_bench.tendon_law import TendonLaw

ROBUST_ARM = {"strength": 0.2, "mass": 0.1, "load": (0.5, 1.5)}


@pytest.mark.parametrize("line", ["mjcf", "band"])
def test_a_batched_copy_follows_the_single_env_with_a_randomised_arm(line):
    """Copy i draws the arm the single env seeded i draws, and the two move alike under the same actions (to the
    solver's warmstart, as without randomize)."""
    env = shoulder_bench.load("track_3dof", seed=1, randomize=ROBUST_ARM, line_of_action=line)
    venv = shoulder_bench.make_vec("track_3dof", 2, seed=0, randomize=ROBUST_ARM, line_of_action=line)
    env.reset()
    draw = venv.draws(1)
    np.testing.assert_array_equal(draw["strength"], env.task.arm_draw["strength"])
    assert draw["load_kg"] == env.task.arm_draw["load_kg"] and 0.5 <= draw["load_kg"] <= 1.5
    assert np.ptp(draw["strength"]) > 0.05 and draw["mass_scale"] != 1.0
    rng = np.random.default_rng(3)
    for _ in range(15):
        a = rng.uniform(-0.01, 0.01, (2, 13))
        ts = env.step(a[1])
        venv.advance(a)
        np.testing.assert_allclose(ts.observation["angle"], venv.observation_array()[1, :3], atol=1e-6)
    nominal = shoulder_bench.make_vec("track_3dof", 2, seed=0, line_of_action=line)
    for _ in range(15):
        nominal.advance(np.zeros((2, 13)))
    venv2 = shoulder_bench.make_vec("track_3dof", 2, seed=0, randomize=ROBUST_ARM, line_of_action=line)
    for _ in range(15):
        venv2.advance(np.zeros((2, 13)))
    # the randomised arm, held by the nominal arm's activations, drifts from where the nominal one stays
    assert np.abs(venv2.observation_array()[:, :3] - nominal.observation_array()[:, :3]).max() > 0.5
    for v in (venv, venv2, nominal):
        v.close()


def test_the_load_sits_at_the_elbow_of_the_full_arm():
    """A 1 kg load changes the gravity term of the equations of motion by J(elbow)^T (0, 0, g): a point mass at the
    MoBL elbow centre in the humerus frame; the strength scales every tendon of a muscle (ld's three) by its draw."""
    m = full_arm.compile_full()
    nominal = randomization.Nominal(m, randomization.groups(m, full_arm.ACTUATORS, full_arm.MUSCLES))
    d = mujoco.MjData(m)
    d.qpos[:] = full_arm.Pose(m).qpos([50.0, 70.0, 10.0])[0]
    mujoco.mj_forward(m, d)
    before = d.qfrc_bias.copy()
    elbow = d.xpos[nominal.body] + d.xmat[nominal.body].reshape(3, 3) @ np.array(randomization.ELBOW_IN_HUMERUS)
    jacp = np.zeros((3, m.nv))
    mujoco.mj_jac(m, d, jacp, None, elbow, nominal.body)
    strength = np.linspace(0.8, 1.2, len(full_arm.MUSCLES))
    randomization.apply(m, nominal, {"strength": strength, "mass_scale": 1.0, "load_kg": 1.0})
    mujoco.mj_forward(m, d)
    np.testing.assert_allclose(d.qfrc_bias - before, jacp.T @ np.array([0.0, 0.0, -m.opt.gravity[2]]), atol=1e-9)
    ld = [m.actuator(a).id for a in full_arm.ACTUATORS["ld"]]
    np.testing.assert_allclose(m.actuator_gear[ld, 0], nominal.gear[ld] * strength[full_arm.MUSCLES.index("ld")])


@pytest.mark.parametrize("native", [True, False])
def test_a_tendons_force_and_band_correction_scale_with_its_gear(native):
    """Twice the gear, twice the muscle: the law reads the tendon's own length (MuJoCo's actuator length over the
    gear), so the actuator force stays and the generalised force doubles, the band's correction (the passive
    callback's: with the band law less with the MJCF one) too; with either actuator callbacks."""
    install_callbacks(native=native)
    try:
        d_of = {}
        for line in ("mjcf", "band"):
            m = full_arm.compile_full()
            attach_law(m, TendonLaw.load("fem", groups=full_arm.ACTUATORS, line_of_action=line))
            d = mujoco.MjData(m)
            d.qpos[:] = full_arm.Pose(m).qpos([40.0, 80.0, -10.0])[0]
            d.ctrl[:] = 0.6
            d_of[line] = (m, d)
        band, force, qfrc = [], [], []
        for gear in (1.0, 2.0):
            for m, d in d_of.values():
                m.actuator_gear[:, 0] = gear
                mujoco.mj_forward(m, d)
            band.append(d_of["band"][1].qfrc_passive - d_of["mjcf"][1].qfrc_passive)
            force.append(d_of["mjcf"][1].actuator_force.copy())
            qfrc.append(d_of["mjcf"][1].qfrc_actuator.copy())
    finally:
        install_callbacks()
    assert np.abs(band[0]).max() > 0.1 and np.abs(force[0]).min() > 1.0
    np.testing.assert_allclose(force[1], force[0], rtol=1e-12)
    np.testing.assert_allclose(qfrc[1], 2.0 * qfrc[0], rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(band[1], 2.0 * band[0], rtol=1e-12, atol=1e-12)


def test_the_single_env_holds_with_the_nominal_arm_and_keeps_its_pose_model_nominal():
    env = shoulder_bench.load("track_3dof", seed=4, randomize=True)
    env.reset()
    env.reset()
    m, pose_m = env.physics.model.ptr, env.task.pose.m
    body = m.body("humerus").id
    assert m.body_mass[body] != pose_m.body_mass[body]  # this episode's arm in the physics, not in the pose model
    nominal = full_arm.compile_full()
    assert pose_m.body_mass[body] == nominal.body_mass[body]


def test_a_restored_randomised_batched_env_continues_exactly():
    venv = shoulder_bench.make_vec("track_3dof", 3, seed=2, randomize=True)
    rng = np.random.default_rng(0)
    for _ in range(5):
        venv.advance(rng.uniform(-0.01, 0.01, (3, 13)))
    state = copy.deepcopy(venv.state_dict())
    twin = shoulder_bench.make_vec("track_3dof", 3, seed=9, randomize=True)
    twin.load_state_dict(state)
    actions = rng.uniform(-0.01, 0.01, (110, 3, 13))  # through an episode's end: the next episode's draws too
    for a in actions:
        venv.advance(a)
        twin.advance(a)
    np.testing.assert_array_equal(twin.observation_array(), venv.observation_array())
    np.testing.assert_array_equal(twin.draw_strength, venv.draw_strength)
    plain = shoulder_bench.make_vec("track_3dof", 3, seed=2)
    with pytest.raises(ValueError, match=r"saved with physiology \(activation_dynamics, fatigue, randomize\)"):
        plain.load_state_dict(state)
    for v in (venv, twin, plain):
        v.close()


def test_bad_randomize_values_are_refused_on_the_3dof_tasks():
    with pytest.raises(ValueError, match="randomize strength must be a number"):
        shoulder_bench.load("track_3dof", randomize={"strength": 5})
    with pytest.raises(ValueError, match="randomize"):
        shoulder_bench.make_vec("track_3dof_discrete", 2, randomize="load=2:1")


def test_gymnasium_reports_the_3dof_episodes_draw():
    import gymnasium as gym

    env = gym.make("ShoulderBench/track_3dof-v0", randomize="strength=0.2,load=1")
    _, info = env.reset(seed=3)
    assert "excitations" not in info and "fatigue" not in info
    draw = info["randomization"]
    assert draw["strength"].shape == (13,) and draw["load_kg"] == 1.0 and draw["mass_scale"] == 1.0
    _, _, _, _, info = env.step(env.action_space.sample())
    np.testing.assert_array_equal(info["randomization"]["strength"], draw["strength"])
    env.close()
    env = gym.make("ShoulderBench/track_3dof-v0", activation_dynamics=True, fatigue=True)
    _, info = env.reset(seed=3)
    _, _, _, _, info = env.step(np.full(13, 0.01, dtype=np.float32))
    assert info["excitations"].shape == (13,) and info["fatigue"].shape == (13, 3)
    assert np.all(info["activations"] < info["excitations"])  # the activation trails its excitation
    env.close()


PHYSIOLOGY = {"activation_dynamics": True, "fatigue": True}


@pytest.mark.parametrize("options", [PHYSIOLOGY, {"condition": "deltoid_weakness", "weakness_fraction": 0.8}])
def test_a_batched_copy_follows_the_single_env_with_the_physiology_or_a_condition(options):
    """Copy 1 of the batched env and the single env seeded 1 under the same actions: the same angles (to the solver's
    warmstart) and activations, and with the physiology options the same excitation and fatigue."""
    env = shoulder_bench.load("track_3dof", seed=1, **options)
    venv = shoulder_bench.make_vec("track_3dof", 2, seed=0, **options)
    env.reset()
    rng = np.random.default_rng(4)
    for _ in range(12):
        a = rng.uniform(-0.01, 0.01, (2, 13))
        ts = env.step(a[1])
        venv.advance(a)
        obs = venv.observation_array()[1]
        np.testing.assert_allclose(ts.observation["angle"], obs[:3], atol=1e-6)
        np.testing.assert_allclose(ts.observation["activations"], obs[12:], atol=1e-12)
    if env.task.physiology:
        np.testing.assert_allclose(env.task.fatigue_state, venv.fatigue_state[1], atol=1e-12)
        np.testing.assert_allclose(env.task.excitation, venv.excitation[1], atol=1e-12)
    venv.close()


def test_the_activation_lags_its_excitation_and_fatigue_builds_up():
    """From rest at zero activation, +0.01 per frame: with the dynamics the activation trails the command (Thelen's
    time constants), without it equals it; held at full command, fatigue moves muscle into the fatigued pool."""
    lagging = shoulder_bench.load("track_3dof", seed=0, init="zero", activation_dynamics=True)
    plain = shoulder_bench.load("track_3dof", seed=0, init="zero")
    for env in (lagging, plain):
        env.reset()
        for _ in range(3):
            ts = env.step(np.full(13, 0.01))
        env.last = ts.observation["activations"]
    np.testing.assert_allclose(plain.last, 0.03, atol=1e-12)
    assert np.all(lagging.last > 0.0) and np.all(lagging.last < 0.03)
    np.testing.assert_allclose(lagging.task.excitation, 0.03, atol=1e-12)
    tired = shoulder_bench.load("track_3dof", seed=0, fatigue=True)
    tired.reset()
    for _ in range(30):
        tired.step(np.full(13, 0.01))
    assert tired.task.fatigue_state[:, 2].max() > 0.01  # M_F: the fatigued share


def test_a_restored_batched_env_with_every_physiology_option_continues_exactly():
    opts = PHYSIOLOGY | {"randomize": True}
    venv = shoulder_bench.make_vec("track_3dof", 2, seed=5, **opts)
    rng = np.random.default_rng(1)
    for _ in range(4):
        venv.advance(rng.uniform(-0.01, 0.01, (2, 13)))
    state = copy.deepcopy(venv.state_dict())
    twin = shoulder_bench.make_vec("track_3dof", 2, seed=8, **opts)
    twin.load_state_dict(state)
    for a in rng.uniform(-0.01, 0.01, (105, 2, 13)):
        venv.advance(a)
        twin.advance(a)
    np.testing.assert_array_equal(twin.observation_array(), venv.observation_array())
    np.testing.assert_array_equal(twin.fatigue_state, venv.fatigue_state)
    other = shoulder_bench.make_vec("track_3dof", 2, seed=5, randomize=True)
    with pytest.raises(ValueError, match="saved with physiology"):
        other.load_state_dict(state)
    for v in (venv, twin, other):
        v.close()
