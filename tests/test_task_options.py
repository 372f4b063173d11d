"""The sensing options (issue 14 §1): `delay_frames` and `obs_noise_deg` in the dm_control, gymnasium, gymnasium
vector and batched envs alike; defaults leave the paper's protocol unchanged."""
import copy
import io
import re

import gymnasium as gym
import numpy as np
import pytest
import torch

import shoulder_bench
from shoulder_bench import protocol
from shoulder_bench.cli import main

TARGET = 40 + 25 * np.sin(np.linspace(0, 3, 31))  # 30 frames: episodes end and restart within a test
OPTIONS = [{"delay_frames": 3}, {"obs_noise_deg": 0.7}, {"delay_frames": 2, "obs_noise_deg": 0.4}]


def _flat(ts):
    return np.concatenate([np.ravel(ts.observation[k]) for k in protocol.OBSERVATION_KEYS])


def _actions(name, steps, n_env, seed=0):
    rng = np.random.default_rng(seed)
    if "discrete" in name:
        return rng.integers(0, protocol.LEVELS, (steps, n_env, 4 if "4m" in name else 1))
    return rng.uniform(-0.012, 0.012, (steps, n_env, 4 if "4m" in name else 1))


def _single_action(name, a):
    return a[0] if "discrete" in name and a.shape == (1,) else a


def _roll_single(name, seed, actions, **options):
    """(observations, rewards, last flags) of one dm_control env over `actions` (T, n), reset after each end."""
    env = shoulder_bench.load(name, seed=seed, **options)
    obs, rew, last = [_flat(env.reset())], [], []
    for a in actions:
        ts = env.step(_single_action(name, a))
        obs.append(_flat(ts)), rew.append(ts.reward), last.append(ts.last())
        if ts.last():
            obs.append(_flat(env.reset()))
    return obs, np.array(rew), last


@pytest.mark.parametrize("options", OPTIONS, ids=lambda o: ",".join(f"{k}={v}" for k, v in o.items()))
@pytest.mark.parametrize("name,trajectory", [("abduction_4m", TARGET), ("abduction_ssp_discrete", None)])
def test_single_batched_and_gymnasium_agree(name, trajectory, options):
    n_env, seed, steps = 3, 11, 70 if trajectory is not None else 205
    acts = _actions(name, steps, n_env)
    venv = shoulder_bench.make_vec(name, n_env, seed=seed, trajectory=trajectory, **options)
    gvec = gym.make_vec(f"ShoulderBench/{name}-v0", num_envs=n_env, trajectory=trajectory, **options)
    gobs, ginfo = gvec.reset(seed=seed)
    singles = [_roll_single(name, seed + i, acts[:, i], trajectory=trajectory, **options) for i in range(n_env)]
    gyms = [gym.make(f"ShoulderBench/{name}-v0", trajectory=trajectory, **options) for _ in range(n_env)]
    gfirst = [g.reset(seed=seed + i) for i, g in enumerate(gyms)]
    pos = [0] * n_env  # index into each single env's observation list
    for i in range(n_env):
        assert np.abs(venv.observation_array()[i] - singles[i][0][0]).max() <= 1e-9
        assert np.array_equal(gobs[i], gfirst[i][0])  # the same float64 observation cast to float32
    ended = 0
    for t, a in enumerate(acts):
        venv.step(torch.as_tensor(a))
        gobs, grew, gterm, gtrunc, ginfo = gvec.step(a)
        obs = venv.observation_array()
        for i in range(n_env):
            s_obs, s_rew, s_last = singles[i]
            pos[i] += 1
            assert abs(s_rew[t] - venv.last_reward[i]) <= 1e-9 and abs(grew[i] - s_rew[t]) <= 1e-9
            o, r, te, tr, inf = gyms[i].step(_single_action(name, a[i]))
            assert (te or tr) == s_last[t] and (te, tr) == (gterm[i], gtrunc[i])
            if s_last[t]:
                ended += 1
                assert np.abs(venv.last_final_obs[i] - s_obs[pos[i]]).max() <= 1e-9  # the episode's last obs
                assert np.allclose(ginfo["final_obs"][i], o, rtol=0, atol=1e-4)
                pos[i] += 1
                o, inf = gyms[i].reset()
            assert np.abs(obs[i] - s_obs[pos[i]]).max() <= 1e-9
            assert np.allclose(gobs[i], o, rtol=0, atol=1e-4)
            assert inf["angle_deg"] == pytest.approx(ginfo["angle_deg"][i], abs=1e-7)
            assert inf["target_deg"] == pytest.approx(ginfo["target_deg"][i], abs=1e-9)
    assert ended >= 2 * n_env  # auto-reset and final observations are covered
    venv.close(), gvec.close()


def _twins(name, seed, **options):
    return shoulder_bench.load(name, seed=seed, **options), shoulder_bench.load(name, seed=seed)


@pytest.mark.parametrize("k", [1, 4])
def test_delay_shows_exactly_the_state_k_frames_back(k):
    name, n = "abduction_4m", 4
    late, now = _twins(name, 5, delay_frames=k)
    acts = _actions(name, 40, 1)[:, 0]
    seen, truth = [_flat(late.reset())], [_flat(now.reset())]
    for a in acts:
        seen.append(_flat(late.step(a))), truth.append(_flat(now.step(a)))
    seen, truth = np.array(seen), np.array(truth)
    sensed = [0, 1] + list(range(4, 4 + n))  # angle, velocity, activations
    for t in range(len(seen)):
        assert np.array_equal(seen[t, sensed], truth[max(t - k, 0), sensed])
        assert np.array_equal(seen[t, [2, 3]], truth[t, [2, 3]])  # the target terms stay current
    assert not np.array_equal(seen[k + 1:, 0], truth[k + 1:, 0])  # the arm does move: the test sees the delay
    # the batched env: the same against its own undelayed twin, copy by copy
    vl, vn = shoulder_bench.make_vec(name, 2, seed=5, delay_frames=k), shoulder_bench.make_vec(name, 2, seed=5)
    hist = [vn.observation_array()]
    for t, a in enumerate(_actions(name, 20, 2)):
        vl.step(torch.as_tensor(a)), vn.step(torch.as_tensor(a))
        hist.append(vn.observation_array())
        assert np.array_equal(vl.observation_array()[:, sensed], hist[max(t + 1 - k, 0)][:, sensed])
        assert np.array_equal(vl.observation_array()[:, [2, 3]], hist[-1][:, [2, 3]])
        assert np.array_equal(vl.last_reward, vn.last_reward)  # the reward sees the arm now


def test_noise_has_the_given_sigma_and_leaves_rewards_and_info_true():
    sigma, name, n_env = 0.5, "abduction_4m", 16
    noisy = shoulder_bench.make_vec(name, n_env, seed=3, obs_noise_deg=sigma)
    clean = shoulder_bench.make_vec(name, n_env, seed=3)
    d = [noisy.observation_array() - clean.observation_array()]
    for a in _actions(name, 30, n_env):
        noisy.step(torch.as_tensor(a)), clean.step(torch.as_tensor(a))
        assert np.array_equal(noisy.last_reward, clean.last_reward)
        d.append(noisy.observation_array() - clean.observation_array())
    d = np.concatenate(d)
    assert np.all(d[:, 2:] == 0)  # targets and activations carry no noise
    z = d[:, :2] / sigma  # angle (deg) and velocity (deg/s), each sigma
    assert np.allclose(z.std(axis=0), 1.0, atol=0.08) and np.all(np.abs(z.mean(axis=0)) < 4 / np.sqrt(len(z)))
    assert abs(np.corrcoef(z.T)[0, 1]) < 0.15  # independent draws
    env = gym.make("ShoulderBench/abduction_4m-v0", obs_noise_deg=2.0)
    obs, info = env.reset(seed=0)
    assert info["angle_deg"] == pytest.approx(env.unwrapped.env.physics.angle_deg())  # info: the true angle
    assert abs(obs[0] - info["angle_deg"]) > 1e-3


@pytest.mark.parametrize("name", ["abduction_4m", "abduction_ssp_discrete"])
def test_defaults_and_zero_leave_the_protocol_unchanged(name):
    acts = _actions(name, 40, 1)[:, 0]
    base = _roll_single(name, 8, acts)
    for zero in ({"delay_frames": 0}, {"obs_noise_deg": 0.0}, {"delay_frames": 0, "obs_noise_deg": 0}):
        other = _roll_single(name, 8, acts, **zero)
        assert all(np.array_equal(a, b) for a, b in zip(base[0], other[0])) and np.array_equal(base[1], other[1])
    env = shoulder_bench.load(name, seed=8)
    ts, physics = env.reset(), env.physics
    for a in acts[:5]:  # the default observation is the state now, read straight from the physics
        ts = env.step(_single_action(name, a))
        assert ts.observation["angle"][0] == physics.angle_deg()
        assert ts.observation["angular_velocity"][0] == physics.angular_velocity_deg()
        assert np.array_equal(ts.observation["activations"], physics.activations(env.task.muscles))
    v0, v1 = shoulder_bench.make_vec(name, 2, seed=8), shoulder_bench.make_vec(name, 2, seed=8, obs_noise_deg=0.0)
    for a in _actions(name, 5, 2):
        v0.step(torch.as_tensor(a)), v1.step(torch.as_tensor(a))
        assert np.array_equal(v0.observation_array(), v1.observation_array())
        assert np.array_equal(v0.observation_array()[:, 0], np.degrees(v0.q))


BAD = [("delay_frames", -1), ("delay_frames", 11), ("delay_frames", 2.0), ("delay_frames", True),
       ("delay_frames", "1"), ("delay_frames", None), ("obs_noise_deg", -0.1), ("obs_noise_deg", float("nan")),
       ("obs_noise_deg", float("inf")), ("obs_noise_deg", "0.5"), ("obs_noise_deg", True)]
WANTED = {"delay_frames": r"delay_frames must be an integer in \[0, 10\]; got",
          "obs_noise_deg": r"obs_noise_deg must be a finite number >= 0; got"}


@pytest.mark.parametrize("key,value", BAD)
def test_bad_values_name_the_option(key, value):
    makers = [lambda: shoulder_bench.load("abduction_4m", **{key: value}),
              lambda: shoulder_bench.make_vec("abduction_4m", 2, **{key: value}),
              lambda: gym.make("ShoulderBench/abduction_4m-v0", **{key: value}),
              lambda: gym.make_vec("ShoulderBench/abduction_4m-v0", num_envs=2, **{key: value})]
    for make in makers:
        with pytest.raises(ValueError, match=WANTED[key]):
            make()


def test_numpy_integers_and_the_largest_delay_are_accepted():
    env = shoulder_bench.load("abduction_ssp", seed=0, delay_frames=np.int64(10), obs_noise_deg=np.float32(1))
    assert env.task.delay_frames == 10 and type(env.task.delay_frames) is int and env.task.obs_noise_deg == 1.0


@pytest.mark.parametrize("options", OPTIONS, ids=lambda o: ",".join(f"{k}={v}" for k, v in o.items()))
def test_checkpoint_round_trip_continues_identically(options):
    name, n_env = "abduction_4m", 3
    acts = _actions(name, 60, n_env, seed=1)
    a = shoulder_bench.make_vec(name, n_env, seed=2, trajectory=TARGET, **options)
    for x in acts[:17]:
        a.step(torch.as_tensor(x))
    buf = io.BytesIO()
    torch.save(a.state_dict(), buf)  # as train.run saves it
    buf.seek(0)
    state = torch.load(buf, weights_only=False)
    b = shoulder_bench.make_vec(name, n_env, seed=99, trajectory=TARGET, **options)  # other draws until restored
    b.load_state_dict(copy.deepcopy(state))
    assert np.array_equal(a.observation_array(), b.observation_array())
    for x in acts[17:]:  # crosses episode ends: auto-reset draws from the restored generators
        _, ra, da, _ = a.step(torch.as_tensor(x))
        _, rb, db, _ = b.step(torch.as_tensor(x))
        assert np.array_equal(a.observation_array(), b.observation_array())
        assert np.array_equal(a.last_reward, b.last_reward) and torch.equal(da, db)
    other = {"delay_frames": 1} if "delay_frames" not in options else {}
    c = shoulder_bench.make_vec(name, n_env, seed=2, trajectory=TARGET, **other)
    with pytest.raises(ValueError, match="delay_frames=.*obs_noise_deg=.*cannot be restored"):
        c.load_state_dict(state)


def test_a_state_saved_before_the_options_still_loads_with_defaults():
    a = shoulder_bench.make_vec("abduction_ssp", 2, seed=0)
    a.step(torch.zeros(2, 1))
    old = {k: v for k, v in a.state_dict().items()
           if k not in ("delay_frames", "obs_noise_deg", "noise_rngs", "obs_history", "noise_z")}
    b = shoulder_bench.make_vec("abduction_ssp", 2, seed=5)
    b.load_state_dict(old)
    assert np.array_equal(a.observation_array(), b.observation_array())
    with pytest.raises(ValueError, match="cannot be restored"):
        shoulder_bench.make_vec("abduction_ssp", 2, obs_noise_deg=0.1).load_state_dict(old)


def test_tasks_options_lists_every_option_with_its_default(capsys):
    from shoulder_bench.tasks.options import OPTIONS as ALL

    assert main(["tasks", "--options"]) == 0
    out = capsys.readouterr().out
    for key in ALL:
        assert any(line.startswith(key + " ") and "default" in line for line in out.splitlines()), key
    assert re.search(r"^delay_frames +an integer in \[0, 10\]", out, re.M) and "default 0.0" in out


def test_eval_takes_sensing_options(tmp_path, capsys):
    import json

    csv = tmp_path / "t.csv"
    csv.write_text("time_s,angle_deg\n0,40\n1,50\n2,60\n3,55\n")
    argv = ["eval", "--policy", "reference", "--trajectories", str(csv), "--json"]
    assert main(argv) == 0
    plain = json.loads(capsys.readouterr().out.splitlines()[-1])
    assert main(argv + ["--option", "delay_frames=2", "--option", "obs_noise_deg=0.5"]) == 0
    out = capsys.readouterr().out
    late = json.loads(out.splitlines()[-1])
    assert late["options"] == {"delay_frames": 2, "obs_noise_deg": 0.5} and "delay_frames=2" in out
    assert late["mae_deg"] != plain["mae_deg"]


@pytest.mark.parametrize("option,message", [("delay_frames=1.5", "delay_frames must be an integer in"),
                                            ("obs_noise_deg=-1", "obs_noise_deg must be a finite number >= 0"),
                                            ("dely_frames=1", "Did you mean 'delay_frames'"),
                                            ("seed=1", "--option seed: not settable here"),
                                            ("delay", "expected KEY=VALUE")])
def test_eval_bad_option_is_a_one_line_error_before_any_work(monkeypatch, capsys, option, message):
    def forbidden(*a, **k):
        raise AssertionError("work started before the option was checked")

    monkeypatch.setattr("shoulder_bench.eval.evaluate.evaluate", forbidden)
    monkeypatch.setattr("shoulder_bench.eval.evaluate.policy_for", forbidden)
    assert main(["eval", "--policy", "reference", "--option", option]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("shoulder-bench eval: error: ") and message in err and "\n" not in err
