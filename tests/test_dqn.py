"""Double DQN / branching DQN (train/dqn.py): tiny training runs, the branching target, checkpoints, export."""
import io

import numpy as np
import pytest
import torch

import shoulder_bench
from shoulder_bench.train.dqn import DQNAgent, DQNConfig, branching_target

TINY = dict(num_envs=8, buffer_size=5_000, batch_size=32, learning_starts=400, eps_decay_frames=2_000,
            updates_per_step=1.0, target_update_every=20, hidden=(32,), log_every=400, checkpoint_every=800)
TASKS = [("abduction_ssp_discrete", False), ("abduction_4m_discrete", True)]


@pytest.fixture(autouse=True)
def one_thread():  # tiny networks: threads only add overhead (and contention on a shared machine)
    before = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(before)


def make_env(task, seed=0):
    return shoulder_bench.make_vec(task, TINY["num_envs"], seed=seed, nthread=1)


def make(task, branching, seed=0, **over):
    cfg = DQNConfig(branching=branching, seed=seed, **{**TINY, **over})
    env = make_env(task, seed)
    return DQNAgent(cfg, env.get_observations()["policy"].shape[1], env.n), env


@pytest.mark.parametrize("task,branching", TASKS)
def test_tiny_training_is_finite_and_counts_frames(task, branching):
    agent, env = make(task, branching)
    logs, checkpoints = [], []
    agent.learn(env, 1_602, on_log=logs.append, on_checkpoint=checkpoints.append)
    assert agent.frames == 1_608  # whole vec steps of 8 copies: the first multiple of 8 >= 1602
    assert agent.grad_steps > 0 and len(agent.buffer) > 0
    assert [d["frames"] for d in logs] == [400, 800, 1_200, 1_600] and checkpoints == [800, 1_600]
    assert {"frames", "fps", "mean_return", "loss", "epsilon", "mae_deg"} <= set(logs[-1])
    assert np.isfinite(logs[-1]["loss"]) and np.isfinite(logs[-1]["q_mean"]) and np.isfinite(logs[-1]["mean_return"])
    obs = env.get_observations()["policy"]
    assert torch.isfinite(agent.q(obs)).all()
    levels = agent.act(obs.numpy(), explore=True)
    assert levels.shape == (8, env.n) and levels.dtype == np.int64 and levels.min() >= 0 and levels.max() <= 20
    agent.learn(env, 400)  # continues
    assert agent.frames == 2_008


def test_time_outs_are_not_stored_and_crashes_are_terminal():
    agent, env = make("abduction_ssp_discrete", False, learning_starts=10**9)  # collection only
    agent.learn(env, 8 * 100)  # exactly one 100-frame training episode per copy, ending in time-outs
    assert len(agent.buffer) == 8 * 99 and not agent.buffer.term[:len(agent.buffer)].any()


def test_branching_target_by_hand():
    # B=2 transitions, n=2 branches, 21 levels; only a few entries matter
    q_online = torch.zeros(2, 2, 21)
    q_target = torch.full((2, 2, 21), 100.0)
    q_online[0, 0, 3], q_target[0, 0, 3] = 1.0, 2.0  # branch 0 selects level 3, evaluated at 2
    q_online[0, 1, 7], q_target[0, 1, 7] = 1.0, -4.0  # branch 1 selects level 7, evaluated at -4
    q_online[1, 0, 0], q_target[1, 0, 0] = 1.0, 5.0
    q_online[1, 1, 1], q_target[1, 1, 1] = 1.0, 5.0
    reward, terminated = torch.tensor([1.0, -3.0]), torch.tensor([False, True])
    y = branching_target(q_online, q_target, reward, terminated, gamma=0.5)
    assert torch.allclose(y, torch.tensor([1.0 + 0.5 * (2.0 - 4.0) / 2, -3.0]))
    # one branch: the Double DQN target (online argmax, target value), not max of the target net
    y1 = branching_target(q_online[:, :1], q_target[:, :1], reward, torch.tensor([False, False]), gamma=0.5)
    assert torch.allclose(y1, torch.tensor([1.0 + 0.5 * 2.0, -3.0 + 0.5 * 5.0]))


def test_dueling_heads_are_identifiable():
    agent, _ = make("abduction_4m_discrete", True)
    obs = torch.randn(3, 8) * 10
    q = agent.q(obs)
    z = agent.q.trunk(agent.q.norm(obs))
    assert q.shape == (3, 4, 21)
    assert torch.allclose(q.mean(-1), agent.q.value(z).expand(3, 4), atol=1e-5)  # mean_a Q_d = V


@pytest.mark.parametrize("task,branching", TASKS)
def test_state_dict_round_trip_and_deterministic_resume(task, branching):
    agent, env = make(task, branching)
    agent.learn(env, 800)
    buf = io.BytesIO()
    torch.save(agent.state_dict(), buf)
    obs = env.get_observations()["policy"]

    buf.seek(0)
    restored = DQNAgent.from_state_dict(torch.load(buf))
    assert restored.frames == agent.frames == 800 and restored.grad_steps == agent.grad_steps
    assert np.array_equal(restored.act(obs, explore=False), agent.act(obs, explore=False))

    # resuming from the checkpoint on a fresh env with the same seed is deterministic
    runs = []
    for _ in range(2):
        buf.seek(0)
        a = DQNAgent.from_state_dict(torch.load(buf))
        a.learn(make_env(task, seed=7), 400)
        runs.append(a)
    assert runs[0].frames == runs[1].frames == 1_200
    for p, q in zip(runs[0].q.parameters(), runs[1].q.parameters()):
        assert torch.equal(p, q)


def test_learn_in_two_calls_equals_one_call():
    a, env_a = make("abduction_ssp_discrete", False)
    a.learn(env_a, 600)
    a.learn(env_a, 600)
    b, env_b = make("abduction_ssp_discrete", False)
    b.learn(env_b, 1_200)
    assert a.frames == b.frames and a.grad_steps == b.grad_steps
    for p, q in zip(a.q.parameters(), b.q.parameters()):
        assert torch.equal(p, q)


@pytest.mark.parametrize("task,branching", TASKS)
def test_exported_policy_matches_greedy_act(task, branching):
    agent, env = make(task, branching)
    agent.learn(env, 600)
    obs = torch.randn(64, 4 + env.n) * torch.tensor([20, 10, 20, 10] + [0.1] * env.n) + torch.tensor(
        [60.0, 0, 60, 0] + [0.2] * env.n)
    greedy = agent.act(obs, explore=False)
    scripted = torch.jit.script(agent.policy())
    traced = torch.jit.trace(agent.policy(), obs[:2])
    for module in (agent.policy(), scripted, traced):
        out = module(obs)
        assert out.dtype == torch.int64 and out.shape == (64, env.n)
        assert np.array_equal(out.numpy(), greedy)
    buf = io.BytesIO()
    torch.jit.save(scripted, buf)
    buf.seek(0)
    assert np.array_equal(torch.jit.load(buf)(obs).numpy(), greedy)


def test_the_error_features_are_each_coordinates_own():
    """The normaliser's tracking errors read the observation's blocks, one column per coordinate: on the 3-DOF task
    (angles, rates, targets, target rates, activations, each 3 wide) target - angle of plane, elevation, rotation;
    on a 1-DOF task the single pair, as before."""
    from shoulder_bench.train.dqn import ObsNormalizer

    for task, dofs in (("abduction_4m_discrete", 1), ("track_3dof_discrete", 3)):
        env = shoulder_bench.make_vec(task, 2, seed=0, nthread=1)
        assert getattr(env.task, "dofs", 1) == dofs
        obs = env.get_observations()["policy"]
        obs = obs + torch.arange(obs.shape[1], dtype=obs.dtype) ** 2  # every column different
        out = ObsNormalizer(obs.shape[1], dofs)(obs)
        d = dofs
        assert out.shape[1] == obs.shape[1] + 2 * d
        torch.testing.assert_close(out[:, -2 * d:-d], (obs[:, 2 * d:3 * d] - obs[:, 0:d]) / 5.0)
        torch.testing.assert_close(out[:, -d:], (obs[:, 3 * d:4 * d] - obs[:, d:2 * d]) / 10.0)
    cfg = DQNConfig(branching=True, **TINY)
    agent = DQNAgent(cfg, obs.shape[1], env.n, dofs=3)
    assert agent.q.trunk[0].in_features == obs.shape[1] + 6
    again = DQNAgent.from_state_dict(agent.state_dict())  # the coordinates travel with the checkpoint
    assert again.dofs == 3 and torch.equal(again.q(obs), agent.q(obs))


def test_n_step_window_by_hand():
    """Three-step returns of two copies: copy 0 runs on, then times out; copy 1 crashes at its second step, and its
    next episode's steps never enter the returns of the one before."""
    from shoulder_bench.train.replay import NStepWindow

    w = NStepWindow(3, gamma=0.5)
    f = torch.tensor([False, False])

    def step(t, done=f, out=f):  # obs = 10 t + copy, next obs = 10 (t + 1) + copy, reward t + 1 (copy 0), -(t + 1)
        obs = torch.tensor([[10.0 * t], [10.0 * t + 1]])
        return w.push(obs, torch.tensor([[t], [t]], dtype=torch.uint8), torch.tensor([t + 1.0, -(t + 1.0)]),
                      obs + 10, done, out)

    assert step(0) is None
    assert step(1, done=torch.tensor([False, True])) is None  # copy 1 crashes
    obs, act, ret, boot, term, steps = step(2)
    assert torch.equal(obs[:, 0], torch.tensor([0.0, 1.0]))
    torch.testing.assert_close(ret, torch.tensor([1 + 0.5 * 2 + 0.25 * 3, -1 - 0.5 * 2]))
    assert torch.equal(boot[:, 0], torch.tensor([30.0, 21.0])) and torch.equal(term, torch.tensor([False, True]))
    assert torch.equal(steps, torch.tensor([3, 2], dtype=torch.uint8))
    # copy 0 times out at step 3: the window from step 1 stops before it and bootstraps from step 3's observation
    obs, act, ret, boot, term, steps = step(3, done=torch.tensor([True, False]), out=torch.tensor([True, False]))
    torch.testing.assert_close(ret, torch.tensor([2 + 0.5 * 3, -2.0]))
    assert torch.equal(boot[:, 0], torch.tensor([30.0, 21.0])) and torch.equal(steps, torch.tensor([2, 1],
                                                                                                   dtype=torch.uint8))
    assert torch.equal(term, torch.tensor([False, True]))
    step(4)
    obs, *_ = step(5)  # the window from step 3: copy 0's time-out stores nothing, copy 1's return runs on
    assert torch.equal(obs[:, 0], torch.tensor([31.0]))
    one = NStepWindow(1, gamma=0.5)  # n = 1: the one-step transitions, time-outs dropped
    obs1, _, ret1, boot1, term1, steps1 = one.push(torch.zeros(2, 1), torch.zeros(2, 1, dtype=torch.uint8),
                                                   torch.tensor([1.0, 2.0]), torch.ones(2, 1),
                                                   torch.tensor([True, True]), torch.tensor([True, False]))
    assert torch.equal(ret1, torch.tensor([2.0])) and term1.tolist() == [True] and steps1.tolist() == [1]


def test_n_step_training_resumes_exactly_and_matches_one_call():
    a, env_a = make("abduction_4m_discrete", True, n_step=3)
    a.learn(env_a, 600)
    assert len(a.window.steps) == 2  # the last two vec steps wait for their returns
    b = DQNAgent.from_state_dict(a.state_dict())
    a.learn(env_a, 600)
    c, env_c = make("abduction_4m_discrete", True, n_step=3)
    c.learn(env_c, 1_200)
    for p, q in zip(a.q.parameters(), c.q.parameters()):
        assert torch.equal(p, q)
    assert len(b.window.steps) == 2 and b.buffer.steps[:len(b.buffer)].max() == 3


def test_the_env_stepping_beside_the_updates_is_deterministic_and_resumable():
    """overlap_env: the copies step in a thread while the gradient steps run; the same frames and steps as without,
    the same parameters on a rerun and whether learned in one call or two."""
    runs = []
    for calls in ((1_200,), (600, 600)):
        agent, env = make("abduction_4m_discrete", True, overlap_env=True)
        for frames in calls:
            agent.learn(env, frames)
        runs.append(agent)
    plain, env = make("abduction_4m_discrete", True, overlap_env=False)
    plain.learn(env, 1_200)
    assert runs[0].frames == runs[1].frames == plain.frames and runs[0].grad_steps == plain.grad_steps > 0
    assert len(runs[0].buffer) == len(plain.buffer)
    for p, q in zip(runs[0].q.parameters(), runs[1].q.parameters()):
        assert torch.equal(p, q)
    assert any(not torch.equal(p, q) for p, q in zip(runs[0].q.parameters(), plain.q.parameters()))
