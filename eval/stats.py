"""Shared statistics: a seeded percentile bootstrap.

`bootstrap_ci(data, of=...)` resamples the rows of `data` (n samples, each a row of k numbers) with replacement,
`n_boot` times from `numpy.random.default_rng(seed)`, takes the column means of each resample and maps them to the
statistic with `of` (default: the mean of the single column). The interval is the (1 - level) / 2 and (1 + level) / 2
percentiles of the resampled statistic. A ratio of means (MAE = summed error / frames over resampled trajectories) is
thus bootstrapped as a whole rather than trajectory by trajectory. The same seed gives the same interval.

With one sample there is nothing to resample: the interval is (nan, nan). With two samples a and b the resampled means
are a, (a + b) / 2 and b with probabilities 1/4, 1/2, 1/4, so the 95 % interval is [min, max] (tests check that).
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np

N_BOOT = 10_000
LEVEL = 0.95
SEED = 0


def _rows(data) -> np.ndarray:
    a = np.asarray(data, dtype=float)
    if a.ndim == 1:
        a = a[:, None]
    if a.ndim != 2:
        raise ValueError(f"bootstrap data must be 1-D (n,) or 2-D (n, k); got shape {a.shape}")
    if not np.isfinite(a).all():
        raise ValueError("bootstrap data must be finite (drop missing samples first)")
    return a


def bootstrap_ci(data, of: Callable[[np.ndarray], np.ndarray] | None = None, n_boot: int = N_BOOT,
                 level: float = LEVEL, seed: int = SEED) -> tuple[float, float]:
    """(low, high) percentile bootstrap interval of the statistic `of(column means)` over the rows of `data`.

    of: maps (n_boot, k) resampled column means to (n_boot,) statistics; default the first column (the mean)."""
    if not 0.0 < level < 1.0:
        raise ValueError(f"level must lie in (0, 1), got {level}")
    rows = _rows(data)
    if len(rows) < 2:
        return float("nan"), float("nan")
    idx = np.random.default_rng(seed).integers(0, len(rows), size=(int(n_boot), len(rows)))
    means = rows[idx].mean(axis=1)  # (n_boot, k)
    stat = means[:, 0] if of is None else np.asarray(of(means), dtype=float)
    lo, hi = np.percentile(stat, [50.0 * (1.0 - level), 50.0 * (1.0 + level)])
    return float(lo), float(hi)


def mean_ci(values, **kwargs) -> tuple[float, float, float, int]:
    """(mean, low, high, n) of the finite values (None and NaN dropped); low/high nan below two values."""
    v = np.array([x for x in values if x is not None], dtype=float)
    v = v[np.isfinite(v)]
    if not v.size:
        return float("nan"), float("nan"), float("nan"), 0
    lo, hi = bootstrap_ci(v, **kwargs)
    return float(v.mean()), lo, hi, int(v.size)


def error_ci(abs_sum, sq_sum, frames, **kwargs) -> dict[str, tuple[float, float, float, int]]:
    """MAE and RMSE (deg) over trajectories, each (value, low, high, n trajectories): per trajectory its summed
    |error|, summed squared error and frame count; resampled whole trajectories, frames weighted as the evaluation
    pools them (MAE = sum |e| / frames, RMSE = sqrt(sum e^2 / frames))."""
    rows = np.stack([np.asarray(abs_sum, float), np.asarray(sq_sum, float), np.asarray(frames, float)], axis=1)
    total = rows.sum(axis=0)
    mae = bootstrap_ci(rows, of=lambda m: m[:, 0] / m[:, 2], **kwargs)
    rmse = bootstrap_ci(rows, of=lambda m: np.sqrt(m[:, 1] / m[:, 2]), **kwargs)
    n = len(rows)
    return {"mae": (float(total[0] / total[2]), *mae, n), "rmse": (float(np.sqrt(total[1] / total[2])), *rmse, n)}
