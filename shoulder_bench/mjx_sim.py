"""The tasks' arm on MJX (MuJoCo in JAX): N copies stepped on the JAX device (a GPU, or the CPU for the tests), with
the muscle force law written in JAX. Optional: needs the `[mjx]` extra (`pip install shoulder-bench[mjx]`).

MJX refuses `user` gains and biases (`mjx.put_model`: mjGAIN_USER / mjBIAS_USER are not implemented), so the design
of the batched simulator's numpy engine (`simulator.BatchSimulator`, engine="numpy") is carried over: the actuators
become plain fixed-gain ones (gain 1, no bias, no control limits), the law is evaluated outside the engine at every
RK4 stage and its (pulling) forces go in as controls, and `mjx.forward` supplies the acceleration (`qacc`). The RK4 is
MuJoCo's tableau and summation order, the law is `muscle.law_point`'s arithmetic on the law's own tables
(`ForceLaw.kernel_arguments`), and the constraint solver's warmstart follows the MuJoCo backend (engine="mujoco": one
`rollout` per frame, each frame from a zero warmstart, within it every step's four stages from the previous step's
last-stage acceleration). The model's joint equalities (the girdle's polycoef couplings), its joint limit, spatial
tendons with sphere/cylinder wrapping and its Newton solver are all supported by MJX 3.17.

The law covers every actuator of the model (6 columns for the v2 arm) with zero tables for the actuators a task does
not drive (their force is then exactly 0, as in the MuJoCo backend where their control stays 0). Each `MjxArm`
compiles its own frame with the MJX model as a constant (passed as an argument, the model makes XLA's CPU code of
`mjx.forward` ~10^4 x slower); the law's arrays are arguments, so that frame serves every law of the same table grid.
The inside-wrap solver takes MuJoCo's settings (`WRAP_INSIDE`), not `mjx.put_model`'s looser ones.

Precision: float64 (`dtype="float64"`, the default on every device) agrees with the MuJoCo backend to rounding
amplified by the model's conditioning: the placeholder girdle bodies make the mass matrix ill-conditioned, so the same
acceleration computed by MJX's dense Cholesky and MuJoCo's sparse factorisation differs by up to ~1e-7 relative in
single evaluations (docs/gpu.md gives the measured bounds per frame and per 20 s episode). float32 does not survive
that conditioning (cond(M) = 2.7e8 at 60 deg, beyond float32's 1 / eps = 1.7e7): its unconstrained accelerations
(~1e8 rad/s^2, which the girdle's equality constraints cancel down to O(1)) come out a factor 2 off and the first
frame's accelerations are zero or NaN, so float32 is kept only for its (failing) drift test.
"""
from __future__ import annotations

import contextlib
from functools import partial

import jax
import jax.numpy as jnp
import numpy as np
from mujoco import mjx

from shoulder_bench import arm as arm_
from shoulder_bench.geometry import forces_as_controls
from shoulder_bench.muscle import FV_MAX

DTYPES = ("float64", "float32")
DEFAULT_DTYPE = "float64"  # on every device: float32 does not carry this model (module docstring)
RK4_STAGE_A = (0.0, 0.5, 0.5, 1.0)  # each stage's state = start + (previous stage's derivative x a) h (MuJoCo's RK4)
RK4_B = (1 / 6, 1 / 3, 1 / 3, 1 / 6)
MAX_ACCELERATION = 1e10  # MuJoCo's mjMAXVAL: beyond it MuJoCo resets the copy (the single env's crash)
BISECTION_STEPS = 60  # statics.distribute's iterations


def check_dtype(dtype) -> str:
    name = np.dtype(dtype).name if not isinstance(dtype, str) else dtype
    if name not in DTYPES:
        raise ValueError(f"dtype must be one of {DTYPES}, got {dtype!r}")
    return name


def precision(dtype: str):
    """The JAX context a computation in `dtype` runs in: 64-bit types on for float64, off for float32 (whatever the
    process's default), and full-precision matrix products (no TF32 on GPUs)."""
    stack = contextlib.ExitStack()
    stack.enter_context(jax.enable_x64(dtype == "float64"))
    stack.enter_context(jax.default_matmul_precision("highest"))
    return stack


def law_arrays(law, actuators: tuple[str, ...], dtype: str) -> dict:
    """The force law `law` (a `ForceLaw`) over all model `actuators` (zero tables for those it does not drive), as
    device arrays: table (K, J, nu) with column 0 of J the passive force, moment arms (K, nu), activation levels (J,),
    grid origin and 1/step (rad), -1/FV velocity scale (nu,), and `src` (nu,): the muscle whose activation drives each
    actuator (n_muscles, an always-zero column, for the undriven ones)."""
    flat, arm, levels, a0, inv_da, nivs = law.kernel_arguments()
    k, n, j = arm.shape[0], arm.shape[1], len(levels)
    table = np.zeros((k, j, len(actuators)))
    arms = np.zeros((k, len(actuators)))
    scale = np.full(len(actuators), -1.0)
    src = np.full(len(actuators), len(law.muscles))
    for c, name in enumerate(law.actuators):
        col = actuators.index(name)
        table[:, :, col] = flat.reshape(k, j, n)[:, :, c]
        arms[:, col] = arm[:, c]
        scale[col] = nivs[c]
        src[col] = law.muscle_of[c]
    f = np.dtype(dtype)
    with precision(dtype):
        return {"table": jnp.asarray(table, f), "arm": jnp.asarray(arms, f), "levels": jnp.asarray(levels, f),
                "a0": jnp.asarray(a0, f), "inv_da": jnp.asarray(inv_da, f), "nivs": jnp.asarray(scale, f),
                "src": jnp.asarray(src, np.int32)}


def _cell(law, angle):
    """(i, w): grid cell and weight of each angle (B,), beyond the grid at its edges (`muscle.law_cell`)."""
    kmax = law["arm"].shape[0] - 1.000001
    x = jnp.clip((angle - law["a0"]) * law["inv_da"], 0.0, kmax)
    i = x.astype(jnp.int32)
    return i, x - i


def per_actuator(law, act):
    """(B, nu) activations of the actuators from the muscles' (B, n_muscles); 0 where no muscle drives one."""
    padded = jnp.concatenate([act, jnp.zeros_like(act[:, :1])], axis=1)
    return padded[:, law["src"]]


def force(law, angle, velocity, act):
    """(B, nu) tendon forces (N, pulling) at angles (B,) rad, velocities (B,) rad/s and actuator activations (B, nu):
    `ForceLaw.force`, the arithmetic of `muscle.law_point` in the same order."""
    tab, levels = law["table"], law["levels"]
    i, w = _cell(law, angle)
    ii, wi = i[:, None], w[:, None]
    c = jnp.arange(tab.shape[2])[None, :]
    a = jnp.clip(act, 0.0, 1.0)
    j = jnp.sum(levels[1:-1][None, None, :] <= a[:, :, None], axis=2)  # the while loop of law_point
    u = (a - levels[j]) / (levels[j + 1] - levels[j])
    p0 = tab[ii, 0, c]
    passive = p0 + (tab[ii + 1, 0, c] - p0) * wi
    lo = tab[ii, j, c] + (tab[ii + 1, j, c] - tab[ii, j, c]) * wi
    hi = tab[ii, j + 1, c] + (tab[ii + 1, j + 1, c] - tab[ii, j + 1, c]) * wi
    active = lo + (hi - lo) * u - passive
    r = law["arm"][i] + (law["arm"][i + 1] - law["arm"][i]) * wi
    v = r * velocity[:, None] * law["nivs"]
    shorten = jnp.maximum(v + 1.0, 0.0)
    lengthen = jnp.maximum(FV_MAX - 1.0 - v, 0.0)
    fv = jnp.where(v <= 0.0, shorten * shorten, FV_MAX - lengthen * lengthen / (FV_MAX - 1.0))
    return active * fv + passive


def moment_arm(law, angle):
    """(B, nu) tabled tendon moment arms (m) at angles (B,) rad (`ForceLaw.moment_arm`)."""
    i, w = _cell(law, angle)
    return law["arm"][i] + (law["arm"][i + 1] - law["arm"][i]) * w[:, None]


def muscle_torque(law, angle, act_m):
    """(B, n_muscles) joint torques at rest (N m, + elevates) of muscle activations (B, n_muscles), each muscle's the
    sum over its actuators (`ForceLaw.torque` at zero velocity)."""
    per = force(law, angle, jnp.zeros_like(angle), per_actuator(law, act_m)) * moment_arm(law, angle)
    return jnp.zeros((angle.shape[0], act_m.shape[1] + 1), per.dtype).at[:, law["src"]].add(per)[:, :-1]


def holding_activation(law, gravity, angle_deg, n_muscles: int):
    """(B, n_muscles) activations that hold the arm at rest at `angle_deg` (B,) against gravity: the bisection of
    `statics.distribute` (minimum sum of squares, lambda bracketed by +-1e3 / max|slope|^2, 60 halvings) on the
    device. gravity: (grid (G,) rad, gravity torque (G,) N m) of the arm, interpolated linearly as `Arm` does."""
    angle = jnp.radians(angle_deg)
    torque = -jnp.interp(angle, gravity[0], gravity[1])
    b = angle.shape[0]
    ones, zeros = jnp.ones((b, n_muscles), angle.dtype), jnp.zeros((b, n_muscles), angle.dtype)
    slope = muscle_torque(law, angle, ones) - muscle_torque(law, angle, zeros)
    arm = moment_arm(law, angle)

    def tau(lam):
        a = jnp.clip(lam[:, None] * slope, 0.0, 1.0)
        return a, (force(law, angle, jnp.zeros_like(angle), per_actuator(law, a)) * arm).sum(axis=1)

    scale = jnp.maximum(jnp.abs(slope).max(axis=1), 1e-9)

    def halve(_, bracket):
        lo, hi = bracket
        mid = 0.5 * (lo + hi)
        low = tau(mid)[1] < torque
        return jnp.where(low, mid, lo), jnp.where(low, hi, mid)

    lo, hi = jax.lax.fori_loop(0, BISECTION_STEPS, halve, (-1e3 / scale ** 2, 1e3 / scale ** 2))
    return tau(0.5 * (lo + hi))[0]


holding = jax.jit(holding_activation, static_argnames=("n_muscles",))


def _qacc(mx, data, qpos, qvel, ctrl, warm):
    return mjx.forward(mx, data.replace(qpos=qpos, qvel=qvel, ctrl=ctrl, qacc_warmstart=warm)).qacc


_batched_qacc = jax.vmap(_qacc, in_axes=(None, None, 0, 0, 0, 0))
BATCHING = ("vmap", "map")


def _accelerations(mx, data, qpos, qvel, ctrl, warm, batching: str):
    """(B, nv) `mjx.forward` accelerations of a batch: `jax.vmap` (GPUs), or `jax.lax.map`, one copy after another
    (the CPU: there XLA runs the vmapped forward of this model, with its constraint solver, orders of magnitude
    slower than B single ones; measured in docs/gpu.md)."""
    if batching == "vmap":
        return _batched_qacc(mx, data, qpos, qvel, ctrl, warm)
    return jax.lax.map(lambda x: _qacc(mx, data, *x), (qpos, qvel, ctrl, warm))


def _frame(mx, data, law, qpos, qvel, act, qadr: int, dadr: int, steps: int, batching: str):
    """`steps` RK4 steps of every copy at constant actuator activations act (B, nu): (qpos, qvel, bad)."""
    h = mx.opt.timestep
    coefs = jnp.asarray([RK4_STAGE_A, RK4_B], qpos.dtype).T
    rest_q, rest_v = jnp.broadcast_to(data.qpos, qpos.shape), jnp.zeros_like(qvel)

    def acceleration(qp, qv, warm):
        ctrl = -force(law, qp[:, qadr], qv[:, dadr], act)
        return _accelerations(mx, data, qp, qv, ctrl, warm, batching)

    def step(carry, _):
        qp, qv, warm, bad = carry

        def stage(c, coef):
            kq, kv, sq, sv, _ = c
            qi, vi = qp + (kq * coef[0]) * h, qv + (kv * coef[0]) * h
            acc = acceleration(qi, vi, warm)
            return (vi, acc, sq + vi * coef[1], sv + acc * coef[1], acc), None

        zero = jnp.zeros_like(qv)
        (_, _, sq, sv, last), _ = jax.lax.scan(stage, (qv, zero, zero, zero, zero), coefs)
        qp, qv = qp + sq * h, qv + sv * h
        bad = bad | ~jnp.isfinite(last).all(axis=1) | (jnp.abs(last) > MAX_ACCELERATION).any(axis=1)
        bad = bad | ~jnp.isfinite(qp).all(axis=1) | ~jnp.isfinite(qv).all(axis=1)
        # a failed copy rests at qpos0 for the rest of the frame (its result is discarded): NaNs would keep the
        # constraint solver iterating to its limit for the whole batch
        qp, qv = jnp.where(bad[:, None], rest_q, qp), jnp.where(bad[:, None], rest_v, qv)
        return (qp, qv, jnp.where(bad[:, None], 0.0, last), bad), None

    init = (qpos, qvel, jnp.zeros_like(qvel), jnp.zeros(qpos.shape[0], dtype=bool))
    (qp, qv, _, bad), _ = jax.lax.scan(step, init, None, length=steps)
    return qp, qv, bad


# MuJoCo's own constants for a tendon wrapping a sphere or cylinder from inside (engine_util_misc.c: Newton's method
# from z = 1 - 1e-7, 20 iterations, |f| <= 1e-6); mjx.put_model sets 5, 1e-4 and 1 - 1e-5, whose looser solution moves
# the middle deltoid's wrap point off MuJoCo's (its length by up to 0.32 mm over 110.0-110.6 deg of elevation, the
# cause of the backends' divergence within 2 s; docs/gpu.md). The start sits closer to 1 than MuJoCo's: MuJoCo 3.17
# finds roots up to z = 1 - 5e-10 (measured on this model), so float64 starts at 1 - 1e-12 (lengths then agree to
# 1e-12 m over the whole path); float32 starts at its largest value below 1.
WRAP_INSIDE = {"float64": (20, 1e-6, 1.0 - 1e-12),
               "float32": (20, 1e-4, float(np.nextafter(np.float32(1.0), np.float32(0.0))))}


def wrap_inside_as_mujoco(mx, dtype: str):
    """The MJX model `mx` with `WRAP_INSIDE[dtype]`'s inside-wrap solver settings."""
    maxiter, tolerance, z_init = WRAP_INSIDE[dtype]
    return mx.tree_replace({"_impl.wrap_inside_maxiter": maxiter, "_impl.wrap_inside_tolerance": tolerance,
                            "_impl.wrap_inside_z_init": z_init})


def _cast(tree, dtype: str):
    """Every floating array of an MJX model or data in `dtype`."""
    def cast(x):
        if isinstance(x, (jax.Array, np.ndarray)) and jnp.issubdtype(x.dtype, jnp.floating):
            return jnp.asarray(x, dtype)
        return x
    return jax.tree_util.tree_map(cast, tree)


class MjxArm:
    """The tasks' arm (`arm.MODEL_FILE`, couplings hardened) on MJX with `law` (a `ForceLaw` of some of its
    actuators), for batches of copies: `frame(qpos, qvel, act)` advances (N, nq), (N, nv) by one 0.1 s frame at
    muscle activations (N, n_muscles) and returns (qpos, qvel, failed (N,)), all device arrays of `dtype`.
    joint_damping: viscous damping (N m s/rad) of the elevation joint (the task option). batching: how a batch's
    forward dynamics run, "vmap" or "map" (`_accelerations`; default "map" on the CPU, "vmap" elsewhere)."""

    def __init__(self, law, dtype: str = DEFAULT_DTYPE, joint_damping: float = 0.0, device=None,
                 batching: str | None = None):
        self.dtype = check_dtype(dtype)
        self.device = device if device is not None else jax.devices()[0]
        self.batching = batching or ("map" if self.device.platform == "cpu" else "vmap")
        if self.batching not in BATCHING:
            raise ValueError(f"batching must be one of {BATCHING}, got {batching!r}")
        m = forces_as_controls(arm_.compile_arm())  # muscle forces as plain controls (the numpy engine's oracle)
        jnt = m.joint(arm_.JOINT)
        self.qadr, self.dadr = int(jnt.qposadr[0]), int(jnt.dofadr[0])
        m.dof_damping[self.dadr] = float(joint_damping)
        self.model, self.law = m, law
        self.nq, self.nv, self.nu = m.nq, m.nv, m.nu
        self.h = float(m.opt.timestep)
        self.steps_per_frame = int(round(0.1 / self.h))
        actuators = tuple(m.actuator(i).name for i in range(m.nu))
        missing = [a for a in law.actuators if a not in actuators]
        if missing:
            raise ValueError(f"no actuator(s) {missing} for the law's muscles; the model has {actuators}")
        path = arm_.LockedPath(m)
        self.couplings = path.couplings
        lo, hi = arm_.RANGE_DEG
        grid = np.radians(np.arange(lo - arm_.VALID_MARGIN_DEG, hi + arm_.VALID_MARGIN_DEG + 1e-9,
                                    arm_.FINE_STEP_DEG))
        gravity = arm_.arm().gravity_torque(grid)  # samples of the tasks' own table (Arm) at its grid points
        with precision(self.dtype), jax.default_device(self.device):
            self.mx = wrap_inside_as_mujoco(_cast(mjx.put_model(m), self.dtype), self.dtype)
            self.data = _cast(mjx.make_data(self.mx), self.dtype)
            self.jlaw = law_arrays(law, actuators, self.dtype)
            self.gravity = (jnp.asarray(grid, self.dtype), jnp.asarray(gravity, self.dtype))
            self.qpos0 = jnp.asarray(m.qpos0, self.dtype)

        # the model, data and layout are constants of the compiled frame, not arguments: traced, the model makes XLA's
        # CPU code of mjx.forward ~10^4 x slower (2.0 ms a call against 27 s, measured; docs/gpu.md)
        self._frame = jax.jit(partial(_frame, self.mx, self.data, qadr=self.qadr, dadr=self.dadr,
                                      steps=self.steps_per_frame, batching=self.batching))

    def frame(self, qpos, qvel, act):
        with precision(self.dtype):
            qpos, qvel, act = (jnp.asarray(x, self.dtype) for x in (qpos, qvel, act))
            return self._frame(self.jlaw, qpos, qvel, per_actuator(self.jlaw, act))

    def qpos(self, elevation_rad):
        """(B, nq) positions on the coupled path at elevations (B,) rad (`arm.LockedPath.qpos`)."""
        with precision(self.dtype):
            return self._qpos(jnp.asarray(elevation_rad, self.dtype))

    def _qpos(self, elevation_rad):
        x = elevation_rad - self.qpos0[self.qadr]
        out = jnp.broadcast_to(self.qpos0, (x.shape[0], self.nq))
        out = out.at[:, self.qadr].set(x + self.qpos0[self.qadr])
        for adr, _, c in self.couplings:
            out = out.at[:, adr].set(self.qpos0[adr] + arm_.polycoef_value(c, x))
        return out

    def holding_activation(self, angle_deg):
        """(B, n_muscles) activations holding the arm at rest at `angle_deg` (`statics.holding_activation`)."""
        with precision(self.dtype):
            return holding(self.jlaw, self.gravity, jnp.asarray(angle_deg, self.dtype), len(self.law.muscles))
