"""The physiology options (issue 14 §1): activation_dynamics, fatigue, randomize. The laws themselves (against an ODE
solver and closed forms), equivalence of the dm_control, gymnasium, gymnasium vector and batched envs, checkpoints,
bad values, and that the defaults leave the paper's protocol unchanged."""
import gymnasium as gym
import mujoco
import numpy as np
import pytest
from scipy.integrate import solve_ivp

import shoulder_bench
from shoulder_bench import arm as arm_
from shoulder_bench import physiology, protocol, randomization
from shoulder_bench.cli import main
from shoulder_bench.geometry import compile_model

TARGET = 40 + 25 * np.sin(np.linspace(0, 3, 31))  # 30 frames: episodes end and restart within a test
NAME = "abduction_4m"
CASES = [({"activation_dynamics": True}, 1e-9), ({"fatigue": {"F": 0.5, "R": 0.05}}, 1e-9),
         ({"randomize": True}, 1e-6),  # an arm on the joint limit: the constraint solver's tolerance (1e-7 deg/s)
         ({"activation_dynamics": True, "fatigue": True, "randomize": "strength=0.3,load=0:2"}, 1e-6)]


@pytest.mark.parametrize("u,a", [(1.0, 0.0), (0.0, 1.0), (0.3, 0.29), (0.5, 0.7), (0.05, 0.0), (0.4, 0.4)])
def test_activation_is_the_exact_solution_of_thelens_ode(u, a):
    ref = solve_ivp(lambda t, y: physiology.activation_rate(u, y), (0, 0.05), [a], rtol=1e-12, atol=1e-14,
                    method="LSODA").y[0, -1]
    got = physiology.activation_after(np.array([u]), np.array([a]), 0.05)[0]
    assert abs(got - ref) < 1e-9
    half = physiology.activation_after(np.array([u]), np.array([a]), 0.025)
    assert abs(physiology.activation_after(np.array([u]), half, 0.025)[0] - got) < 1e-12  # a flow: halves compose
    assert min(a, u) - 1e-15 <= got <= max(a, u) + 1e-15  # never crosses the excitation


def test_fatigue_follows_the_3cc_r_model():
    p = physiology.Fatigue()
    state = physiology.fresh_fatigue(np.array([0.5]))
    for _ in range(400):  # 20 s at 50 %: M_A holds the load (M_R stays > 0), M_F = TL F / R (1 - e^(-R t))
        state = physiology.fatigue_after(state, np.array([0.5]), 0.05, p)
    assert abs(state[0, 0] - 0.5) < 1e-3 and state[0, 1] > 0.1
    assert abs(state[0, 2] - 0.5 * p.F / p.R * (1 - np.exp(-p.R * 20))) < 2e-3
    assert abs(state.sum() - 1.0) < 1e-12
    mf = state[0, 2]
    for _ in range(200):  # 10 s of rest: recovery r R (M_A drains within a second)
        state = physiology.fatigue_after(state, np.array([0.0]), 0.05, p)
    assert abs(state[0, 2] - mf * np.exp(-p.r * p.R * 10)) < 0.02 * mf
    assert abs(physiology.capacity(state)[0] - (1 - state[0, 2])) < 1e-15


def test_fatigue_caps_the_acting_activation():
    tired = np.array([[[0.3, 0.0, 0.7]]])  # 70 % fatigued: at most 0.3 acts
    acting, a, _ = physiology.frame_plan(np.array([[0.8]]), np.array([[0.8]]), tired, 2, 0.05, False,
                                         physiology.Fatigue())
    assert acting[0, 0, 0] == pytest.approx(0.3) and a[0, 0] == 0.8  # the agent's activation stays its own


def _flat(ts):
    return np.concatenate([np.ravel(ts.observation[k]) for k in protocol.OBSERVATION_KEYS])


@pytest.mark.parametrize("options,tol", CASES, ids=lambda o: str(o))
def test_single_batched_and_gymnasium_agree(options, tol):
    n, seed, steps = 3, 5, 70
    acts = np.random.default_rng(0).uniform(-0.012, 0.012, (steps, n, 4))
    venv = shoulder_bench.make_vec(NAME, n, seed=seed, trajectory=TARGET, **options)
    gvec = gym.make_vec(f"ShoulderBench/{NAME}-v0", num_envs=n, trajectory=TARGET, **options)
    gobs, _ = gvec.reset(seed=seed)
    envs = [shoulder_bench.load(NAME, seed=seed + i, trajectory=TARGET, **options) for i in range(n)]
    gyms = [gym.make(f"ShoulderBench/{NAME}-v0", trajectory=TARGET, **options) for _ in range(n)]
    first = [_flat(e.reset()) for e in envs]
    ginfo = [g.reset(seed=seed + i)[1] for i, g in enumerate(gyms)]
    for i in range(n):
        assert np.abs(venv.observation_array()[i] - first[i]).max() <= tol
        if "randomize" in options:
            assert np.array_equal(envs[i].task.arm_draw["strength"], venv.draws(i)["strength"])
            assert envs[i].task.arm_draw["load_kg"] == ginfo[i]["randomization"]["load_kg"]
    worst = 0.0
    for t in range(steps):
        venv.step(acts[t])
        vobs = venv.observation_array()
        gv, grew, _, _, gvinfo = gvec.step(acts[t].astype(np.float32))
        for i in range(n):
            ts = envs[i].step(acts[t, i])
            go, gr, term, trunc, gi = gyms[i].step(acts[t, i].astype(np.float32))
            if ts.last():
                envs[i].reset(), gyms[i].reset()
                continue
            obs = _flat(ts)  # dm_control and batched: float64 actions; gymnasium's two: the float32 casts
            worst = max(worst, np.abs(vobs[i] - obs).max(), abs(venv.last_reward[i] - ts.reward),
                        abs(gr - grew[i]), np.abs(go - gv[i]).max() / max(1.0, np.abs(go).max()) * 1e-3)
            if "fatigue" in options:
                worst = max(worst, np.abs(gi["fatigue"] - gvinfo["fatigue"][i]).max())
            if options.get("activation_dynamics"):
                worst = max(worst, np.abs(gi["excitations"] - gvinfo["excitations"][i]).max())
    assert worst <= tol, worst
    venv.close(), gvec.close()


def test_activation_dynamics_lags_the_excitation():
    env = shoulder_bench.load(NAME, seed=1, trajectory=TARGET, activation_dynamics=True)
    env.reset()
    a0 = env.task.activation.copy()
    env.step(np.full(4, 0.01))
    assert np.allclose(env.task.excitation, np.clip(a0 + 0.01, 0, 1))
    u = env.task.excitation
    assert np.abs(env.task.activation - physiology.activation_after(u, a0, protocol.FRAME_S)).max() < 1e-12
    assert ((env.task.activation < u) | (u == a0)).all() and (env.task.activation >= a0).all()


def test_defaults_leave_the_protocol_unchanged():
    acts = np.random.default_rng(3).uniform(-0.01, 0.01, (25, 2, 4))
    plain = shoulder_bench.make_vec(NAME, 2, seed=2, trajectory=TARGET)
    off = shoulder_bench.make_vec(NAME, 2, seed=2, trajectory=TARGET, activation_dynamics=False, fatigue=False,
                                  randomize=None)
    for a in acts:
        plain.step(a), off.step(a)
        assert np.array_equal(plain.observation_array(), off.observation_array())
    assert not off.physiology and off.sim._models[0] is off.sim.model  # the shared model, no per-copy copies


def test_checkpoint_round_trip_with_every_option():
    options = {"activation_dynamics": True, "fatigue": {"F": 0.3}, "randomize": True}
    acts = np.random.default_rng(4).uniform(-0.012, 0.012, (50, 2, 4))
    a = shoulder_bench.make_vec(NAME, 2, seed=9, trajectory=TARGET, **options)
    for x in acts[:20]:
        a.step(x)
    state = a.state_dict()
    b = shoulder_bench.make_vec(NAME, 2, seed=123, trajectory=TARGET, **options)
    b.load_state_dict(state)
    for x in acts[20:]:  # crosses an episode end: the draws' generators were restored too
        a.step(x), b.step(x)
        assert np.array_equal(a.observation_array(), b.observation_array())
    assert np.array_equal(a.fatigue_state, b.fatigue_state) and np.array_equal(a.draw_load, b.draw_load)
    with pytest.raises(ValueError, match="physiology"):
        shoulder_bench.make_vec(NAME, 2, seed=9, trajectory=TARGET).load_state_dict(state)


def _without_actuators():
    spec = mujoco.MjSpec.from_file(str(arm_.MODEL_FILE))
    for act in list(spec.actuators):
        spec.delete(act)
    return spec


def test_the_merged_load_is_a_point_mass_at_the_elbow():
    """The humerus with its mass x 1.1 and a 2 kg load merged into it (randomization.apply) has the mass matrix and
    gravity forces of the model with its mass x 1.1 and a separate 2 kg body at the elbow, at several poses."""
    merged = _without_actuators().compile()
    nom = randomization.Nominal(merged, [])
    randomization.apply(merged, nom, {"strength": np.ones(0), "mass_scale": 1.1, "load_kg": 2.0})
    spec = _without_actuators()
    spec.body(randomization.BODY).add_body(pos=randomization.ELBOW_IN_HUMERUS, ipos=[0, 0, 0], mass=2.0,
                                               inertia=[1e-12] * 3)
    two = spec.compile()
    two.body_mass[nom.body], two.body_inertia[nom.body] = 1.1 * nom.mass, 1.1 * nom.inertia
    assert two.nbody == merged.nbody + 1 and merged.body_mass[nom.body] == pytest.approx(1.1 * nom.mass + 2.0)
    for q in (0.2, 0.9, 1.7):
        out = []
        for model in (merged, two):
            d = mujoco.MjData(model)
            d.qpos[:] = arm_.arm().qpos(q)[0]
            d.qvel[:] = 0.3
            mujoco.mj_forward(model, d)
            full = np.zeros((model.nv, model.nv))
            mujoco.mj_fullM(model, d, full)
            out.append((full, d.qfrc_bias.copy()))
        assert np.abs(out[0][0] - out[1][0]).max() < 1e-9
        assert np.abs(out[0][1] - out[1][1]).max() < 1e-9
    nominal = _without_actuators().compile()
    randomization.apply(nominal, randomization.Nominal(nominal, []), None)  # the nominal arm: nothing changes
    assert np.array_equal(nominal.body_inertia, _without_actuators().compile().body_inertia)


def test_physics_only_model_has_the_same_physics():
    a = arm_.compile_arm()
    b = compile_model(xml=randomization.physics_only_xml(arm_.MODEL_FILE), prepare=arm_.harden_couplings)
    for key in ("body_mass", "body_inertia", "body_ipos", "body_iquat", "jnt_range", "eq_data", "dof_invweight0",
                "actuator_user", "actuator_gear", "tendon_range", "wrap_prm", "site_pos", "geom_size"):
        assert np.array_equal(getattr(a, key), getattr(b, key)), key
    assert a.opt.timestep == b.opt.timestep and b.ntex == 0


@pytest.mark.parametrize("options,message", [
    ({"randomize": "strength=2"}, "strength must be a number in"),
    ({"randomize": "mass=0.1,weight=3"}, "unknown key"),
    ({"randomize": "load=2:1"}, "lo 2 > hi 1"),
    ({"randomize": "load=heavy"}, "is not a number"),
    ({"randomize": 3}, "randomize must be"),
    ({"fatigue": {"F": -1}}, "fatigue F must be"),
    ({"fatigue": {"x": 1}}, "unknown parameter"),
    ({"fatigue": "yes"}, "fatigue must be"),
    ({"activation_dynamics": 1}, "activation_dynamics must be"),
])
def test_bad_values_name_the_option(options, message):
    with pytest.raises(ValueError, match=message):
        shoulder_bench.tasks.check_options(NAME, **options)


def test_tasks_options_lists_them(capsys):
    main(["tasks", "--options"])
    out = capsys.readouterr().out
    for name in ("activation_dynamics", "randomize", "fatigue"):
        assert name in out


def test_both_engines_take_one_activation_per_physics_step():
    from shoulder_bench.simulator import BatchSimulator

    law = arm_.arm().load_law("fem", arm_.MUSCLES)
    sims = [BatchSimulator(law, 2, path=arm_.MODEL_FILE, prepare=arm_.harden_couplings, engine=e)
            for e in ("numpy", "mujoco")]
    qpos, qvel = arm_.arm().qpos(np.radians([40.0, 70.0])), np.zeros((2, sims[0].nv))
    acts = np.random.default_rng(1).uniform(0.0, 0.4, (2, sims[0].steps_per_frame, 4))
    ends = [s.frame_state(qpos, qvel, acts)[0] for s in sims]
    assert np.abs(ends[0] - ends[1]).max() < 1e-9
    held = sims[1].frame_state(qpos, qvel, acts[:, :1].repeat(2, axis=1))[0]
    assert np.abs(held - sims[1].frame_state(qpos, qvel, acts[:, 0])[0]).max() == 0.0  # (N, n) = every step alike
    assert np.abs(held - ends[1]).max() > 1e-6  # the per-step rows are used
    with pytest.raises(ValueError, match="expected"):
        sims[0].frame_state(qpos, qvel, acts[:, :1])
