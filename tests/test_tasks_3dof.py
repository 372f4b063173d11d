"""The full shoulder's 3-DOF tasks (issue 12 §3): by name through dm_control, gymnasium and the batched env; the
targets (random, CSV, ADL, test set); the holding start; the bad-input rules."""
from __future__ import annotations

import unittest

import numpy as np
import pytest
import torch
from dm_env import test_utils

import shoulder_bench
from shoulder_bench import full_arm, protocol, trajectory3
from shoulder_bench.tasks import TASKS_3DOF, check_options, fixed_test_set, list_tasks, spec

NAMES = tuple(TASKS_3DOF)


def test_tasks_are_listed_and_described():
    assert set(NAMES) <= set(list_tasks())
    assert spec("track_3dof") == (full_arm.MUSCLES, False) and spec("track_3dof_discrete")[1]
    assert len(full_arm.MUSCLES) >= 12
    with pytest.raises(KeyError, match="Did you mean 'track_3dof'"):
        shoulder_bench.load("track_3dfo")


@pytest.mark.parametrize("name", NAMES)
def test_dm_env_conformance(name):
    cls = type(f"Test_{name}", (test_utils.EnvironmentTestMixin, unittest.TestCase),
               {"make_object_under_test": lambda self: shoulder_bench.load(name, split="test", seed=0)})
    result = unittest.TextTestRunner(verbosity=0, stream=open("/dev/null", "w")).run(
        unittest.defaultTestLoader.loadTestsFromTestCase(cls))
    assert result.wasSuccessful(), [tb.splitlines()[-1] for _, tb in result.failures + result.errors]


@pytest.mark.parametrize("name", ["track_3dof", "track_3dof_discrete"])
def test_gymnasium_check_env(name):
    import gymnasium as gym
    from gymnasium.utils.env_checker import check_env

    env = gym.make(f"ShoulderBench/{name}-v0")
    check_env(env.unwrapped, skip_render_check=True)
    obs, info = env.reset(seed=3)
    assert obs.shape == (12 + len(full_arm.MUSCLES),) and info["error_deg"] == pytest.approx(0.0, abs=1e-6)


# band: the passive callback in rollout's threads too; the sensing options: the same delay buffer and noise draws
@pytest.mark.parametrize("options", [{}, {"line_of_action": "band"}, {"delay_frames": 2, "obs_noise_deg": 0.5},
                                     {"tendon": "compliant"}])
def test_batched_env_follows_the_single_env(options):
    env = shoulder_bench.load("track_3dof", split="test", seed=11, **options)
    ts = env.reset()
    venv = shoulder_bench.make_vec("track_3dof", 2, seed=11, split="test", **options)
    try:
        np.testing.assert_allclose(venv.get_observations()["policy"].numpy()[0], protocol.flatten(ts.observation),
                                   atol=1e-5)
        rng = np.random.default_rng(0)
        for _ in range(30):
            a = rng.uniform(-0.012, 0.012, (2, len(full_arm.MUSCLES)))
            ts = env.step(a[0])
            obs, reward, done, _ = venv.step(torch.as_tensor(a))
            np.testing.assert_allclose(obs["policy"].numpy()[0], protocol.flatten(ts.observation), atol=1e-4)
            assert reward[0].item() == pytest.approx(ts.reward, abs=1e-3)
            assert not done.any()
    finally:
        venv.close()


def test_hold_start_keeps_the_arm_at_rest_and_reward_is_the_orientation_error():
    target = np.tile([50.0, 60.0, 10.0], (21, 1))
    env = shoulder_bench.load("track_3dof", trajectory=target)
    env.reset()
    for _ in range(20):
        ts = env.step(np.zeros(len(full_arm.MUSCLES)))
    assert np.abs(env.physics.coordinates_deg() - target[0]).max() < 0.5
    assert -ts.reward == pytest.approx(env.task.error_deg(env.physics), rel=1e-9)
    assert ts.last() and ts.discount == 1.0  # the end of the target is a time limit


def test_scapular_plane_task_keeps_plane_and_rotation():
    env = shoulder_bench.load("elevate_scapular_plane_12m", seed=2)
    ts = env.reset()
    assert ts.observation["target_angle"][0] == 30.0 and ts.observation["target_angle"][2] == 0.0
    assert 30.0 <= ts.observation["target_angle"][1] <= 90.0


def test_orientation_error_is_the_rotation_angle():
    pose = full_arm.Pose()
    a = pose.orientation(pose.qpos([[40, 60, 0]]))
    b = pose.orientation(pose.qpos([[40, 60, 25]]))  # 25 deg of axial rotation
    assert full_arm.angular_distance_deg(a, a)[0] == pytest.approx(0.0, abs=1e-5)
    assert full_arm.angular_distance_deg(a, b)[0] == pytest.approx(25.0, abs=1e-6)


def test_bad_options_and_actions_are_clear_errors():
    with pytest.raises(ValueError, match="not offered on the 3-DOF tasks"):
        shoulder_bench.load("track_3dof", joint_damping=1.0)
    with pytest.raises(ValueError, match="not offered on the 3-DOF tasks"):
        check_options("track_3dof", tracking_only=True)
    with pytest.raises(ValueError, match="workspace"):
        shoulder_bench.load("track_3dof", workspace="moon")
    with pytest.raises(ValueError, match="FEM tables only"):
        shoulder_bench.load("track_3dof", muscle_model="hill")
    env = shoulder_bench.load("track_3dof", seed=0)
    env.reset()
    with pytest.raises(ValueError, match="shape"):
        env.step(np.zeros(4))
    with pytest.raises(ValueError, match="not finite"):
        env.step(np.full(len(full_arm.MUSCLES), np.nan))


def test_random_targets_stay_in_their_ranges():
    rngs = [np.random.default_rng(k) for k in range(20)]
    for split, cfg in trajectory3.SPLITS.items():
        angle, velocity = trajectory3.random_targets(rngs, split)
        assert angle.shape == (20, int(cfg["duration_s"] / 0.1) + 1, 3)
        for k, (lo, hi) in enumerate(cfg["range_deg"]):
            assert lo - 1e-9 <= angle[..., k].min() and angle[..., k].max() <= hi + 1e-9
        assert np.abs(velocity[:, 0]).max() < 1.0  # rest-to-rest segments


def test_csv_round_trip_and_errors(tmp_path):
    tr = trajectory3.reach_back_of_head()
    path = tmp_path / "t.csv"
    trajectory3.write_csv(path, [tr])
    back = trajectory3.load_csv(path)[0]
    np.testing.assert_allclose(back.angle_deg, tr.angle_deg, atol=1e-6)
    bad = tmp_path / "bad.csv"
    bad.write_text("time_s,plane_deg,elevation_deg\n0,10,20\n")
    with pytest.raises(ValueError, match="missing column"):
        trajectory3.load_csv(bad)
    bad.write_text("time_s,plane_deg,elevation_deg,rotation_deg\n0,10,20,0\n0.5,10,170,0\n")
    with pytest.raises(ValueError, match="row 3: elevation_deg 170"):
        trajectory3.load_csv(bad)
    bad.write_text("time_s,plane_deg,elevation_deg,rotation_deg\n0,30,20,0\n0,30,25,0\n")
    with pytest.raises(ValueError, match="does not increase"):
        trajectory3.load_csv(bad)
    env = shoulder_bench.load("track_3dof", trajectory=str(path))
    assert env.reset().observation["target_angle"] == pytest.approx(tr.angle_deg[1])


def test_adl_profiles_are_synthetic_and_in_the_pose_space():
    for name, make in trajectory3.ADL.items():
        tr = make()
        assert "synthetic" in tr.name and tr.frames > 50
        trajectory3.check_in_pose_space(tr.angle_deg, name)
        assert shoulder_bench.load("track_3dof", trajectory=name).reset().observation["angle"].shape == (3,)


def test_test_set_is_checked_and_fixed():
    test = fixed_test_set("track_3dof")
    assert len(test) == trajectory3.TEST_SET_SIZE and all(t.frames == 200 for t in test)
    again = trajectory3.make_test_set()
    np.testing.assert_allclose(test[7].angle_deg, again[7].angle_deg, atol=1e-6)


def test_holding_activations_hold_the_workspace():
    from shoulder_bench.statics_full import Statics
    from shoulder_bench.tendon_law import TendonLaw

    st = Statics(TendonLaw.load("fem", groups=full_arm.ACTUATORS))
    for pose in ([30, 30, -20], [70, 90, 30], [50, 60, 0]):
        a, residual = st.holding(pose)
        assert residual < 1e-3 and np.all((a >= 0) & (a <= 1))
    assert st.gravity([50, 90, 0])[1] > 2.0  # gravity pulls the raised arm down: muscles must elevate


@pytest.mark.slow
def test_ppo_trains_and_evaluates_on_the_3dof_test_set(tmp_path):
    from shoulder_bench.eval import board3
    from shoulder_bench.eval.experiment import train

    metrics = train("track_3dof", "ppo", frames=1536, seed=0, out=tmp_path / "track_3dof/ppo/0", eval_every=10 ** 9)
    assert metrics["n_trajectories"] == 100 and np.isfinite(metrics["mae_deg"])
    rows = board3.collect(tmp_path, test=trajectory3.load_test_set()[:2], suites=["paper", "adl"])
    assert [r["algorithm"] for r in rows] == ["PPO", "reference controller"]
    assert all(list(r["suites"]) == ["adl"] and np.isfinite(r["suites"]["adl"]) for r in rows)
    assert all(np.isfinite(r[k]) for r in rows for k in ("mae", "plane", "elevation", "rotation"))
    assert all(np.isfinite(r[k]) for r in rows for k in board3.MEASURES) and 0 <= rows[0]["success"] <= 1
    assert "| track_3dof | PPO | 1 |" in board3.markdown(rows) and "<table>" in board3.html(rows)


def test_a_recorded_3dof_evaluation_gives_the_boards_measures():
    """evaluate(record=True) on a 3-DOF task: coordinates (B, T, 3), the orientation error the score is made of, the
    activations; the board's success, effort, saw-tooth and mean |delta a| follow from it (eval.measures)."""
    from shoulder_bench.eval import board3, measures
    from shoulder_bench.eval.evaluate import evaluate
    from shoulder_bench.eval.reference3 import ReferenceController3

    test = [trajectory3.Trajectory3(t.angle_deg[:31], t.velocity_deg_s[:31], name=t.name)
            for t in trajectory3.load_test_set()[:2]]  # the first 3 s of two test trajectories
    score = evaluate(ReferenceController3("track_3dof"), "track_3dof", test, record=True)
    trace = score["trace"]
    assert trace["angle_deg"].shape == trace["target_deg"].shape == (2, 30, 3)
    assert trace["activation"].shape == (2, 30, len(full_arm.MUSCLES)) and trace["error_deg"].shape == (2, 30)
    np.testing.assert_allclose(np.nanmean(trace["error_deg"]), score["mae_deg"], rtol=1e-9)  # no crash here
    err = measures.tracking_error(trace, [30, 30])
    np.testing.assert_array_equal(err, trace["error_deg"])
    assert measures.successes(err, [30, 30]).tolist() == [bool((e < 2).mean() >= 0.9) for e in err]
    assert not measures.successes(err + 2.0, [30, 30]).any()  # 2 deg worse everywhere: nothing succeeds
    torques = board3.TorqueLaw3()
    row = board3.score_of(ReferenceController3("track_3dof"), "track_3dof", test, law=torques)
    assert "trace" not in row and row["mae_deg"] == pytest.approx(score["mae_deg"])
    assert row["effort"] == pytest.approx(measures.effort(trace["activation"])) and row["sawtooth_per_s"] >= 0
    assert 0.0 < row["co_contraction"] < 1.0  # holding a low pose co-contracts (docs/tasks_3dof.md "Workspace")


def test_3dof_co_contraction_is_the_share_against_the_net_torque_vector():
    """TorqueLaw3: the FEM tables' torques through the tendon moment arms; one muscle alone opposes nothing; with
    every muscle on, the share of those whose torque vector points against the net (negative dot product)."""
    from shoulder_bench.eval import board3
    from shoulder_bench.eval.measures import co_contraction

    torques = board3.TorqueLaw3()
    angle = np.array([[[50.0, 60.0, 10.0]] * 2])  # (1, 2, 3)
    act = np.zeros((1, 2, len(full_arm.MUSCLES)))
    act[..., full_arm.MUSCLES.index("dan")] = 0.4
    assert co_contraction(angle, act, torques) == pytest.approx(0.0)
    act[:] = 0.5
    tau = torques.torque(np.radians(angle[0, :1]), np.zeros(1), act[0, :1])[0]  # (muscles, 3)
    against = (tau @ tau.sum(axis=0)) < 0
    assert co_contraction(angle, act, torques) == pytest.approx(against.mean()) and 0 < against.mean() < 1
    ssp = np.zeros((1, len(full_arm.MUSCLES)))
    ssp[0, full_arm.MUSCLES.index("ssp")] = 1.0
    tau1 = torques.torque(np.radians(angle[0, :1]), np.zeros(1), ssp)[0]
    L, r = torques.pose.tendon_geometry(angle[0, :1], torques.law.actuators)
    f = torques.law.force(L, np.zeros_like(L), ssp)
    k = torques.law.actuators.index("ssp")  # ssp: one tendon; its torque = its table force x its moment arms
    np.testing.assert_allclose(tau1[full_arm.MUSCLES.index("ssp")], f[0, k] * r[0, k], rtol=1e-12)


def test_render_a_3dof_episode(tmp_path, monkeypatch):
    import mujoco

    from shoulder_bench.eval import render3
    from shoulder_bench.eval.render import render_video
    from shoulder_bench.eval.render_model import IDLE

    info = render_video(tmp_path / "arm.gif", task="track_3dof", policy="reference", trajectory="lift_to_shelf",
                        seconds=0.5, width=96, height=64, gif=True)
    assert (tmp_path / "arm.gif").stat().st_size > 0 and info["frames"] == 10 and info["task"] == "track_3dof"
    assert info["controller"] == "reference controller" and not info["crashed"]
    # post-op: the rerouted latissimus drawn on its own path, the torn cuff grey
    seen, build = {}, render3.build_render_model
    monkeypatch.setattr(render3, "build_render_model", lambda *a, **k: seen.setdefault("model", build(*a, **k)))
    info = render_video(tmp_path / "post.gif", task="track_3dof", policy="reference", seconds=0.3, width=96,
                        height=64, gif=True, condition="posterosuperior_tear+ld_transfer")
    assert (tmp_path / "post.gif").stat().st_size > 0 and not info["crashed"]

    def wraps(m, tendon: str) -> list[str]:
        t = m.tendon(tendon).id
        return [m.geom(int(m.wrap_objid[k])).name for k in range(m.tendon_adr[t], m.tendon_adr[t] + m.tendon_num[t])
                if m.wrap_type[k] != mujoco.mjtWrap.mjWRAP_SITE]

    m = seen["model"]
    rerouted, intact = wraps(full_arm.compile_full("ld_transfer"), "ld1"), wraps(full_arm.compile_full(), "ld1")
    assert wraps(m, "ld1") == rerouted != intact
    np.testing.assert_allclose(m.tendon_rgba[m.tendon("isp").id], IDLE)  # removed: grey in every frame


def test_bench_covers_the_full_shoulder(capsys):
    import json

    from shoulder_bench.cli import main

    assert main(["bench", "--quick", "--json", "--task", "track_3dof"]) == 0
    result = json.loads(capsys.readouterr().out.splitlines()[-1])
    assert result["task"] == "track_3dof" and result["rows"][0]["physics_step_s"] == pytest.approx(0.01)
    assert all(r["batched_fps"] > 0 and r["bare_fps"] > 0 and r["resets"] == r["num_envs"] for r in result["rows"])


def test_error_features_take_each_coordinates_error():
    from shoulder_bench.train.ppo import ErrorFeatures

    obs = torch.zeros(2, 12 + 13)
    obs[:, 0:3] = torch.tensor([40.0, 60.0, 0.0])  # angles
    obs[:, 6:9] = torch.tensor([45.0, 50.0, 10.0])  # targets
    obs[:, 9:12] = torch.tensor([10.0, 0.0, -20.0])  # target rates
    out = ErrorFeatures(3)(obs)
    assert out.shape == (2, 25 + 6)
    torch.testing.assert_close(out[0, 25:], torch.tensor([1.0, -2.0, 2.0, 1.0, 0.0, -2.0]))
    assert ErrorFeatures()(torch.zeros(1, 8)).shape == (1, 10)  # the 1-DOF layout (4 + 4 muscles) as before


def test_board_rows_of_different_settings_do_not_pool():
    import json

    from shoulder_bench.eval.board3 import _variant

    a = json.dumps({"config": {"error_features": True, "lr": 1}, "options": {}}, sort_keys=True)
    b = json.dumps({"config": {"error_features": False, "lr": 1}, "options": {}}, sort_keys=True)
    assert _variant(a, [a, b]) == " (error_features=True)" and _variant(b, [a]) == ""
    c = json.dumps({"config": {"error_features": True, "lr": 1}, "options": {"line_of_action": "band"}},
                   sort_keys=True)  # a task option is named even where the row is alone
    assert _variant(c, [c]) == " (line_of_action=band)"
    assert _variant(c, [a, c]) == " (line_of_action=band)"


def test_board_pools_seeds_of_one_setting():
    from shoulder_bench.eval.board3 import setting_key

    bdq = {"task": "track_3dof_discrete", "algo": "bdq", "options": {}, "config": {"lr": 5e-4, "branching": True}}
    seeds = [{**bdq, "seed": s, "config": {**bdq["config"], "seed": s}} for s in (0, 1)]  # DQN's config repeats it
    assert setting_key(seeds[0]) == setting_key(seeds[1])
    assert setting_key(seeds[0]) != setting_key({**bdq, "config": {**bdq["config"], "lr": 1e-3}})


def test_scapular_plane_task_is_tested_on_the_paper_test_set_in_the_scapular_plane():
    from shoulder_bench.trajectory import load_test_set

    one, three = load_test_set(), fixed_test_set("elevate_scapular_plane_12m")
    assert len(three) == len(one) == 100
    np.testing.assert_allclose(three[3].angle_deg[:, 1], one[3].angle_deg)
    assert np.all(three[3].angle_deg[:, 0] == 30.0) and np.all(three[3].angle_deg[:, 2] == 0.0)


def test_the_sensing_options_delay_and_blur_what_the_agent_sees_not_the_reward():
    """delay_frames=k: the observed angles, velocities and activations are those of k frames before (the targets
    current); obs_noise_deg=sigma: Gaussian with that sigma on the angles and velocities only; a restored state
    continues exactly."""
    k, rng = 2, np.random.default_rng(4)
    late = shoulder_bench.make_vec("track_3dof", 2, seed=3, split="test", delay_frames=k)
    now = shoulder_bench.make_vec("track_3dof", 2, seed=3, split="test")
    seen, truth = [], []
    for _ in range(6):
        a = torch.as_tensor(rng.uniform(-0.01, 0.01, (2, len(full_arm.MUSCLES))))
        seen.append(late.step(a)[0]["policy"].numpy())
        truth.append(now.step(a)[0]["policy"].numpy())
    seen, truth = np.array(seen), np.array(truth)
    sensed = np.r_[0:6, 12:25]  # angles, velocities, activations
    np.testing.assert_array_equal(seen[k:][..., sensed], truth[:-k][..., sensed])
    np.testing.assert_array_equal(seen[..., 6:12], truth[..., 6:12])  # targets: current
    assert not np.array_equal(seen[k:][..., :3], truth[k:][..., :3])
    sigma, n = 0.8, 64
    noisy = shoulder_bench.make_vec("track_3dof", n, seed=3, split="test", obs_noise_deg=sigma)
    clean = shoulder_bench.make_vec("track_3dof", n, seed=3, split="test")
    d = noisy.get_observations()["policy"].numpy().astype(float) - clean.get_observations()["policy"].numpy()
    assert 0.6 * sigma < d[:, :6].std() < 1.4 * sigma and np.all(d[:, 6:] == 0)
    a = torch.zeros(n, len(full_arm.MUSCLES))
    _, r_noisy, _, _ = noisy.step(a)
    _, r_clean, _, _ = clean.step(a)
    np.testing.assert_array_equal(r_noisy.numpy(), r_clean.numpy())  # rewards see the true state
    both = shoulder_bench.make_vec("track_3dof", 2, seed=9, split="test", delay_frames=1, obs_noise_deg=0.3)
    both.step(torch.zeros(2, len(full_arm.MUSCLES)))
    saved = both.state_dict()
    ahead = [both.step(torch.full((2, len(full_arm.MUSCLES)), 0.004))[0]["policy"].numpy() for _ in range(3)]
    both.load_state_dict(saved)
    again = [both.step(torch.full((2, len(full_arm.MUSCLES)), 0.004))[0]["policy"].numpy() for _ in range(3)]
    np.testing.assert_array_equal(np.array(ahead), np.array(again))
    with pytest.raises(ValueError, match="cannot be restored"):
        late.load_state_dict(saved)
    with pytest.raises(ValueError, match=r"delay_frames must be an integer in \[0, 10\]"):
        shoulder_bench.load("track_3dof", delay_frames=11)
    for env in (late, now, noisy, clean, both):
        env.close()
