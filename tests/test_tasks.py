"""Tasks by name through dm_control and gymnasium: protocol, reward, determinism, bad input, crashes."""
import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import shoulder_bench
from shoulder_bench import arm, protocol

TASKS = ["abduction_ssp", "abduction_ssp_discrete", "abduction_4m", "abduction_4m_discrete"]


def test_names_and_unknown_name():
    assert shoulder_bench.list_tasks()[:4] == TASKS  # the 3-DOF tasks follow (tests/test_tasks_3dof.py)
    with pytest.raises(KeyError, match="abduction_4m"):
        shoulder_bench.load("abduction_4mm")


def test_tasks_command_lists_every_task_by_name(capsys):
    """`shoulder-bench tasks` prints one line per loadable task, the full shoulder's 3-DOF tasks included."""
    from shoulder_bench.cli import main

    assert main(["tasks"]) == 0
    listed = [line.split()[0] for line in capsys.readouterr().out.splitlines()]
    assert listed == shoulder_bench.list_tasks() and "track_3dof" in listed and "abduction_4m" in listed


@pytest.mark.parametrize("name", TASKS)
def test_protocol(name):
    env = shoulder_bench.load(name, split="train", seed=0)
    assert env.control_timestep() == pytest.approx(0.1)
    n = 4 if "4m" in name else 1
    spec = env.action_spec()
    if "discrete" in name:
        assert spec.dtype == np.int64 and int(np.max(spec.maximum)) == 20
    else:
        assert spec.shape == (n,) and np.allclose(spec.minimum, -0.01) and np.allclose(spec.maximum, 0.01)
    ts = env.reset()
    assert set(ts.observation) == set(protocol.OBSERVATION_KEYS) and ts.observation["activations"].shape == (n,)
    steps = 0
    while not ts.last():
        ts = env.step(np.zeros(n) if "discrete" not in name else np.full(spec.shape, 10))
        steps += 1
    assert steps == 100 and ts.discount == 1.0  # 10 s train episode ends by time, not as a terminal state


def test_test_split_is_20_s():
    env = shoulder_bench.load("abduction_ssp", split="test", seed=0)
    env.reset()
    assert env.task.target.frames == 200
    assert np.all((env.task.target.angle_deg[::50] >= 20) & (env.task.target.angle_deg[::50] <= 100))


def test_observation_and_reward_by_hand():
    env = shoulder_bench.load("abduction_4m", split="train", seed=2, alpha=0.5, omega_max=0.005)
    ts = env.reset()
    task, physics = env.task, env.physics
    a0 = physics.activations(task.muscles).copy()
    action = np.array([0.004, -0.02, 0.008, 0.0])  # second entry out of range: clipped, but penalised as sent
    ts = env.step(action)
    applied = np.clip(a0 + np.clip(action, -0.01, 0.01), 0, 1)
    assert np.allclose(ts.observation["activations"], applied)
    phi = float(np.degrees(physics.named.data.qpos[arm.JOINT][0]))  # the elevation joint, by name
    assert ts.observation["angle"][0] == pytest.approx(phi)
    assert ts.observation["angular_velocity"][0] == pytest.approx(np.degrees(physics.named.data.qvel[arm.JOINT][0]))
    assert ts.observation["target_angle"][0] == task.target.angle_deg[2]  # phi_hat(t + 1) with t = 1
    assert ts.observation["target_velocity"][0] == task.target.velocity_deg_s[2]
    expected = (-abs(phi - task.target.angle_deg[1]) - 0.5 * 100 * (0.004 + 0.02 + 0.008)
                - (1 / 4) * (0 + 1 + 1 + 0))
    assert ts.reward == pytest.approx(expected, rel=1e-12)


def test_single_muscle_reward_is_tracking_only():
    env = shoulder_bench.load("abduction_ssp", seed=1)
    env.reset()
    ts = env.step(np.array([0.01]))
    assert ts.reward == pytest.approx(-abs(ts.observation["angle"][0] - env.task.target.angle_deg[1]))


def test_discrete_levels():
    assert np.allclose(protocol.level_to_delta(np.arange(21)), np.linspace(-0.01, 0.01, 21))
    env = shoulder_bench.load("abduction_4m_discrete", seed=0)
    env.reset()
    a0 = env.physics.activations(env.task.muscles).copy()
    ts = env.step(np.array([20, 10, 15, 0]))
    assert np.allclose(ts.observation["activations"], np.clip(a0 + [0.01, 0, 0.005, -0.01], 0, 1))


def _roll(name, seed, actions):
    env = shoulder_bench.load(name, split="test", seed=seed)
    ts = env.reset()
    out = []
    for a in actions:
        ts = env.step(a)
        out.append(np.concatenate([np.ravel(v) for v in ts.observation.values()] + [[ts.reward]]))
    return np.array(out)


def test_same_seed_same_episode_other_seed_other_episode():
    acts = np.random.default_rng(0).uniform(-0.01, 0.01, (40, 4))
    a, b, c = _roll("abduction_4m", 5, acts), _roll("abduction_4m", 5, acts), _roll("abduction_4m", 6, acts)
    assert np.array_equal(a, b) and not np.array_equal(a, c)


@pytest.mark.parametrize("name", ["abduction_ssp", "abduction_4m"])
@pytest.mark.parametrize("bad", ["nan", "inf", "shape", "string"])
def test_bad_action_raises_and_changes_nothing(name, bad):
    n = 4 if "4m" in name else 1
    good = np.full(n, 0.004)
    e1, e2 = shoulder_bench.load(name, split="test", seed=3), shoulder_bench.load(name, split="test", seed=3)
    e1.reset(), e2.reset()
    e1.step(good), e2.step(good)
    action = {"nan": np.full(n, np.nan), "inf": np.full(n, np.inf), "shape": np.zeros(n + 2),
              "string": np.array(["a"] * n)}[bad]
    with pytest.raises(ValueError, match=rf"\({n},\)|{n} numbers"):
        e1.step(action)
    t1, t2 = e1.step(good), e2.step(good)
    assert all(np.array_equal(t1.observation[k], t2.observation[k]) for k in t1.observation)
    assert t1.reward == t2.reward


def test_bad_discrete_action():
    env = shoulder_bench.load("abduction_4m_discrete", seed=0)
    env.reset()
    for bad in (np.array([21, 0, 0, 0]), np.array([0.5, 0, 0, 0]), np.array([1, 2])):
        with pytest.raises(ValueError, match="0..20"):
            env.step(bad)


def test_crash_ends_episode_with_penalty_not_exception():
    env = shoulder_bench.load("abduction_4m", split="train", seed=0)
    env.reset()
    env.step(np.zeros(4))
    env.physics.data.qvel[0] = 1e4  # a blow-up: the arm leaves the model's range within the frame
    ts = env.step(np.zeros(4))
    assert ts.last() and ts.discount == 0.0 and env.physics.failed()
    assert ts.reward == pytest.approx(-protocol.CRASH_ERROR_DEG * (100 - 2 + 1))
    assert not env.step(np.zeros(4)).last()  # the next step starts a new episode


def test_trajectory_from_csv_and_array(tmp_path):
    p = tmp_path / "t.csv"
    t = np.arange(0, 5.0001, 0.02)
    p.write_text("time_s,angle_deg\n" + "".join(f"{a:.2f},{40 + 20 * np.sin(a):.4f}\n" for a in t))
    env = shoulder_bench.load("abduction_4m", trajectory=p, seed=0)
    ts, n = env.reset(), 0
    while not ts.last():
        ts, n = env.step(np.zeros(4)), n + 1
    assert n == 50
    env = shoulder_bench.load("abduction_ssp", trajectory=np.linspace(30, 60, 31))
    assert env.reset().observation["angle"][0] == pytest.approx(30.0)


@pytest.mark.parametrize("name", TASKS)
def test_gymnasium(name):
    env = gym.make(f"ShoulderBench/{name}-v0")
    check_env(env.unwrapped, skip_render_check=True)
    obs, info = env.reset(seed=4)
    obs2, _ = env.reset(seed=4)
    assert np.array_equal(obs, obs2)
    obs, r, term, trunc, info = env.step(env.action_space.sample())
    assert {"angle_deg", "target_deg", "activations", "crashed"} <= set(info)
    assert obs.dtype == np.float32 and env.observation_space.contains(obs)


def test_gymnasium_options_pass_through():
    env = gym.make("ShoulderBench/abduction_ssp-v0", split="test")
    env.reset(seed=0)
    assert env.unwrapped.task.target.frames == 200


def test_gymnasium_rgb_array_render_is_not_blank():
    env = gym.make("ShoulderBench/abduction_4m-v0", render_mode="rgb_array")
    env.reset(seed=0)
    img = env.render()
    assert img.shape == (480, 640, 3) and img.dtype == np.uint8 and img.std() > 10


@pytest.mark.parametrize("wrapped", [False, True])
def test_gymnasium_step_after_the_end_raises_reset_needed(wrapped):
    env = gym.make("ShoulderBench/abduction_ssp-v0", trajectory=np.linspace(30, 31, 3))
    env = env if wrapped else env.unwrapped
    if not wrapped:
        with pytest.raises(gym.error.ResetNeeded, match="reset"):
            env.step(np.zeros(1, np.float32))  # before the first reset
    env.reset(seed=0)
    assert env.step(np.zeros(1, np.float32))[3] is False
    assert env.step(np.zeros(1, np.float32))[3] is True  # truncated: the 2-frame target is done
    with pytest.raises(gym.error.ResetNeeded, match="call reset"):
        env.step(np.zeros(1, np.float32))
    env.reset()
    obs, r, term, trunc, _ = env.step(np.zeros(1, np.float32))
    assert np.isfinite(r) and not term and not trunc


def test_gymnasium_observation_bounds_are_finite_where_known():
    space = gym.make("ShoulderBench/abduction_4m-v0").observation_space
    lo, hi = arm.RANGE_DEG
    m = arm.VALID_MARGIN_DEG
    assert np.allclose(space.low[[0, 2]], [lo - m, lo]) and np.allclose(space.high[[0, 2]], [hi + m, hi])
    assert np.all(space.low[4:] == 0) and np.all(space.high[4:] == 1)
    assert np.all(np.isinf(space.low[[1, 3]])) and np.all(np.isinf(space.high[[1, 3]]))


def test_gymnasium_crash_observation_stays_in_the_space():
    env = gym.make("ShoulderBench/abduction_4m-v0").unwrapped
    env.reset(seed=0)
    physics = env.env.physics
    top = arm.RANGE_DEG[1] + arm.VALID_MARGIN_DEG
    physics.named.data.qpos[arm.JOINT] = np.radians(top + 20.0)  # far outside the model's range
    obs, r, term, trunc, info = env.step(np.zeros(4, np.float32))
    assert term and info["crashed"] and info["angle_deg"] > top
    assert env.observation_space.contains(obs) and obs[0] == pytest.approx(top)


def test_gymnasium_vector_entry_point_equals_the_single_env():
    """make_vec's fast path: numpy batches, SAME_STEP autoreset, copy i = the single env reset with seed + i."""
    from gymnasium.vector import AutoresetMode

    n, seed = 4, 7
    envs = gym.make_vec("ShoulderBench/abduction_4m-v0", num_envs=n, vectorization_mode="vector_entry_point")
    assert type(envs.unwrapped).__name__ == "ShoulderVectorEnv"
    assert envs.metadata["autoreset_mode"] == AutoresetMode.SAME_STEP
    singles = [gym.make("ShoulderBench/abduction_4m-v0") for _ in range(n)]
    obs, info = envs.reset(seed=seed)
    first = np.array([e.reset(seed=seed + i)[0] for i, e in enumerate(singles)])
    assert obs.shape == (n, 8) and obs.dtype == np.float32 and np.allclose(obs, first, rtol=0, atol=1e-4)
    actions = np.random.default_rng(0).uniform(-0.012, 0.012, (100, n, 4)).astype(np.float32)
    for a in actions:
        obs, rew, term, trunc, info = envs.step(a)
        assert envs.observation_space.contains(obs) and rew.dtype == np.float64
        for i, env in enumerate(singles):
            o, r, te, tr, inf = env.step(a[i])
            assert r == pytest.approx(rew[i], abs=1e-7) and (te, tr) == (term[i], trunc[i])
            if tr:
                assert info["_final_obs"][i] and np.allclose(info["final_obs"][i], o, rtol=0, atol=1e-4)
                assert info["final_info"]["angle_deg"][i] == pytest.approx(inf["angle_deg"], abs=1e-7)
                assert info["final_info"]["target_deg"][i] == pytest.approx(inf["target_deg"], abs=1e-9)
                o, inf = env.reset()  # the vector env has auto-reset this copy in the same step
            else:
                assert "final_obs" not in info
            assert np.allclose(obs[i], o, rtol=0, atol=1e-4)
            assert info["angle_deg"][i] == pytest.approx(inf["angle_deg"], abs=1e-7)
            assert info["target_deg"][i] == pytest.approx(inf["target_deg"], abs=1e-9)
    assert trunc.all() and not term.any()  # the 10 s train episodes end together, by time
    envs.close()


def test_gymnasium_vector_env_discrete_and_options():
    envs = gym.make_vec("ShoulderBench/abduction_ssp_discrete-v0", num_envs=3, split="test")
    assert type(envs.unwrapped).__name__ == "ShoulderVectorEnv"  # the default vectorization for these ids
    obs, _ = envs.reset(seed=0)
    obs, rew, term, trunc, _ = envs.step(np.array([0, 10, 20]))
    assert obs.shape == (3, 5) and rew.shape == (3,) and np.all(np.isfinite(rew))
    assert envs.unwrapped.batched.max_episode_length == 200
    with pytest.raises(ValueError, match="seed must be None or an integer"):
        envs.reset(seed="x")
    envs.close()


def test_gymnasium_reset_with_a_bad_seed():
    env = gym.make("ShoulderBench/abduction_ssp-v0")
    with pytest.raises(ValueError, match=r"seed must be None or an integer .*; got 'abc'"):
        env.reset(seed="abc")
