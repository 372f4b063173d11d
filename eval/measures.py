"""The paper's qualitative findings as numbers, from recorded rollouts (`evaluate(..., record=True)["trace"]`).

- Saw-tooth: how often the change of activation flips sign, per muscle and second. The paper sees a saw-tooth in
  DQN's activations (discrete steps up and down) and a smooth curve from PPO. Frames where the activation does not
  change (|delta| < 1e-6, e.g. DQN's "hold" level or an activation resting at a bound) are skipped, so a flip is counted
  between consecutive changes.
- Early against late abduction: the share of ssp + isp in the summed activation of all muscles, over frames with the
  arm below 45 deg against at or above it. The paper sees ssp and isp initiate abduction and fade beyond it.
"""
from __future__ import annotations

import numpy as np

from shoulder_bench.protocol import FRAME_S

EARLY_DEG = 45.0
STILL = 1e-6


def sawtooth_rate(activation: np.ndarray, frame_s: float = FRAME_S) -> float:
    """Sign changes of delta-activation per second, averaged over muscles; activation (B, T, n), NaN-padded."""
    flips, muscle_seconds = 0, 0.0
    for traj in activation:
        live = traj[~np.isnan(traj).any(axis=1)]
        if len(live) < 3:
            continue
        muscle_seconds += len(live) * frame_s * traj.shape[1]
        for delta in np.diff(live, axis=0).T:
            moving = np.sign(delta[np.abs(delta) >= STILL])
            flips += int(np.count_nonzero(moving[1:] != moving[:-1]))
    return flips / muscle_seconds if muscle_seconds else float("nan")


def early_late_share(angle_deg: np.ndarray, activation: np.ndarray, muscles: list[str] | tuple[str, ...],
                     pair: tuple[str, ...] = ("ssp", "isp")) -> tuple[float, float]:
    """(share below EARLY_DEG, share at or above it) of `pair`'s activation in all muscles' summed activation."""
    missing = [m for m in pair if m not in muscles]
    if missing:
        raise ValueError(f"muscles {missing} are not in this task ({', '.join(muscles)})")
    idx = [list(muscles).index(m) for m in pair]
    ok = ~np.isnan(angle_deg)
    a, q = activation[ok], angle_deg[ok]

    def share(mask: np.ndarray) -> float:
        total = a[mask].sum()
        return float(a[mask][:, idx].sum() / total) if total > 0 else float("nan")

    return share(q < EARLY_DEG), share(q >= EARLY_DEG)


def measures(trace: dict, muscles) -> dict:
    """The leaderboard's qualitative columns for one recorded evaluation."""
    out = {"sawtooth_per_s": sawtooth_rate(trace["activation"])}
    if {"ssp", "isp"} <= set(muscles) and len(muscles) > 2:
        out["early_share"], out["late_share"] = early_late_share(trace["angle_deg"], trace["activation"], muscles)
    return out
