"""N copies of a task on MJX (`shoulder_bench.mjx_sim`) as an rsl-rl `VecEnv`: physics, force law, observations,
rewards and episode resets all on the JAX device; torch sees the observations, rewards and dones through DLPack
(zero-copy where JAX and torch share the device). Needs the `[mjx]` extra.

    from shoulder_bench.tasks import mjx_env
    venv = mjx_env.make("abduction_4m", 4096, device="cuda", seed=0)      # a GPU
    venv = mjx_env.make("abduction_4m", 8, device="cpu", seed=0)          # the CPU (the tests)

The protocol is the MuJoCo backend's (`tasks.vec_env.VecEnv`, the paper's): the same options, actions, observation
(`protocol.OBSERVATION_KEYS` order), reward (`protocol.reward`), crash rule and time-outs, written once more in JAX
(`mjx_protocol`, tested against the originals). What differs: the random targets and the observation noise are drawn
on the device from JAX keys (the same distributions as the single env's numpy draws, not the same numbers; a given
`trajectory` is tracked exactly as by the MuJoCo backend), and `last_final_obs` is not kept.
"""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import torch
from rsl_rl.env import VecEnv as _RslVecEnv
from tensordict import TensorDict

from shoulder_bench import arm as arm_
from shoulder_bench import protocol
from shoulder_bench import trajectory as targets
from shoulder_bench.mjx_sim import DEFAULT_DTYPE, MjxArm, check_dtype, precision
from shoulder_bench.model import DEFAULT_MUSCLE_MODEL
from shoulder_bench.tasks import TASKS, check_name, mjx_protocol
from shoulder_bench.tasks import options as options_check
from shoulder_bench.tasks.abduction import Abduction


def jax_device(device: torch.device):
    """The JAX device of a torch device: the CPU, or the GPU of the same index."""
    if device.type == "cpu":
        return jax.devices("cpu")[0]
    if device.type == "cuda":
        gpus = jax.devices("gpu")
        return gpus[device.index or 0]
    raise ValueError(f"device {device}: the MJX backend runs on 'cpu' or 'cuda[:k]'")


def to_torch(x: jax.Array) -> torch.Tensor:
    """A JAX array as a torch tensor on the same device, through DLPack (no copy)."""
    return torch.from_dlpack(x)


def from_torch(t: torch.Tensor) -> jax.Array:
    return jax.dlpack.from_dlpack(t.detach().contiguous())


class MjxVecEnv(_RslVecEnv):
    """`make(name, num_envs, device, seed, **options)`: options as for `shoulder_bench.make_vec` (`trajectory` may be
    a list with one target per copy); dtype: "float64" (the default, on every device) or "float32", which this model's
    dynamics do not survive (`mjx_sim.DTYPES`)."""

    def __init__(self, name: str, num_envs: int, device: str = "cpu", seed=None, trajectory=None,
                 muscle_model: str = DEFAULT_MUSCLE_MODEL, dtype: str | None = None, **options):
        muscles, discrete, _ = TASKS[check_name(name)]
        if isinstance(num_envs, bool) or not isinstance(num_envs, (int, np.integer)) or num_envs < 1:
            raise ValueError(f"num_envs must be an integer >= 1, got {num_envs!r}")
        seed = options_check.seed(seed)
        self.name, self.num_envs, self.device = name, int(num_envs), torch.device(device)
        self.jdev = jax_device(self.device)
        self.dtype = check_dtype(dtype or DEFAULT_DTYPE)
        fixed = trajectory if isinstance(trajectory, (list, tuple)) else [trajectory] * self.num_envs
        if len(fixed) != self.num_envs:
            raise ValueError(f"{len(fixed)} trajectories for {self.num_envs} environments: give one, or one per copy")
        fixed = [targets.as_trajectory(t) for t in fixed]
        self.task = Abduction(muscles, discrete=discrete, trajectory_=fixed[0], **options)
        self.muscles, self.discrete, self.n = tuple(muscles), discrete, len(muscles)
        self.num_actions = self.n
        self.cfg = {"task": name, "muscle_model": muscle_model, "backend": "mjx", "dtype": self.dtype, **options}
        self.law = arm_.arm().load_law(muscle_model, self.muscles, **self.task.condition)
        self.sim = MjxArm(self.law, self.dtype, joint_damping=self.task.joint_damping, device=self.jdev)
        split_frames = int(round(targets.SPLITS[self.task.split]["duration_s"] / protocol.FRAME_S))
        frames = np.array([split_frames if t is None else t.frames for t in fixed])
        self.max_episode_length = int(frames.max())
        length = self.max_episode_length + 1
        fixed_angle, fixed_vel = np.zeros((self.num_envs, length)), np.zeros((self.num_envs, length))
        for i, t in enumerate(fixed):
            if t is not None:
                fixed_angle[i, :len(t.angle_deg)], fixed_angle[i, len(t.angle_deg):] = t.angle_deg, t.angle_deg[-1]
                fixed_vel[i, :len(t.angle_deg)] = t.velocity_deg_s
        self.spec = mjx_protocol.Spec(
            n=self.n, discrete=discrete, split=self.task.split, length=length, alpha=self.task.alpha,
            omega_max=self.task.omega_max, tracking_only=self.task.tracking_only, hold=self.task.init == "hold",
            delay_frames=self.task.delay_frames, obs_noise_deg=self.task.obs_noise_deg,
            random_targets=any(t is None for t in fixed))
        f = np.dtype(self.dtype)
        with precision(self.dtype), jax.default_device(self.jdev):
            self.const = {"fixed": jnp.asarray([t is not None for t in fixed]),
                          "fixed_angle": jnp.asarray(fixed_angle, f), "fixed_vel": jnp.asarray(fixed_vel, f),
                          "episode_frames": jnp.asarray(frames, np.int32)}
            self.state = mjx_protocol.initial_state(self.spec, self.sim, self.num_envs, f,
                                                    jax.random.key(0 if seed is None else seed))
            if seed is None:  # fresh entropy, as numpy's default_rng(None)
                self.state["key"] = jax.random.key(np.random.SeedSequence().generate_state(1)[0])
            self.state = mjx_protocol.reset(self.spec, self.sim, self.const, self.state,
                                            jnp.ones(self.num_envs, dtype=bool))
        self.episode_frames = frames
        self.episode_length_buf = torch.zeros(self.num_envs, dtype=torch.long, device=self.device)
        self._finished: list[float] = []
        self.last = None

    # --- observations ---------------------------------------------------------------------------------------------
    def observation_array(self) -> jax.Array:
        """(N, 4 + n) observations on the device in the env's dtype, in protocol.OBSERVATION_KEYS order."""
        with precision(self.dtype):
            return mjx_protocol.observe(self.spec, self.sim.qadr, self.sim.dadr, self.const, self.state)

    def _observation(self, flat: jax.Array) -> TensorDict:
        obs = to_torch(flat.astype(jnp.float32))
        return TensorDict({"policy": obs, "critic": obs.clone()}, batch_size=[self.num_envs], device=self.device)

    def get_observations(self) -> TensorDict:
        return self._observation(self.observation_array())

    def reset(self) -> TensorDict:
        with precision(self.dtype):
            self.state = mjx_protocol.reset(self.spec, self.sim, self.const, self.state,
                                            jnp.ones(self.num_envs, dtype=bool))
        self.episode_length_buf.zero_()
        return self.get_observations()

    # --- stepping ---------------------------------------------------------------------------------------------------
    def check_actions(self, actions) -> jax.Array:
        """The actions as a device array; ValueError (before any change) for a wrong shape or a value that is not
        finite (continuous) or not an integer level 0..LEVELS-1 (discrete), as `protocol.to_delta`."""
        a = actions if torch.is_tensor(actions) else torch.as_tensor(np.asarray(actions))
        n, b = self.n, self.num_envs
        shapes = ((b, n),) + (((b,),) if n == 1 else ())
        if tuple(a.shape) not in shapes or a.dtype == torch.bool or a.is_complex():
            raise ValueError(f"action of shape {tuple(a.shape)}: expected shape ({n},) for {b} environments")
        a = a.reshape(b, n).to(self.device)
        if self.discrete:
            ok = bool(torch.all(torch.isfinite(a.double()) & (a == torch.round(a)) & (a >= 0)
                                & (a < protocol.LEVELS)))
            if not ok:
                raise ValueError(f"action: expected {n} integers in 0..{protocol.LEVELS - 1} per environment")
        elif not bool(torch.all(torch.isfinite(a))):
            raise ValueError(f"action is not finite: expected {n} numbers within +-{protocol.ACTION_LIMIT} per "
                             f"environment (finite values outside are clipped)")
        return from_torch(a.to(torch.float32 if a.dtype != torch.float64 else torch.float64))

    def step(self, actions) -> tuple[TensorDict, torch.Tensor, torch.Tensor, dict]:
        a = self.check_actions(actions)
        with precision(self.dtype):
            self.state, out = mjx_protocol.step(self.spec, self.sim, self.const, self.state, a)
        self.last = out
        done = to_torch(out["done"])
        self.episode_length_buf += 1
        self.episode_length_buf[done] = 0
        extras = {"time_outs": to_torch(out["time_out"])}
        if bool(out["any_done"]):
            finished = np.asarray(out["done"])
            returns = np.asarray(out["return"])[finished]
            extras["log"] = {"/episode/return": float(returns.mean()),
                             "/episode/length": float(np.asarray(out["length"])[finished].mean()),
                             "/episode/mae_deg": float(np.asarray(out["mae_deg"])[finished].mean()),
                             "/episode/crash_rate": float(np.asarray(out["crashed"])[finished].mean())}
            self._finished.extend(returns.tolist())
        return (self._observation(out["obs"]), to_torch(out["reward"].astype(jnp.float32)),
                done.to(torch.long), extras)

    # the last step's per-copy results as numpy (host copies), as tasks.vec_env.VecEnv names them
    @property
    def last_angle_deg(self) -> np.ndarray:
        return np.asarray(self.last["angle_deg"])

    @property
    def last_target_deg(self) -> np.ndarray:
        return np.asarray(self.last["target_deg"])

    @property
    def last_error_deg(self) -> np.ndarray:
        return np.abs(self.last_angle_deg - self.last_target_deg)

    @property
    def last_crashed(self) -> np.ndarray:
        return np.asarray(self.last["crashed"])

    @property
    def last_reward(self) -> np.ndarray:
        return np.asarray(self.last["reward"])

    @property
    def last_activation(self) -> np.ndarray:
        return np.asarray(self.last["activation"])

    @property
    def qpos(self) -> np.ndarray:
        return np.asarray(self.state["qpos"])

    @property
    def qvel(self) -> np.ndarray:
        return np.asarray(self.state["qvel"])

    # --- checkpoints ------------------------------------------------------------------------------------------------
    def state_dict(self) -> dict:
        """The device state (physics, activations, targets, episode progress, sensing buffers) as numpy arrays and
        the JAX key's data, so a restored env continues exactly as this one would."""
        arrays = {k: np.asarray(v) for k, v in self.state.items() if k != "key"}
        return {"name": self.name, "num_envs": self.num_envs, "dtype": self.dtype, "arrays": arrays,
                "key": np.asarray(jax.random.key_data(self.state["key"])),
                "episode_length_buf": self.episode_length_buf.clone(), "finished": list(self._finished)}

    def load_state_dict(self, state: dict) -> None:
        if (state["name"], state["num_envs"], state["dtype"]) != (self.name, self.num_envs, self.dtype):
            raise ValueError(f"env state of {state['num_envs']} copies of {state['name']} ({state['dtype']}) cannot "
                             f"be restored into {self.num_envs} copies of {self.name} ({self.dtype})")
        missing = [k for k in self.state if k != "key" and k not in state["arrays"]]
        if missing:
            raise ValueError(f"env state lacks {missing}: it was saved by another version of the MJX env")
        with precision(self.dtype), jax.default_device(self.jdev):
            self.state = {k: jnp.asarray(state["arrays"][k]) for k in self.state if k != "key"}
            self.state["key"] = jax.random.wrap_key_data(jnp.asarray(state["key"]))
        self.episode_length_buf = state["episode_length_buf"].clone().to(self.device)
        self._finished = list(state["finished"])

    def finished_returns(self) -> list[float]:
        """Returns of the episodes that ended since the last call."""
        out, self._finished = self._finished, []
        return out

    def close(self) -> None:
        self.state = {}


def make(name: str, num_envs: int, device: str = "cpu", seed=None, **options) -> MjxVecEnv:
    """N copies of a task on MJX as an rsl-rl VecEnv (see `MjxVecEnv`); options as for `shoulder_bench.make_vec`."""
    options_check.check_names({k: v for k, v in options.items() if k != "dtype"})
    return MjxVecEnv(name, num_envs, device=device, seed=seed, **options)
