"""The batched environment: equal to the single env, auto-reset, per-copy crashes, rsl-rl shapes, bench command."""
import gymnasium as gym
import numpy as np
import pytest
import torch

import shoulder_bench
from shoulder_bench import protocol
from shoulder_bench.cli import main


def _flat(ts):
    return np.concatenate([np.ravel(ts.observation[k]) for k in protocol.OBSERVATION_KEYS])


@pytest.mark.parametrize("name", ["abduction_4m", "abduction_ssp_discrete"])
def test_batched_equals_single(name):
    """Copy i of the batch = the single env seeded seed + i. Tolerance 1e-6 deg: the batch steps with MuJoCo's RK4
    one rollout per frame, each frame starting the constraint solver from a zero warmstart (rollout cannot carry it
    across calls), while mj_step carries it; where a constraint is active (the arm on its joint limit) the solver
    stops at its tolerance on either path (measured: up to 8e-9 deg)."""
    n_env, seed, tol = 3, 21, 1e-6
    venv = shoulder_bench.make_vec(name, n_env, seed=seed)
    envs = [shoulder_bench.load(name, seed=seed + i) for i in range(n_env)]
    steps = [e.reset() for e in envs]
    assert np.abs(venv.observation_array() - np.array([_flat(t) for t in steps])).max() <= 1e-9
    rng = np.random.default_rng(0)
    ended = 0
    for _ in range(230):  # crosses the 100-frame episode boundary twice: auto-reset included
        if venv.discrete:
            a = rng.integers(0, 21, (n_env, venv.num_actions))
        else:
            a = rng.uniform(-0.012, 0.012, (n_env, venv.num_actions))
        venv.step(torch.as_tensor(a))
        obs = venv.observation_array()
        for i, env in enumerate(envs):
            ts = env.step(a[i] if venv.num_actions > 1 or not venv.discrete else a[i, 0])
            assert abs(ts.reward - venv.last_reward[i]) <= tol
            if ts.last():
                ended += 1
                ts = env.reset()
            assert np.abs(_flat(ts) - obs[i]).max() <= tol
    assert ended == 2 * n_env
    venv.close()


def test_tensordict_shapes_dtypes_and_time_outs():
    venv = shoulder_bench.make_vec("abduction_4m", 5, seed=0)
    obs = venv.get_observations()
    assert set(obs.keys()) == {"policy", "critic"} and obs["policy"].shape == (5, 8)
    assert obs["policy"].dtype == torch.float32
    for _ in range(100):
        obs, rew, done, extras = venv.step(torch.zeros(5, 4))
        assert rew.shape == (5,) and done.shape == (5,) and extras["time_outs"].dtype == torch.bool
    assert bool(done.all()) and bool(extras["time_outs"].all())  # the 10 s train episodes end together
    assert "/episode/return" in extras["log"] and extras["log"]["/episode/length"] == 100
    assert int(venv.episode_length_buf.max()) == 0  # reset


def test_auto_reset_starts_a_fresh_trajectory():
    venv = shoulder_bench.make_vec("abduction_ssp", 2, seed=4)
    first = venv.targets.copy()
    for _ in range(100):
        venv.step(torch.zeros(2, 1))
    assert not np.allclose(first, venv.targets)
    assert np.allclose(np.degrees(venv.q), venv.targets[:, 0]) and np.all(venv.frames == 0)


def test_crash_in_one_copy_leaves_the_others_running():
    venv = shoulder_bench.make_vec("abduction_4m", 3, seed=0)
    venv.step(torch.zeros(3, 4))
    venv.v[1] = 1e4  # copy 1 blows up
    _, rew, done, extras = venv.step(torch.zeros(3, 4))
    assert done.tolist() == [0, 1, 0] and not bool(extras["time_outs"][1])
    assert float(rew[1]) == pytest.approx(-protocol.CRASH_ERROR_DEG * (100 - 2 + 1))
    assert extras["log"]["/episode/crash_rate"] == 1.0
    assert venv.frames.tolist() == [2, 0, 2]


def test_bad_batched_action_changes_nothing():
    venv = shoulder_bench.make_vec("abduction_4m", 2, seed=0)
    before = venv.observation_array().copy()
    for bad in (torch.full((2, 4), float("nan")), torch.zeros(3, 4)):
        with pytest.raises(ValueError):
            venv.step(bad)
    assert np.array_equal(before, venv.observation_array())


def test_gymnasium_vector_env():
    envs = gym.make_vec("ShoulderBench/abduction_4m-v0", num_envs=2, vectorization_mode="sync")
    obs, _ = envs.reset(seed=0)
    obs, rew, term, trunc, info = envs.step(envs.action_space.sample())
    assert obs.shape == (2, 8) and rew.shape == (2,)


def test_bench_quick(capsys):
    assert main(["bench", "--quick", "--json"]) == 0
    out = capsys.readouterr().out
    assert "bare MuJoCo" in out and '"gym_sim_s_per_s"' in out.splitlines()[-1]


@pytest.mark.parametrize("kw,message", [({"seed": "abc"}, "seed must be None or an integer"),
                                        ({"seed": True}, "seed must be None or an integer"),
                                        ({"num_envs": 2.5}, "num_envs must be an integer >= 1")])
def test_bad_seed_or_count_is_a_clear_error(kw, message):
    with pytest.raises(ValueError, match=message):
        shoulder_bench.make_vec("abduction_4m", **{"num_envs": 2} | kw)


def test_make_vec_names_its_backends():
    import shoulder_bench

    with pytest.raises(ValueError, match="backend must be 'mujoco' or 'mjx'.*float32"):
        shoulder_bench.make_vec("abduction_4m", 2, backend="warp")
    with pytest.raises(ValueError, match="backend must be 'mujoco' or 'mjx', got 'jax'$"):
        shoulder_bench.make_vec("abduction_4m", 2, backend="jax")
    with pytest.raises(ValueError, match="MJX backend runs the 1-DOF tasks"):  # before it needs jax
        shoulder_bench.make_vec("track_3dof", 2, backend="mjx")
    with pytest.raises(KeyError, match="unknown task"):
        shoulder_bench.make_vec("track_3dog", 2, backend="mjx")


@pytest.mark.parametrize("name", ["abduction_4m", "track_3dof"])
def test_step_is_advance_plus_the_observation(name):
    """rsl-rl's step (TensorDict, float32 rewards, dones) and the array path evaluation uses (`advance`,
    `observation_array`) give the same frames, auto-resets included."""
    a, b = shoulder_bench.make_vec(name, 3, seed=2), shoulder_bench.make_vec(name, 3, seed=2)
    gen = torch.Generator().manual_seed(0)
    for _ in range(a.max_episode_length + 2):  # past every copy's first episode
        act = torch.rand(3, a.num_actions, generator=gen) * 0.02 - 0.01
        obs, reward, done, extras = a.step(act)
        r, d, e = b.advance(act)
        np.testing.assert_array_equal(obs["policy"].numpy(), b.observation_array().astype(np.float32))
        np.testing.assert_array_equal(reward.numpy(), r.astype(np.float32))
        assert done.dtype == a.DONE_DTYPE and (done.numpy().astype(bool) == d).all()
        assert (extras["time_outs"] == e["time_outs"]).all()
    assert d.dtype == bool
    a.close()
    b.close()


def test_evaluation_imports_no_tensordict():
    """`eval` steps the copies with `advance` and reads `observation_array`: tensordict (which imports
    torch._dynamo, about 1.4 s of start-up) stays unimported; training imports it on its first step."""
    import subprocess
    import sys

    code = ("import sys; from shoulder_bench.eval.evaluate import evaluate, policy_for, trajectories_for\n"
            "p, meta, task = policy_for('pretrained:ppo_4m')\n"
            "m = evaluate(p, task, trajectories_for('test')[:2])\n"
            "assert 'tensordict' not in sys.modules, 'evaluation imported tensordict'\n"
            "import shoulder_bench, torch\n"
            "shoulder_bench.make_vec(task, 1).step(torch.zeros(1, 4))\n"
            "assert 'tensordict' in sys.modules\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
