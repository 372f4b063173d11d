"""Static equilibrium: the activations that hold the arm still at an angle (minimum sum of squared activations).

Used to start episodes at rest on the target and by the reference controller's static optimisation.
"""
from __future__ import annotations

import numpy as np

GRAVITY = 9.81  # m/s^2 (the models' gravity)


def gravity_torque(angle_rad: np.ndarray) -> np.ndarray:
    """Joint torque of gravity on the tasks' arm (N m, positive elevates) at elevations (rad): it pulls the arm down
    (`arm.Arm.gravity_torque`, along the coupled path)."""
    from shoulder_bench.arm import arm

    return arm().gravity_torque(angle_rad)


def distribute(law, angle_rad: np.ndarray, torque: np.ndarray, upper=1.0, lower=0.0, iters: int = 60) -> np.ndarray:
    """Activations (B, n) in [lower, upper] that produce `torque` (B,) at rest and minimise sum a^2.

    The isometric torque is affine in each activation on its table cell, tau = p + s . a; the minimum-norm solution is
    a = clip(lambda * s), with the scalar lambda found by bisection (the torque rises monotonically in lambda).
    Where the target torque is out of reach the closest bound is returned.
    """
    angle_rad = np.atleast_1d(angle_rad).astype(float)
    b, n = len(angle_rad), len(law.muscles)
    zero = np.zeros(b)
    upper = np.broadcast_to(upper, (b, n)).astype(float)
    lower = np.broadcast_to(lower, (b, n)).astype(float)
    arm = law.moment_arm(angle_rad)
    slope = law.torque(angle_rad, zero, np.ones((b, n))) - law.torque(angle_rad, zero, np.zeros((b, n)))

    def tau(lam):
        a = np.clip(lam[:, None] * slope, lower, upper)
        return a, (law.force(angle_rad, zero, a) * arm).sum(axis=1)

    scale = np.maximum(np.abs(slope).max(axis=1), 1e-9)
    lo, hi = -1e3 / scale ** 2, 1e3 / scale ** 2  # wide enough that every activation saturates
    for _ in range(iters):
        mid = 0.5 * (lo + hi)
        _, t = tau(mid)
        low = t < torque
        lo = np.where(low, mid, lo)
        hi = np.where(low, hi, mid)
    return tau(0.5 * (lo + hi))[0]


def holding_activation(law, angle_deg) -> np.ndarray:
    """Activations (B, n) that hold the arm at rest at `angle_deg` against gravity."""
    a = np.radians(np.atleast_1d(angle_deg).astype(float))
    return distribute(law, a, -gravity_torque(a))


def static_capacity(law, angle_rad, off=()) -> np.ndarray:
    """(B,) the largest elevating torque at rest (N m): each muscle of the law fully on where that helps, off
    (passive only) otherwise; muscles in `off` held at activation 0."""
    angle_rad = np.atleast_1d(np.asarray(angle_rad, dtype=float))
    n, v = len(law.muscles), np.zeros_like(angle_rad)
    on = law.torque(angle_rad, v, np.ones((len(angle_rad), n)))
    rest = law.torque(angle_rad, v, np.zeros((len(angle_rad), n)))
    best = np.maximum(on, rest)
    for m in off:
        k = law.muscles.index(m)
        best[:, k] = rest[:, k]
    return best.sum(axis=1)


def rest_on_grid(deg: np.ndarray, net: np.ndarray) -> float:
    """Where the arm let go hanging settles, from the net torque (passive + gravity, N m) sampled on the ascending
    grid `deg`: from 0 deg, in the direction the torque pushes, the first sign change (linear interpolation; a zero
    with negative slope, a stable rest), or the end of the grid."""
    i0 = int(np.argmin(np.abs(deg)))
    if net[i0] == 0.0:
        return float(deg[i0])
    sign = 1.0 if net[i0] > 0 else -1.0
    d, t = (deg[i0:], net[i0:]) if sign > 0 else (deg[i0::-1], -net[i0::-1])
    k = np.nonzero((t[:-1] > 0) & (t[1:] <= 0))[0]
    if not len(k):
        return float(d[-1])
    k = int(k[0])
    return float(d[k] + (d[k + 1] - d[k]) * t[k] / (t[k] - t[k + 1]))


def reach_on_grid(deg: np.ndarray, capacity: np.ndarray, gravity: np.ndarray, top_deg: float):
    """How high muscles with torque `capacity` hold the arm against `gravity` (both N m, sampled on the ascending grid
    `deg`): the highest grid angle in [0, top_deg) up to which every angle from 0 is held; None if not even 0."""
    sel = (deg >= -1e-9) & (deg < top_deg - 1e-9)
    held = capacity[sel] >= -gravity[sel]
    first_not = len(held) if held.all() else int(np.argmin(held))
    return float(deg[sel][first_not - 1]) if first_not else None
