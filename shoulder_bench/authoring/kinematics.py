"""Poses the v2 (MoBL-ARMS) shoulder and computes tendon moment arms the way the reference tables were made.

Method (../shared/reference/moment_arms/README.md section 4, models/reference/README.md):

1. Posing: the three GH coordinates are set directly; every slaved coordinate is set from the model's own joint
   equality polynomials (`eq_data`), no iterative assembly. Girdle `fixed`: the couplings driven by shoulder_elv are
   skipped (clavicle and scapula at rest), only shoulder1_r2 = -elv_angle is applied. Girdle `coupled`: all are.
   Then `mj_kinematics`, `mj_comPos`, `mj_tendon`.
2. Moment arm r = -dL/dq (mm; q in rad) by central differences with h = 0.25 deg, one GH coordinate at a time, the
   slaved coordinates re-evaluated at q +/- h (so the coupled shoulder_elv arm is the total derivative).
3. Where the central difference disagrees with the analytic derivative (the tendon Jacobian `ten_J` with the
   coupling chain rule) by more than 0.5 mm, the stencil straddles a path-length jump (a wrap switching sides): the
   one-sided difference closer to the analytic value is reported instead.

Positive r: tension tends to increase the coordinate (shoulder_elv: elevation; shoulder_rot: internal rotation;
elv_angle: the plane moves anteriorly).

    >>> from shoulder_bench.authoring.kinematics import ShoulderPoser, moment_arms
    >>> r = moment_arms(model, ["ssp", "dmi"], [(0, 30, 0), (30, 90, 0)], girdle="coupled")
    >>> r["shoulder_elv"].shape   # (poses, tendons), mm
"""
from __future__ import annotations

import mujoco
import numpy as np

from shoulder_bench.arm import polycoef_slope, polycoef_value
from shoulder_bench.geometry import tendon_jacobian

GH_COORDINATES = ("elv_angle", "shoulder_elv", "shoulder_rot")
GIRDLES = ("fixed", "coupled")
H_DEG = 0.25
JUMP_TOL_MM = 0.5
GIRDLE_DRIVER = "shoulder_elv"  # couplings driven by it are the girdle rhythm


class ShoulderPoser:
    """Sets a v2 model's pose from (plane of elevation, elevation, axial rotation) and a girdle mode."""

    def __init__(self, model: mujoco.MjModel):
        self.m, self.d = model, mujoco.MjData(model)
        m = model
        self.qadr = {m.joint(i).name: int(m.jnt_qposadr[i]) for i in range(m.njnt)}
        self.dadr = {m.joint(i).name: int(m.jnt_dofadr[i]) for i in range(m.njnt)}
        missing = [c for c in GH_COORDINATES if c not in self.qadr]
        if missing:
            raise ValueError(f"the model has no joint(s) {missing}; it is not the v2 (MoBL) shoulder")
        self.couplings = []  # (dependent, driver, polycoef c0..c4)
        for e in range(m.neq):
            if m.eq_type[e] == mujoco.mjtEq.mjEQ_JOINT and m.eq_active0[e]:
                self.couplings.append((m.joint(int(m.eq_obj1id[e])).name, m.joint(int(m.eq_obj2id[e])).name,
                                       m.eq_data[e, :5].copy()))

    def _active(self, girdle: str):
        if girdle not in GIRDLES:
            raise ValueError(f"girdle must be one of {GIRDLES}, not {girdle!r}")
        return [c for c in self.couplings if not (girdle == "fixed" and c[1] == GIRDLE_DRIVER)]

    def pose(self, plane: float, elevation: float, rotation: float, girdle: str) -> mujoco.MjData:
        """Angles in radians. Returns the MjData with kinematics, COM quantities and tendons computed."""
        m, d = self.m, self.d
        d.qpos[:] = m.qpos0
        for name, q in zip(GH_COORDINATES, (plane, elevation, rotation)):
            d.qpos[self.qadr[name]] = q
        for dep, drv, c in self._active(girdle):
            x = d.qpos[self.qadr[drv]] - m.qpos0[self.qadr[drv]]
            d.qpos[self.qadr[dep]] = m.qpos0[self.qadr[dep]] + polycoef_value(c, x)
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        mujoco.mj_tendon(m, d)
        return d

    def lengths(self, tendon_ids, angles, girdle: str) -> np.ndarray:
        return self.pose(*angles, girdle).ten_length[tendon_ids].copy()

    def jacobian_arms(self, tendon_ids, angles, girdle: str) -> dict[str, np.ndarray]:
        """Analytic -dL/dq (m) per GH coordinate from `ten_J`, the slaved joints by the chain rule."""
        m = self.m
        d = self.pose(*angles, girdle)
        J = tendon_jacobian(m, d)
        out = {}
        for name in GH_COORDINATES:
            dq = np.zeros(m.nv)
            dq[self.dadr[name]] = 1.0
            for dep, drv, c in self._active(girdle):
                if drv == name:
                    x = d.qpos[self.qadr[drv]] - m.qpos0[self.qadr[drv]]
                    dq[self.dadr[dep]] = polycoef_slope(c, x)
            out[name] = -(J[tendon_ids] @ dq)
        return out


def moment_arms(model: mujoco.MjModel, tendons, poses_deg, girdle: str = "fixed", h_deg: float = H_DEG,
                jump_tol_mm: float = JUMP_TOL_MM) -> dict[str, np.ndarray]:
    """Moment arms (mm) of `tendons` (names) about each GH coordinate at `poses_deg`, a sequence of
    (plane of elevation, elevation, axial rotation) in degrees, girdle `fixed` or `coupled`.

    Returns {coordinate: array (len(poses), len(tendons))}, by the reference tables' method (module docstring)."""
    poser = ShoulderPoser(model)
    tid = [model.tendon(t).id for t in tendons]
    h = np.radians(h_deg)
    out = {c: np.zeros((len(poses_deg), len(tid))) for c in GH_COORDINATES}
    for p, pose in enumerate(poses_deg):
        base = np.radians(np.asarray(pose, dtype=float))
        L0 = poser.lengths(tid, base, girdle)
        ana = poser.jacobian_arms(tid, base, girdle)
        for k, name in enumerate(GH_COORDINATES):
            step = np.zeros(3)
            step[k] = h
            Lp, Lm = poser.lengths(tid, base + step, girdle), poser.lengths(tid, base - step, girdle)
            cen, fwd, bwd = -(Lp - Lm) / (2 * h), -(Lp - L0) / h, -(L0 - Lm) / h
            rj = ana[name]
            one_sided = np.where(np.abs(fwd - rj) < np.abs(bwd - rj), fwd, bwd)
            jump = np.abs(cen - rj) * 1000 > jump_tol_mm
            out[name][p] = np.where(jump, one_sided, cen) * 1000
    return out
