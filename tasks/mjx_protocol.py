"""The paper's protocol on the JAX device, for the MJX env (`tasks.mjx_env`): actions, reward, observation, crash rule,
targets and episode resets, as `tasks.vec_env.VecEnv` computes them with `protocol`, `sensing` and `trajectory`.

The arithmetic is that of the originals (`protocol.reward`, `protocol.observation`, `protocol.to_delta`,
`trajectory.random_trajectory` through `trajectory.quintic` itself, `sensing.noisy`); tests/test_mjx.py checks each
against its original. The random draws (target end points, observation noise) come from a JAX key carried in the
state, not from the single env's numpy generators.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import partial

import jax
import jax.numpy as jnp
import numpy as np

from shoulder_bench import arm as arm_
from shoulder_bench import protocol
from shoulder_bench import trajectory as targets

MAX_ABS = 1e10  # MuJoCo's mjMAXVAL: beyond it the single env's MuJoCo would warn (a crash)


@dataclass(frozen=True)
class Spec:
    """What a task's episodes are (static for compilation)."""

    n: int
    discrete: bool
    split: str
    length: int  # target samples per copy (the longest episode's frames + 1)
    alpha: float
    omega_max: float
    tracking_only: bool
    hold: bool  # init="hold": start at rest with the holding activations
    delay_frames: int
    obs_noise_deg: float
    random_targets: bool  # some copies draw random targets


def reward(angle_deg, target_deg, sent, alpha: float, omega_max: float, tracking_only: bool):
    """`protocol.reward` in JAX: -|phi - phi_hat| - alpha sum|omega| (%) - mean 1{|omega| > omega_max}."""
    r = -jnp.abs(angle_deg - target_deg)
    if tracking_only:
        return r
    mag = jnp.minimum(jnp.abs(sent), protocol.REWARD_ACTION_CAP)
    return r - alpha * 100.0 * mag.sum(axis=1) - jnp.count_nonzero(mag > omega_max, axis=1) / mag.shape[1]


def observation(angle_deg, velocity_deg_s, target_deg, target_velocity_deg_s, activations):
    """(B, 4 + n): `protocol.observation` flattened in OBSERVATION_KEYS order."""
    cols = {"angle": angle_deg[:, None], "angular_velocity": velocity_deg_s[:, None],
            "target_angle": target_deg[:, None], "target_velocity": target_velocity_deg_s[:, None],
            "activations": activations}
    return jnp.concatenate([cols[k] for k in protocol.OBSERVATION_KEYS], axis=1)


def to_delta(a, discrete: bool):
    """(applied, sent) changes of activation (B, n) from checked actions, floats (`protocol.to_delta`)."""
    if discrete:  # numpy's values themselves: XLA may fuse -limit + k step into one FMA, and the reward's
        # bang-bang count compares levels 1 and 19 (+-0.009) with omega_max = 0.009 to the last bit
        d = jnp.asarray(protocol.level_to_delta(np.arange(protocol.LEVELS)), a.dtype)[a.astype(jnp.int32)]
        return d, d
    return jnp.clip(a, -protocol.ACTION_LIMIT, protocol.ACTION_LIMIT), a


def quintic_targets(points):
    """(angle (B, K), velocity (B, K)) deg, deg/s of the stacked rest-to-rest quintics through end points (B, S + 1):
    `trajectory.random_trajectory`'s samples (`trajectory.quintic`), velocity its central difference (np.gradient)."""
    per_seg = int(round(targets.SEGMENT_S / targets.FRAME_S))
    t = np.arange(per_seg) * targets.FRAME_S
    segs = [targets.quintic(t, points[:, k:k + 1], points[:, k + 1:k + 2], targets.SEGMENT_S)[0]
            for k in range(points.shape[1] - 1)]
    a = jnp.concatenate(segs + [points[:, -1:]], axis=1)
    dx = targets.FRAME_S
    vel = jnp.concatenate([(a[:, 1:2] - a[:, :1]) / dx, (a[:, 2:] - a[:, :-2]) / (2.0 * dx),
                           (a[:, -1:] - a[:, -2:-1]) / dx], axis=1)
    return a, vel


def random_targets(key, spec: Spec, num: int, dtype):
    """(angle, velocity) (num, spec.length) of random targets of the split, padded as the MuJoCo backend pads."""
    split = targets.SPLITS[spec.split]
    lo, hi = split["range_deg"]
    n_seg = int(round(split["duration_s"] / targets.SEGMENT_S))
    a, v = quintic_targets(jax.random.uniform(key, (num, n_seg + 1), dtype, lo, hi))
    pad = spec.length - a.shape[1]
    return (jnp.concatenate([a, jnp.repeat(a[:, -1:], pad, axis=1)], axis=1),
            jnp.concatenate([v, jnp.zeros((num, pad), dtype)], axis=1))


def initial_state(spec: Spec, sim, num: int, dtype, key) -> dict:
    z = partial(jnp.zeros, dtype=dtype)
    return {"qpos": z((num, sim.nq)), "qvel": z((num, sim.nv)), "act": z((num, spec.n)),
            "targets": z((num, spec.length)), "target_vel": z((num, spec.length)),
            "frames": jnp.zeros(num, jnp.int32), "ret": z(num), "abs_err": z(num),
            "history": z((num, spec.delay_frames + 1, 2 + spec.n)), "noise_z": z((num, 2)), "key": key}


def _sense(state, qadr: int, dadr: int):
    """(B, 2 + n): the true angle (deg), velocity (deg/s) and activations now (`sensing.state`)."""
    return jnp.concatenate([jnp.degrees(state["qpos"][:, qadr:qadr + 1]),
                            jnp.degrees(state["qvel"][:, dadr:dadr + 1]), state["act"]], axis=1)


def _draw_noise(spec: Spec, state, mask):
    if spec.obs_noise_deg <= 0:
        return state
    key, sub = jax.random.split(state["key"])
    z = jax.random.normal(sub, state["noise_z"].shape, state["noise_z"].dtype)
    return {**state, "key": key, "noise_z": jnp.where(mask[:, None], z, state["noise_z"])}


@partial(jax.jit, static_argnums=(0,))
def _new_targets(spec: Spec, const, state, mask):
    angle, vel = const["fixed_angle"], const["fixed_vel"]
    key = state["key"]
    if spec.random_targets:
        key, sub = jax.random.split(key)
        ra, rv = random_targets(sub, spec, mask.shape[0], angle.dtype)
        angle = jnp.where(const["fixed"][:, None], angle, ra)
        vel = jnp.where(const["fixed"][:, None], vel, rv)
    return {**state, "key": key, "targets": jnp.where(mask[:, None], angle, state["targets"]),
            "target_vel": jnp.where(mask[:, None], vel, state["target_vel"])}


@partial(jax.jit, static_argnums=(0, 1, 2))
def _restart(spec: Spec, qadr: int, dadr: int, state, mask, qpos, act):
    m = mask[:, None]
    state = {**state, "qpos": jnp.where(m, qpos, state["qpos"]), "qvel": jnp.where(m, 0.0, state["qvel"]),
             "act": jnp.where(m, act, state["act"]), "frames": jnp.where(mask, 0, state["frames"]),
             "ret": jnp.where(mask, 0.0, state["ret"]), "abs_err": jnp.where(mask, 0.0, state["abs_err"])}
    if spec.delay_frames:
        now = jnp.broadcast_to(_sense(state, qadr, dadr)[:, None, :], state["history"].shape)
        state["history"] = jnp.where(mask[:, None, None], now, state["history"])
    return _draw_noise(spec, state, mask)


def reset(spec: Spec, sim, const, state, mask):
    """Start new episodes in the copies where `mask` (N,): targets, the arm at rest on the first target (with the
    holding activations for init="hold"), the delay buffer and the noise of the first observation."""
    state = _new_targets(spec, const, state, mask)
    start = state["targets"][:, 0]
    qpos = sim.qpos(jnp.radians(start))
    act = sim.holding_activation(start) if spec.hold else jnp.zeros_like(state["act"])
    return _restart(spec, sim.qadr, sim.dadr, state, mask, qpos, act)


@partial(jax.jit, static_argnums=(0, 1, 2))
def observe(spec: Spec, qadr: int, dadr: int, const, state):
    """(N, 4 + n) observations (`VecEnv.observation_array`): the sensed terms delay_frames late and noisy, the
    targets of the next frame."""
    k = jnp.minimum(state["frames"] + 1, const["episode_frames"])[:, None]
    sensed = state["history"][:, 0] if spec.delay_frames else _sense(state, qadr, dadr)
    angle, velocity, act = sensed[:, 0], sensed[:, 1], sensed[:, 2:]
    if spec.obs_noise_deg > 0:  # sensing.noisy
        angle = angle + spec.obs_noise_deg * state["noise_z"][:, 0]
        velocity = velocity + spec.obs_noise_deg * state["noise_z"][:, 1]
    return observation(angle, velocity, jnp.take_along_axis(state["targets"], k, 1)[:, 0],
                       jnp.take_along_axis(state["target_vel"], k, 1)[:, 0], act)


@partial(jax.jit, static_argnums=(0,))
def _act(spec: Spec, state, a):
    applied, sent = to_delta(a.astype(state["act"].dtype), spec.discrete)
    return {**state, "act": jnp.clip(state["act"] + applied, 0.0, 1.0)}, sent


@partial(jax.jit, static_argnums=(0, 1, 2))
def _score(spec: Spec, qadr: int, dadr: int, const, state, qpos, qvel, bad, sent):
    """After the physics: frame count, delay buffer, noise, crash rule, reward, episode sums and ends."""
    state = {**state, "qpos": qpos, "qvel": qvel, "frames": state["frames"] + 1}
    if spec.delay_frames:
        state["history"] = jnp.concatenate([state["history"][:, 1:], _sense(state, qadr, dadr)[:, None, :]], axis=1)
    state = _draw_noise(spec, state, jnp.ones(qpos.shape[0], dtype=bool))
    angle = jnp.degrees(qpos[:, qadr])
    lo, hi = arm_.RANGE_DEG
    crashed = bad | ~jnp.isfinite(qpos).all(axis=1) | ~jnp.isfinite(qvel).all(axis=1)
    crashed |= (jnp.abs(qpos) > MAX_ABS).any(axis=1) | (jnp.abs(qvel) > MAX_ABS).any(axis=1)
    crashed |= (angle < lo - arm_.VALID_MARGIN_DEG) | (angle > hi + arm_.VALID_MARGIN_DEG)
    frames, episode = state["frames"], const["episode_frames"]
    target_now = jnp.take_along_axis(state["targets"], frames[:, None], 1)[:, 0]
    r = reward(angle, target_now, sent, spec.alpha, spec.omega_max, spec.tracking_only)
    r = jnp.where(crashed, -protocol.CRASH_ERROR_DEG * (episode - frames + 1), r)
    state["ret"] = state["ret"] + r
    state["abs_err"] = state["abs_err"] + jnp.where(crashed, 0.0, jnp.abs(angle - target_now))
    time_out = (frames >= episode) & ~crashed
    done = crashed | time_out
    out = {"reward": r, "done": done, "time_out": time_out, "any_done": done.any(), "crashed": crashed,
           "angle_deg": angle, "target_deg": target_now, "activation": state["act"], "return": state["ret"],
           "length": frames, "mae_deg": state["abs_err"] / frames}
    return state, out


def step(spec: Spec, sim, const, state, a):
    """One frame of every copy (`VecEnv.step`): activations, physics, score, auto-reset of the ended episodes, then
    the observation. Returns (state, out); out holds per-copy device arrays (reward, done, ...) and `obs`."""
    state, sent = _act(spec, state, a)
    qpos, qvel, bad = sim.frame(state["qpos"], state["qvel"], state["act"])
    state, out = _score(spec, sim.qadr, sim.dadr, const, state, qpos, qvel, bad, sent)
    if bool(out["any_done"]):
        state = reset(spec, sim, const, state, out["done"])
    out["obs"] = observe(spec, sim.qadr, sim.dadr, const, state)
    return state, out
