"""Compiling an MJCF whose actuators are `user` ones, and its tendon geometry: lengths, moment arms, Jacobian.

No force law here: the law (`muscle`) reads v1's moment arms from this module, and the callback (`model`) attaches
the law to models compiled by it.
"""
from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np

from shoulder_bench.paths import MODEL_PATH

JOINT = "abduction"  # model v1's joint


def forces_as_controls(m: mujoco.MjModel) -> mujoco.MjModel:
    """Make `m`'s actuators plain, in place: fixed gain 1, no bias, no control limits, so that each control is the
    force along its tendon (the numpy engine's acceleration oracle, the MJX backend, `benchmarks/warp_check.py`)."""
    m.actuator_gaintype[:] = mujoco.mjtGain.mjGAIN_FIXED
    m.actuator_gainprm[:] = 0.0
    m.actuator_gainprm[:, 0] = 1.0
    m.actuator_biastype[:] = mujoco.mjtBias.mjBIAS_NONE
    m.actuator_biasprm[:] = 0.0
    m.actuator_ctrllimited[:] = 0
    return m


def compile_model(path: Path | str = MODEL_PATH, prepare=None, *, xml: str | None = None) -> mujoco.MjModel:
    """Compile an MJCF file (`path`) or MJCF text (`xml`) whose actuators may be `user` ones while the muscle
    callbacks are installed (thread-safe), then call `prepare(model)` if given (e.g. `arm.harden_couplings`).

    The `user` gains and biases are compiled as fixed gain / no bias, so that compiling never calls the callbacks, and
    set back to `user` in the compiled model.
    """
    spec = mujoco.MjSpec.from_string(xml) if xml is not None else mujoco.MjSpec.from_file(str(path))
    user_gain, user_bias = [], []
    for k, act in enumerate(spec.actuators):
        if act.gaintype == mujoco.mjtGain.mjGAIN_USER:
            act.gaintype = mujoco.mjtGain.mjGAIN_FIXED
            user_gain.append(k)
        if act.biastype == mujoco.mjtBias.mjBIAS_USER:
            act.biastype = mujoco.mjtBias.mjBIAS_NONE
            user_bias.append(k)
    m = spec.compile()
    m.actuator_gaintype[user_gain] = mujoco.mjtGain.mjGAIN_USER
    m.actuator_biastype[user_bias] = mujoco.mjtBias.mjBIAS_USER
    if prepare is not None:
        prepare(m)
    return m


def tendon_geometry(angle_deg, path: Path | str = MODEL_PATH) -> tuple[dict, dict]:
    """(tendon lengths (m), moment arms (m, positive = elevates the arm)) per tendon at the given abduction angles."""
    m = compile_model(path)
    d = mujoco.MjData(m)
    jnt = m.joint(JOINT)
    angles = np.radians(np.atleast_1d(angle_deg))
    lengths, arms = np.zeros((len(angles), m.ntendon)), np.zeros((len(angles), m.ntendon))
    for k, a in enumerate(angles):
        d.qpos[jnt.qposadr[0]] = a
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        mujoco.mj_tendon(m, d)
        lengths[k] = d.ten_length
        arms[k] = -tendon_jacobian(m, d)[:, jnt.dofadr[0]]
    names = [m.tendon(t).name for t in range(m.ntendon)]
    return ({n: lengths[:, t] for t, n in enumerate(names)}, {n: arms[:, t] for t, n in enumerate(names)})


def moment_arms(angle_deg, path: Path | str = MODEL_PATH) -> dict[str, np.ndarray]:
    """MJCF tendon moment arms (m, positive = elevates the arm) at the given abduction angles."""
    return tendon_geometry(angle_deg, path)[1]


def tendon_jacobian(m: mujoco.MjModel, d: mujoco.MjData) -> np.ndarray:
    """Dense (ntendon, nv) tendon Jacobian dL/dq, whether MuJoCo stores it sparse or dense."""
    if not mujoco.mj_isSparse(m):
        return np.asarray(d.ten_J).reshape(m.ntendon, m.nv).copy()
    dense = np.zeros((m.ntendon, m.nv))
    mujoco.mju_sparse2dense(dense, d.ten_J, d.ten_J_rownnz, d.ten_J_rowadr, d.ten_J_colind)
    return dense
