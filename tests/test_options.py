"""Task options are checked: a bad one raises ValueError naming the option and what it accepts, on every entry point."""
import gymnasium as gym
import numpy as np
import pytest
import torch

import shoulder_bench
from shoulder_bench import protocol
from shoulder_bench.tasks import options

BAD = [
    ({"alpha": -1}, r"alpha must be a finite number in \[0, 1e\+06\]; got -1$"),
    ({"alpha": float("nan")}, r"alpha must be a finite number in \[0, 1e\+06\]; got nan$"),
    ({"alpha": np.float64("inf")}, r"alpha must be a finite number .*; got inf$"),
    ({"alpha": "0.1"}, r"alpha must be a finite number .*; got '0.1'"),
    ({"alpha": True}, r"alpha must be a finite number"),
    ({"alpha": 2e6}, r"alpha must be a finite number in \[0, 1e\+06\]"),
    ({"omega_max": -0.001}, r"omega_max must be a finite number >= 0; got -0.001"),
    ({"omega_max": float("nan")}, r"omega_max must be a finite number >= 0; got nan"),
    ({"tracking_only": "no"}, r"tracking_only must be None, True or False; got 'no'"),
    ({"tracking_only": 1}, r"tracking_only must be None, True or False; got 1"),
    ({"init": "rest"}, r"init must be one of 'hold', 'zero'; got 'rest'"),
    ({"split": "val"}, r"split must be one of 'train', 'test'; got 'val'"),
    ({"split": ["train"]}, r"split must be one of 'train', 'test'; got \['train'\]"),
    ({"seed": "abc"}, r"seed must be None or an integer .*; got 'abc'"),
    ({"seed": True}, r"seed must be None or an integer .*; got True"),
    ({"seed": 1.5}, r"seed must be None or an integer .*; got 1.5"),
    ({"seed": -1}, r"seed must be None or an integer >= 0; got -1"),
    ({"muscle_model": "fe"}, r"unknown muscle model 'fe'; choose one of fem, hill"),
    ({"alpah": 0.1}, r"unknown option\(s\) \['alpah'\]. Did you mean 'alpha'\? Valid options: split, seed"),
]


@pytest.mark.parametrize("kwargs,match", BAD)
def test_bad_option_is_a_clear_value_error(kwargs, match):
    with pytest.raises(ValueError, match=match):
        shoulder_bench.load("abduction_4m", **kwargs)


@pytest.mark.parametrize("kwargs,match", [b for b in BAD if "seed" not in b[0]])
def test_bad_option_through_gymnasium_and_make_vec(kwargs, match):
    with pytest.raises(ValueError, match=match):
        gym.make("ShoulderBench/abduction_4m-v0", **kwargs)
    with pytest.raises(ValueError, match=match):
        shoulder_bench.make_vec("abduction_4m", 2, **kwargs)


def test_numpy_scalars_are_valid_values():
    a = shoulder_bench.load("abduction_4m", seed=np.int64(3), alpha=np.float32(0.5), omega_max=np.int32(0),
                            tracking_only=np.bool_(False))
    b = shoulder_bench.load("abduction_4m", seed=3, alpha=0.5, omega_max=0.0, tracking_only=False)
    assert a.task.alpha == b.task.alpha == 0.5 and a.task.tracking_only is False
    ta, tb = a.reset(), b.reset()
    assert np.array_equal(ta.observation["angle"], tb.observation["angle"])
    assert a.step(np.full(4, 0.004)).reward == pytest.approx(b.step(np.full(4, 0.004)).reward, rel=1e-12)


def test_plain_prints_numbers_as_typed():
    assert options.plain(np.float64("nan")) == "nan" and options.plain(np.int64(3)) == "3"


def test_huge_finite_action_gives_a_finite_reward_capped_at_the_activation_range():
    big, cap = shoulder_bench.load("abduction_4m", seed=0), shoulder_bench.load("abduction_4m", seed=0)
    big.reset(), cap.reset()
    r_big = big.step(np.array([1e308, -1e308, 0.004, 0.0])).reward
    r_cap = cap.step(np.array([1.0, -1.0, 0.004, 0.0])).reward
    assert np.isfinite(r_big) and r_big == pytest.approx(r_cap, rel=1e-12)
    tracking = -abs(big.physics.angle_deg() - big.task.target.angle_deg[1])
    assert r_big == pytest.approx(tracking - 0.1 * 100 * (1 + 1 + 0.004) - 2 / 4, rel=1e-12)


def test_huge_finite_action_in_the_batched_env():
    venv = shoulder_bench.make_vec("abduction_4m", 2, seed=0)
    venv.step(torch.tensor([[1e308, 0.0, 0.0, 0.0], [-1e308, -1e308, -1e308, -1e308]], dtype=torch.float64))
    assert np.all(np.isfinite(venv.last_reward))
    assert np.all(venv.last_reward > -0.1 * 100 * 4 * protocol.REWARD_ACTION_CAP - 1 - 180)
