"""Shoulder conditions (issue 13, first step): each changes exactly what it says, through every API."""
import json

import gymnasium as gym
import numpy as np
import pytest
import torch

import shoulder_bench
from shoulder_bench import conditions, protocol
from shoulder_bench.arm import MUSCLES, arm
from shoulder_bench.cli import main
from shoulder_bench.model import install_callbacks

ANGLES = np.radians(np.arange(0.0, 121.0, 5.0))


def _forces(law, act=1.0):
    z = np.zeros_like(ANGLES)
    return law.force(ANGLES, z, np.full((len(ANGLES), len(law.muscles)), act))


@pytest.mark.parametrize("native", [True, False])
def test_a_removed_muscle_applies_no_force_in_mujoco(native):
    """The callback path: ssp's ctrl at 1, MuJoCo's actuator force of ssp is zero (nonzero when intact)."""
    install_callbacks(native=native)
    try:
        for condition, zero in ((None, False), ("ssp_tear", True)):
            env = shoulder_bench.load("abduction_4m", seed=0, condition=condition)
            env.reset()
            physics = env.physics
            physics.set_angle(40.0)
            physics.data.ctrl[:] = 0.0
            physics.data.ctrl[physics.model.name2id("ssp", "actuator")] = 1.0
            physics.forward()
            f = physics.data.actuator_force[physics.model.name2id("ssp", "actuator")]
            assert (f == 0.0) if zero else (abs(f) > 1.0)
    finally:
        install_callbacks()


def test_a_removed_muscle_has_no_force_in_the_batched_env():
    venv = shoulder_bench.make_vec("abduction_4m", 2, seed=0, condition="posterosuperior_tear")
    f = _forces(venv.law)
    cols = [venv.law.actuators.index(a) for a in ("ssp", "isp")]
    assert np.all(f[:, cols] == 0.0) and np.all(_forces(venv.law, 0.0)[:, cols] == 0.0)
    assert venv.sim.law is venv.law
    venv.close()


def test_partial_tear_and_weakness_scale_forces_exactly_and_compose():
    intact = arm().load_law("fem", MUSCLES)
    f0 = _forces(intact)
    for fraction in (0.25, 0.5):
        law = arm().load_law("fem", MUSCLES, "ssp_partial_tear", tear_fraction=fraction)
        f = _forces(law)
        k = law.actuators.index("ssp")
        np.testing.assert_allclose(f[:, k], (1 - fraction) * f0[:, k], rtol=1e-12, atol=1e-12)
        others = [i for i in range(len(law.actuators)) if i != k]
        assert np.array_equal(f[:, others], f0[:, others])
        np.testing.assert_allclose(_forces(law, 0.0)[:, k], (1 - fraction) * _forces(intact, 0.0)[:, k], atol=1e-12)
    both = conditions.factors("posterosuperior_tear+deltoid_weakness", weakness_fraction=0.3)
    assert both == {"ssp": 0.0, "isp": 0.0, "dmi": pytest.approx(0.7)}
    assert conditions.factors("ssp_partial_tear+deltoid_weakness") == {"ssp": 0.5, "dmi": 0.5}
    law = arm().load_law("fem", MUSCLES, "ssp_partial_tear+deltoid_weakness", tear_fraction=0.2)
    f = _forces(law)
    for muscle, factor in (("ssp", 0.8), ("dmi", 0.5), ("isp", 1.0)):
        k = law.actuators.index(muscle)
        np.testing.assert_allclose(f[:, k], factor * f0[:, k], rtol=1e-12, atol=1e-12)
    # ld's three bundles scale together
    ld = intact.scaled({"ld": 0.5})
    for a in ("ld1", "ld2", "ld3"):
        k = intact.actuators.index(a)
        np.testing.assert_allclose(_forces(ld)[:, k], 0.5 * f0[:, k], rtol=1e-12)


def test_the_preop_model_is_unchanged_by_loading_a_condition():
    before = arm().load_law("fem", MUSCLES)
    f_before, flat = _forces(before), before.kernel_arguments()[0].copy()
    env = shoulder_bench.load("abduction_4m", seed=0)
    env.reset()
    shoulder_bench.load("abduction_4m", seed=0, condition="posterosuperior_tear+deltoid_weakness").reset()
    arm().load_law("fem", MUSCLES, "ssp_tear")
    assert np.array_equal(before.kernel_arguments()[0], flat) and np.array_equal(_forces(before), f_before)
    assert np.array_equal(_forces(arm().load_law("fem", MUSCLES)), f_before)
    physics = env.physics  # the intact env built first still applies the intact force
    physics.set_angle(40.0)
    physics.data.ctrl[:] = 0.0
    physics.data.ctrl[physics.model.name2id("ssp", "actuator")] = 1.0
    physics.forward()
    assert abs(physics.data.actuator_force[physics.model.name2id("ssp", "actuator")]) > 1.0


@pytest.mark.parametrize("kw, message", [
    ({"condition": "rotator_cuff"}, "unknown condition 'rotator_cuff'; valid conditions: ssp_tear, ssp_partial_tear"),
    ({"condition": "posterosuperior_tear+nope"}, "unknown condition 'nope'"),
    ({"condition": "ld_transfer+ld_transfer"}, "names a condition twice"),
    ({"condition": "lower_trapezius_transfer"}, "no model here has a trapezius"),
    ({"condition": 3}, "condition must be None or a name"),
    ({"condition": "ssp_partial_tear", "tear_fraction": 1.0}, r"tear_fraction must be a number in \(0, 1\)"),
    ({"condition": "ssp_partial_tear", "tear_fraction": 0}, r"tear_fraction must be a number in \(0, 1\)"),
    ({"condition": "deltoid_weakness", "weakness_fraction": "half"}, "weakness_fraction must be"),
    ({"condition": "ssp_tear", "tear_fraction": 0.3}, "tear_fraction applies only with ssp_partial_tear"),
])
def test_bad_conditions_are_clear_errors(kw, message):
    with pytest.raises(ValueError, match=message):
        shoulder_bench.load("abduction_4m", **kw)


@pytest.mark.parametrize("name", ["abduction_ssp", "abduction_ssp_discrete"])
def test_removing_a_needed_muscle_is_an_error(name):
    with pytest.raises(ValueError, match="removes ssp, which the task needs"):
        shoulder_bench.load(name, condition="ssp_tear")
    with pytest.raises(ValueError, match="which the task needs"):
        shoulder_bench.make_vec(name, 2, condition="posterosuperior_tear")
    shoulder_bench.load(name, condition="ssp_partial_tear")  # scaled, not removed: fine


def test_single_and_batched_agree_under_a_condition():
    n_env, seed, tol, opts = 2, 5, 1e-6, {"condition": "posterosuperior_tear+deltoid_weakness",
                                          "weakness_fraction": 0.3}
    venv = shoulder_bench.make_vec("abduction_4m", n_env, seed=seed, **opts)
    envs = [shoulder_bench.load("abduction_4m", seed=seed + i, **opts) for i in range(n_env)]
    for e in envs:
        e.reset()
    rng = np.random.default_rng(0)
    for _ in range(60):
        a = rng.uniform(-0.012, 0.012, (n_env, venv.num_actions))
        venv.step(torch.as_tensor(a))
        obs = venv.observation_array()
        for i, env in enumerate(envs):
            ts = env.step(a[i])
            assert abs(ts.reward - venv.last_reward[i]) <= tol
            flat = np.concatenate([np.ravel(ts.observation[k]) for k in protocol.OBSERVATION_KEYS])
            assert np.abs(flat - obs[i]).max() <= tol
    venv.close()


def test_gymnasium_ids_and_make_vec_take_the_condition():
    env = gym.make("ShoulderBench/abduction_4m-v0", condition="ssp_tear")
    assert env.unwrapped.task.condition == {"condition": "ssp_tear"}
    env.close()
    envs = gym.make_vec("ShoulderBench/abduction_4m-v0", num_envs=2, vectorization_mode="vector_entry_point",
                        condition="deltoid_weakness", weakness_fraction=0.25)
    law = envs.unwrapped.batched.law
    k = law.actuators.index("dmi")
    np.testing.assert_allclose(_forces(law)[:, k], 0.75 * _forces(arm().load_law("fem", MUSCLES))[:, k], rtol=1e-12)
    envs.close()


def test_reference_plans_with_the_conditioned_law(capsys):
    from shoulder_bench.eval.evaluate import policy_for

    policy, _, _ = policy_for("reference", "abduction_4m", options={"condition": "ssp_tear", "delay_frames": 0})
    assert np.all(_forces(policy.law)[:, policy.law.actuators.index("ssp")] == 0.0)
    assert main(["eval", "--policy", "reference", "--trajectories", "combing", "--option", "condition=ssp_tear",
                 "--json"]) == 0
    last = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert last["options"] == {"condition": "ssp_tear"} and last["crashes"] == 0
    # --condition NAME is --option condition=NAME; both at once must agree
    assert main(["eval", "--policy", "reference", "--trajectories", "combing", "--condition", "ssp_tear",
                 "--json"]) == 0
    again = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert again["options"] == last["options"] and again["mae_deg"] == pytest.approx(last["mae_deg"], rel=1e-9)
    assert main(["eval", "--policy", "reference", "--condition", "ssp_tear", "--option", "condition=ld_transfer"]) == 2
    assert "give the condition once" in capsys.readouterr().err


def test_a_run_refuses_a_condition_its_task_cannot_have(tmp_path, capsys):
    out = tmp_path / "run"
    for flag in (["--option", "condition=ssp_tear"], ["--condition", "ssp_tear"]):
        assert main(["train", "--task", "abduction_ssp", "--algo", "ppo", "--frames", "1", "--out", str(out),
                     *flag]) == 2
        assert "which the task needs" in capsys.readouterr().err and not out.exists()


def test_condition_report_runs(capsys):
    from shoulder_bench.eval import conditions as report_module

    r = report_module.report(reference=False)
    rows = {row["condition"]: row for row in r["conditions"]}
    assert list(rows) == ["none", *conditions.CONDITIONS, "posterosuperior_tear+ld_transfer"]
    assert rows["ld_transfer"]["max_er_torque_Nm"] > rows["none"]["max_er_torque_Nm"]
    er = rows["ld_transfer"]["rerouted"]["er_anchor"]
    assert er["model_mm"] > 0 and er["difference_mm"] == pytest.approx(er["model_mm"] - 10.6)
    assert "rerouted" not in rows["ssp_tear"] and "model_transfer_deg" in r["muench_anchor"]
    assert rows["ssp_tear"]["static_reach_deg"] < rows["none"]["static_reach_deg"]
    assert rows["deltoid_weakness"]["max_torque_Nm"] < rows["none"]["max_torque_Nm"]
    assert 0.0 < r["ssp_share_anchor"]["model"] < 1.0
    assert main(["condition", "report", "--json", "--no-reference"]) == 0
    assert json.loads(capsys.readouterr().out)["conditions"][0]["condition"] == "none"
