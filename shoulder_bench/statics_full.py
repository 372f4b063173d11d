"""Statics of the full shoulder: the gravity torque in the three coordinates and the holding activations (static
optimisation), for the 3-DOF tasks' rest starts and the reference controller.

At rest on the couplings the reduced equilibrium is sum_t F_t(L_t(q), a_m(t)) r_t(q) = S(q)^T qfrc_bias(q, 0)
(r_t = -ten_J S the moment arms about plane, elevation, rotation; qfrc_bias at zero velocity is gravity; the
coupling constraint forces do no work along S). Static optimisation: the activations in [0, 1] of least sum a^2 that
meet the three equations (SLSQP with the law's exact piecewise-linear slopes); where no activations meet them (a pose
the muscles cannot hold), those of least squared residual, then least effort.
"""
from __future__ import annotations

import mujoco
import numpy as np
from scipy.optimize import lsq_linear, minimize

from shoulder_bench import full_arm

FEASIBLE_NM = 1e-3  # a residual above this (N m, any coordinate) means the pose cannot be held
TORQUE_WEIGHT = 1e3  # `distribute`: (N m)^-2 weight of the torque residual against the sum of a^2
LEVEL_PASSES = 1  # `solve`: passes after the first where the arms depend on the activation (band level tables)


class Statics:
    """Gravity torque and holding activations of `law` (a `TendonLaw` of the full shoulder's muscles) on `pose`."""

    def __init__(self, law, pose: full_arm.Pose | None = None):
        self.law, self.pose = law, pose or full_arm.Pose()
        self._d = mujoco.MjData(self.pose.m)

    def gravity(self, pose_deg) -> np.ndarray:
        """(3,) S^T qfrc_bias at rest (N m): what the muscles must supply to hold the pose."""
        m, d = self.pose.m, self._d
        d.qpos[:] = self.pose.qpos(pose_deg)[0]
        d.qvel[:] = 0.0
        mujoco.mj_forward(m, d)
        return self.pose.slopes(pose_deg).T @ d.qfrc_bias

    def torque_and_jacobian(self, L: np.ndarray, r: np.ndarray, a: np.ndarray, velocity: np.ndarray | None = None,
                            departures: np.ndarray | None = None):
        """(torque (3,), d torque / d a (3, muscles)) at tendon lengths L (n,), moment arms r (n, 3), activations a
        (muscles,) and the band tendons' fibres' departures (nt, n; `TendonLaw.departures`, None: one length); the
        law is piecewise linear in a, so the slopes are exact within a level cell."""
        law, n = self.law, len(a)
        v = np.zeros((1, len(L))) if velocity is None else velocity[None]
        up = np.minimum(a + 1e-6, 1.0)
        lo = np.maximum(up - 1e-6, 0.0)
        batch = np.repeat(a[None], 2 * n + 1, axis=0)  # row 0: a; rows 1..n: a_k up; rows n+1..2n: a_k down
        batch[1 + np.arange(n), np.arange(n)] = up
        batch[1 + n + np.arange(n), np.arange(n)] = lo
        f = law.force(np.repeat(L[None], len(batch), axis=0), np.repeat(v, len(batch), axis=0), batch,
                      None if departures is None else departures[None])
        tau = f @ r  # (2n + 1, 3)
        jac = ((tau[1:n + 1] - tau[n + 1:]) / (up - lo)[:, None]).T
        return tau[0], jac

    def solve(self, pose_deg, torque: np.ndarray, start: np.ndarray | None = None) -> tuple[np.ndarray, float]:
        """(activations (muscles,), largest |residual| N m) of least effort that produce `torque` (3,) at rest at
        `pose_deg`. Where a band's line depends on the activation (`band_lines`' level tables), solved again
        LEVEL_PASSES times with the arms at the activations found before (the first pass: at a = 1)."""
        lines = getattr(self.law, "lines", None)
        a, fibres = None, self.law.departures(np.asarray(pose_deg, dtype=float))
        for _ in range(1 + (LEVEL_PASSES if lines is not None and len(lines.levels) > 1 else 0)):
            L, r = self.law.geometry(self.pose, np.asarray(pose_deg, dtype=float), a)
            a, residual = self._solve_at(L[0], r[0], torque, start if a is None else a,
                                         None if fibres is None else fibres[0])
        return a, residual

    def _solve_at(self, L: np.ndarray, r: np.ndarray, torque: np.ndarray, start,
                  fibres: np.ndarray | None = None) -> tuple[np.ndarray, float]:
        n = len(self.law.muscles)
        x0 = np.full(n, 0.05) if start is None else np.clip(start, 0.0, 1.0)
        cons = {"type": "eq", "fun": lambda a: self.torque_and_jacobian(L, r, a, None, fibres)[0] - torque,
                "jac": lambda a: self.torque_and_jacobian(L, r, a, None, fibres)[1]}
        res = minimize(lambda a: float(a @ a), x0, jac=lambda a: 2 * a, bounds=[(0.0, 1.0)] * n,
                       constraints=[cons], method="SLSQP", options={"maxiter": 200, "ftol": 1e-10})
        a = np.clip(res.x, 0.0, 1.0)
        residual = float(np.abs(self.torque_and_jacobian(L, r, a, None, fibres)[0] - torque).max())
        if residual > FEASIBLE_NM:  # cannot be met: least squared residual (then a little effort)
            def fun(a):
                tau, jac = self.torque_and_jacobian(L, r, a, None, fibres)
                e = tau - torque
                return float(e @ e + 1e-4 * a @ a), 2 * jac.T @ e + 2e-4 * a
            res = minimize(fun, a, jac=True, bounds=[(0.0, 1.0)] * n, method="L-BFGS-B")
            a = np.clip(res.x, 0.0, 1.0)
            residual = float(np.abs(self.torque_and_jacobian(L, r, a, None, fibres)[0] - torque).max())
        return a, residual

    def distribute(self, L: np.ndarray, r: np.ndarray, velocity: np.ndarray, torque: np.ndarray, a0: np.ndarray,
                   lower: np.ndarray, upper: np.ndarray, departures: np.ndarray | None = None) -> np.ndarray:
        """Activations in [lower, upper] that produce `torque` (3,) with least effort, the law linearised at `a0`
        (exact within its activation cells; the controller moves a by <= 1 % a frame): bounded least squares of
        TORQUE_WEIGHT |J a - (torque - tau(a0) + J a0)|^2 + |a|^2 (scipy's lsq_linear). L (n,), r (n, 3): tendon
        lengths and moment arms; velocity (n,): tendon lengthening rates (the force-velocity factor); departures
        (nt, n): the band tendons' fibres' (`torque_and_jacobian`)."""
        tau0, jac = self.torque_and_jacobian(L, r, a0, velocity, departures)
        w = np.sqrt(TORQUE_WEIGHT)
        A = np.vstack([w * jac, np.eye(len(a0))])
        b = np.concatenate([w * (torque - tau0 + jac @ a0), np.zeros(len(a0))])
        return lsq_linear(A, b, bounds=(lower, np.maximum(upper, lower + 1e-12)), method="bvls").x

    def holding(self, pose_deg, start: np.ndarray | None = None) -> tuple[np.ndarray, float]:
        """(activations, largest |residual| N m) that hold `pose_deg` (deg) at rest against gravity."""
        return self.solve(pose_deg, self.gravity(pose_deg), start)

    def held(self, poses_deg) -> tuple[np.ndarray, np.ndarray]:
        """(whether each of `poses_deg` (P, 3) is held: residual <= FEASIBLE_NM, (P,) bool; the largest holding
        activation there (P,)): the workspace the muscles can hold against gravity."""
        rows = [self.holding(p) for p in np.asarray(poses_deg, dtype=float)]
        return (np.array([r <= FEASIBLE_NM for _, r in rows], dtype=bool),
                np.array([a.max() for a, _ in rows], dtype=float))
