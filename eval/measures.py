"""The paper's qualitative findings as numbers, from recorded rollouts (`evaluate(..., record=True)["trace"]`).

- Saw-tooth: how often the change of activation flips sign, per muscle and second. The paper sees a saw-tooth in
  DQN's activations (discrete steps up and down) and a smooth curve from PPO. Frames where the activation does not
  change (|delta| < 1e-6, e.g. DQN's "hold" level or an activation resting at a bound) are skipped, so a flip is counted
  between consecutive changes.
- Early against late abduction: the share of ssp + isp in the summed activation of all muscles, over frames with the
  arm below 45 deg against at or above it. The paper sees ssp and isp initiate abduction and fade beyond it.

The ranking measures (issue 14 §3; docs/ranking.md):
- Success: a trajectory succeeds when its tracking error |angle - target| (on the 3-DOF tasks the humerus
  orientation error) is under SUCCESS_DEG (2 deg) on at least SUCCESS_SHARE (90 %) of its frames; the frames after a
  crash count as failed. The success rate is the share of
  trajectories that succeed.
- Effort: the mean over recorded frames of the summed squared activations, sum_i a_i^2 (per frame, not per muscle).
- Mean |delta a|: the mean over muscles and consecutive recorded frames of |a_t - a_(t-1)| (activation per frame).
- Co-contraction: sum over frames and muscles of a_i where muscle i's torque has the opposite sign to the net muscle
  torque (the sum over muscles) — on the 3-DOF tasks, where its torque vector (plane, elevation, rotation) has a
  negative dot product with the net one — divided by the sum of a_i over frames and muscles. The torques are the
  task's force law at the recorded angle and activation, isometric (joint velocity 0: the force-velocity factor is
  1), active and passive force through the tabled moment arms. 0 = no activation works against the muscles' net
  torque; a one-muscle task is 0 by definition.
"""
from __future__ import annotations

import numpy as np

from shoulder_bench.protocol import CRASH_ERROR_DEG, FRAME_S

EARLY_DEG = 45.0
STILL = 1e-6
SUCCESS_DEG = 2.0
SUCCESS_SHARE = 0.9


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


def tracking_error(trace: dict, frames) -> np.ndarray:
    """(B, T) tracking error (deg) of a recorded evaluation as the evaluation scores it — |angle - target|, or the
    trace's "error_deg" where it has one (the 3-DOF tasks' orientation error) — with the frames after a crash
    (recorded NaN up to the trajectory's frames[b]) at the crash error, NaN after the trajectory's end."""
    err = (np.asarray(trace["error_deg"], float) if "error_deg" in trace
           else np.abs(np.asarray(trace["angle_deg"], float) - np.asarray(trace["target_deg"], float)))
    frames = np.asarray(frames, dtype=int)
    if err.ndim != 2 or len(frames) != len(err) or (frames > err.shape[1]).any() or (frames < 1).any():
        raise ValueError(f"tracking_error: a (B, T) trace {err.shape} and B frame counts in 1..T; got {frames.shape}")
    inside = np.arange(err.shape[1])[None, :] < frames[:, None]
    return np.where(inside & np.isnan(err), CRASH_ERROR_DEG, np.where(inside, err, np.nan))


def successes(error_deg: np.ndarray, frames, tol_deg: float = SUCCESS_DEG, share: float = SUCCESS_SHARE) -> np.ndarray:
    """(B,) bool: trajectory b succeeds when its error (B, T) is under tol_deg on at least `share` of its frames[b]
    frames (NaN frames within them count as failed)."""
    frames = np.asarray(frames, dtype=int)
    within = np.nan_to_num(np.asarray(error_deg, float), nan=np.inf) < tol_deg
    if within.ndim != 2 or len(frames) != len(within) or (frames > within.shape[1]).any() or (frames < 1).any():
        raise ValueError(f"successes: an error (B, T) {within.shape} and B frame counts in 1..T; got {frames.shape}")
    good = np.array([within[b, :frames[b]].sum() for b in range(len(frames))])
    return good >= share * frames


def effort(activation: np.ndarray) -> float:
    """Mean over recorded frames of sum_i a_i^2; activation (B, T, n), NaN-padded."""
    a = activation[~np.isnan(activation).any(axis=-1)]
    return float((a ** 2).sum(axis=1).mean()) if len(a) else float("nan")


def mean_abs_delta(activation: np.ndarray) -> float:
    """Mean |a_t - a_(t-1)| over muscles and pairs of consecutive recorded frames; activation (B, T, n)."""
    d = np.abs(np.diff(activation, axis=1))
    d = d[~np.isnan(d).any(axis=-1)]
    return float(d.mean()) if d.size else float("nan")


def co_contraction(angle_deg: np.ndarray, activation: np.ndarray, law) -> float:
    """Share of the summed activation in muscles whose (isometric) torque opposes the net muscle torque; `law` a
    `ForceLaw` of the task's muscles (its `torque(angle rad, velocity rad/s, activation)`, (F, muscles)), or on the
    3-DOF tasks a law whose torque takes angles (F, 3) and gives (F, muscles, 3) (`board3.TorqueLaw3`)."""
    bad = np.isnan(angle_deg)
    ok = ~(bad.any(axis=-1) if bad.ndim == activation.ndim else bad) & ~np.isnan(activation).any(axis=-1)
    q, a = np.radians(angle_deg[ok]), activation[ok]
    if a.shape[-1] != len(law.muscles):
        raise ValueError(f"co_contraction: {a.shape[-1]} activations for a law of {len(law.muscles)} muscles")
    total = a.sum()
    if not len(a) or total <= 0:
        return float("nan")
    tau = law.torque(q, np.zeros_like(q), a)
    tau = tau[..., None] if tau.ndim == 2 else tau  # (F, muscles, DOFs)
    opposing = (tau * tau.sum(axis=1, keepdims=True)).sum(axis=-1) < 0
    return float(a[opposing].sum() / total)


def measures(trace: dict, muscles, law=None) -> dict:
    """The leaderboard's qualitative columns for one recorded evaluation (co-contraction where `law` is given)."""
    out = {"sawtooth_per_s": sawtooth_rate(trace["activation"]), "effort": effort(trace["activation"]),
           "mean_abs_delta": mean_abs_delta(trace["activation"])}
    if law is not None:
        out["co_contraction"] = co_contraction(trace["angle_deg"], trace["activation"], law)
    if {"ssp", "isp"} <= set(muscles) and len(muscles) > 2:
        out["early_share"], out["late_share"] = early_late_share(trace["angle_deg"], trace["activation"], muscles)
    return out
