"""The seeded bootstrap (`eval.stats`): known data give known intervals."""
import numpy as np
import pytest

from shoulder_bench.eval.stats import bootstrap_ci, error_ci, mean_ci


def test_two_samples_give_their_range():
    # resampled means of (a, b): a, (a + b) / 2, b with probability 1/4, 1/2, 1/4 -> the 95 % interval is [a, b]
    assert bootstrap_ci([1.0, 3.0]) == (pytest.approx(1.0), pytest.approx(3.0))
    m, lo, hi, n = mean_ci([0.35, 1.74, None])
    assert (m, lo, hi, n) == (pytest.approx(1.045), pytest.approx(0.35), pytest.approx(1.74), 2)


def test_a_large_normal_sample_gives_the_normal_interval():
    x = np.random.default_rng(1).normal(10.0, 2.0, size=400)
    lo, hi = bootstrap_ci(x)
    half = 1.96 * x.std() / np.sqrt(len(x))  # 0.196 for sigma 2, n 400
    assert lo == pytest.approx(x.mean() - half, abs=0.02) and hi == pytest.approx(x.mean() + half, abs=0.02)
    lo90, hi90 = bootstrap_ci(x, level=0.9)
    assert lo < lo90 < hi90 < hi


def test_the_seed_fixes_the_interval():
    x = np.random.default_rng(2).exponential(size=30)
    assert bootstrap_ci(x, seed=5) == bootstrap_ci(x, seed=5)
    assert bootstrap_ci(x, seed=5) != bootstrap_ci(x, seed=6)


def test_too_few_or_bad_samples():
    assert all(np.isnan(v) for v in bootstrap_ci([2.0]))
    assert np.isnan(mean_ci([None])[0]) and mean_ci([None])[3] == 0
    with pytest.raises(ValueError, match="finite"):
        bootstrap_ci([1.0, np.nan])
    with pytest.raises(ValueError, match="level"):
        bootstrap_ci([1.0, 2.0], level=95)


def test_errors_over_trajectories_pool_frames():
    # two trajectories: 10 frames at |e| = 1 and 30 frames at |e| = 3 -> MAE 2.5, RMSE sqrt(7); resampled: 1, 2.5, 3
    abs_sum, sq_sum, frames = [10.0, 90.0], [10.0, 270.0], [10, 30]
    ci = error_ci(abs_sum, sq_sum, frames)
    assert ci["mae"] == (pytest.approx(2.5), pytest.approx(1.0), pytest.approx(3.0), 2)
    assert ci["rmse"][0] == pytest.approx(np.sqrt(7.0)) and ci["rmse"][1:3] == (pytest.approx(1.0), pytest.approx(3.0))
