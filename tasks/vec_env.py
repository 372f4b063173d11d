"""N copies of a task in lockstep as an rsl-rl `VecEnv` (TensorDict observations, auto-reset, episode statistics).

Copy i draws its targets exactly as `shoulder_bench.load(name, seed=seed + i)` does, and the physics reproduces the
callback path (`simulator.BatchSimulator`), so a batched episode equals a single-env episode with the same actions.
"""
from __future__ import annotations

import numpy as np
import torch

from shoulder_bench import arm as arm_
from shoulder_bench import protocol, randomization, statics
from shoulder_bench import trajectory as targets
from shoulder_bench.arm import harden_couplings
from shoulder_bench.model import DEFAULT_MUSCLE_MODEL
from shoulder_bench.simulator import BatchSimulator
from shoulder_bench.tasks import TASKS, check_name, sensing
from shoulder_bench.tasks import options as options_check
from shoulder_bench.tasks.abduction import VALID_MARGIN_DEG, Abduction
from shoulder_bench.tasks.lockstep import Lockstep


def batch_engine() -> str:
    """The batched simulator's engine: "mujoco" (MuJoCo's RK4, one rollout per frame, the compiled GIL-free
    callbacks) where `shoulder_bench.native` is available, else "numpy" (the numpy RK4 with the law outside MuJoCo)."""
    from shoulder_bench import native  # lazily: numba loads the compiled callbacks

    return "mujoco" if native.AVAILABLE else "numpy"


MAX_ABS = 1e10  # MuJoCo's mjMAXVAL: beyond it the single env's MuJoCo would warn (a crash)


class VecEnv(Lockstep):
    """`shoulder_bench.make_vec(name, num_envs, device, seed, **options)`; options as for `shoulder_bench.load`, and
    `trajectory` may also be a list with one target per copy (episodes of a copy then repeat its target)."""

    def __init__(self, name: str, num_envs: int, device: str = "cpu", seed=None, trajectory=None,
                 muscle_model: str = DEFAULT_MUSCLE_MODEL, nthread: int = 2, **options):
        muscles, discrete, _ = TASKS[check_name(name)]
        if isinstance(num_envs, bool) or not isinstance(num_envs, (int, np.integer)) or num_envs < 1:
            raise ValueError(f"num_envs must be an integer >= 1, got {num_envs!r}")
        seed = options_check.seed(seed)
        self.name, self.num_envs, self.device = name, int(num_envs), torch.device(device)
        fixed = trajectory if isinstance(trajectory, (list, tuple)) else [trajectory] * self.num_envs
        if len(fixed) != self.num_envs:
            raise ValueError(f"{len(fixed)} trajectories for {self.num_envs} environments: give one, or one per copy")
        self.fixed = [targets.as_trajectory(t) for t in fixed]
        self.task = Abduction(muscles, discrete=discrete, trajectory_=self.fixed[0], **options)
        self.muscles, self.discrete, self.n = tuple(muscles), discrete, len(muscles)
        self.num_actions = self.n
        self.cfg = {"task": name, "muscle_model": muscle_model, **options}
        self.arm = arm_.arm_for(self.task.condition.get("condition"))  # a rerouting condition's geometry
        self.law = self.arm.load_law(muscle_model, self.muscles, **self.task.condition)  # the task's condition
        # MuJoCo's own RK4 with the compiled callbacks (one rollout per frame), where they are available
        # randomize: one model per copy, compiled without the textures (randomization.physics_only_xml)
        model_file = arm_.model_file(self.arm.geometry)  # the condition's geometry (ld_transfer reroutes ld)
        source = {"path": model_file} if self.task.randomize is None else {
            "xml": randomization.physics_only_xml(model_file)}
        self.sim = BatchSimulator(self.law, self.num_envs, nthread=nthread, prepare=harden_couplings,
                                  engine=batch_engine(), **source)
        self.sim.model.dof_damping[self.sim.dadr] = self.task.joint_damping
        self._setup_physiology(seed, randomization.groups(self.sim.model, arm_.ACTUATORS, self.muscles))
        self.rngs = [np.random.default_rng(None if seed is None else seed + i) for i in range(self.num_envs)]
        self._setup_sensing(seed)
        split_frames = int(round(targets.SPLITS[self.task.split]["duration_s"] / protocol.FRAME_S))
        self.episode_frames = np.array([split_frames if t is None else t.frames for t in self.fixed])
        self.max_episode_length = int(self.episode_frames.max())
        n_frames = self.max_episode_length
        self.targets = np.zeros((self.num_envs, n_frames + 1))
        self.target_vel = np.zeros_like(self.targets)
        self.random_target = np.array([t is None for t in self.fixed])  # copies that draw a target per episode
        for i, tr in enumerate(self.fixed):  # a given target is every episode's: set once, never redrawn
            if tr is not None:
                self._set_targets([i], tr.angle_deg[None], tr.velocity_deg_s[None])
        self.frames = np.zeros(self.num_envs, dtype=np.int64)
        self.qpos, self.qvel = np.zeros((self.num_envs, self.sim.nq)), np.zeros((self.num_envs, self.sim.nv))
        self.act = np.zeros((self.num_envs, self.n))
        self.episode_length_buf = torch.zeros(self.num_envs, dtype=torch.long, device=self.device)
        self._return = np.zeros(self.num_envs)
        self._finished: list[float] = []
        self._abs_err = np.zeros(self.num_envs)
        self._reset(np.arange(self.num_envs))

    # --- episodes ---------------------------------------------------------------------------------------------------
    def _reset(self, idx: np.ndarray) -> None:
        """Start new episodes in the copies `idx`: targets, arm at rest on the first target, holding activations,
        the physiology state, in arrays; per copy only what its own generators draw (its target's end points, its
        randomised arm, its noise), so that copy i is the single env seeded seed + i."""
        idx = np.asarray(idx, dtype=np.int64)
        drawn = idx[self.random_target[idx]]  # copies with a given target keep it (set in __init__)
        if drawn.size:
            self._set_targets(drawn, *targets.random_targets([self.rngs[i] for i in drawn], self.task.split))
        start = self.targets[idx, 0]
        self.qpos[idx] = self.arm.qpos(np.radians(start))
        self.qvel[idx] = 0.0
        if self.sim.carry_warmstart:
            self.sim.warmstart[idx] = 0.0  # as mj_resetData
        self.act[idx] = statics.holding_activation(self.law, start) if self.task.init == "hold" else 0.0
        self._physiology_reset(idx)
        self.frames[idx] = 0
        self._sense_reset(idx)
        self._return[idx] = 0.0
        self._abs_err[idx] = 0.0
        self.episode_length_buf[torch.as_tensor(idx, device=self.device)] = 0

    def _set_targets(self, rows, angle: np.ndarray, velocity: np.ndarray) -> None:
        """Targets (len(rows), K) of the copies `rows`, padded past frame K - 1 with the last angle, zero velocity."""
        k = angle.shape[1]
        self.targets[rows, :k], self.targets[rows, k:] = angle, angle[:, -1:]
        self.target_vel[rows, :k], self.target_vel[rows, k:] = velocity, 0.0

    @property
    def q(self) -> np.ndarray:
        """(N,) elevation angles (rad)."""
        return self.qpos[:, self.sim.qadr]

    @property
    def v(self) -> np.ndarray:
        """(N,) elevation velocities (rad/s)."""
        return self.qvel[:, self.sim.dadr]

    def _sense(self) -> np.ndarray:
        """(N, 2 + n): the true angle (deg), velocity (deg/s) and activations now."""
        return sensing.state(np.degrees(self.q), np.degrees(self.v), self.act)

    def observation_array(self) -> np.ndarray:
        """(N, 4 + n) float64 observations in protocol.OBSERVATION_KEYS order (the TensorDict holds float32 casts):
        the sensed terms delay_frames late and noisy (`shoulder_bench.tasks.sensing`), the targets current."""
        k = np.minimum(self.frames + 1, self.episode_frames)
        rows = np.arange(self.num_envs)
        angle, velocity, act = self._sensed()
        obs = protocol.observation(angle, velocity, self.targets[rows, k], self.target_vel[rows, k], act)
        return np.concatenate([obs[key] for key in protocol.OBSERVATION_KEYS], axis=1)

    # --- stepping ----------------------------------------------------------------------------------------------------
    def advance(self, actions) -> tuple[np.ndarray, np.ndarray, dict]:
        """One frame of every copy (auto-reset of the ended ones): rewards (N,) float64, dones (N,) bool, extras
        (rsl-rl's: time_outs, and the log of ended episodes); the observations after it: `observation_array()`."""
        a = actions.detach().cpu().numpy() if torch.is_tensor(actions) else np.asarray(actions)
        applied, sent = protocol.to_delta(a, self.n, self.discrete, batch=self.num_envs)  # raises before any change
        acting = self._frame_activations(applied)  # per physics step with the physiology options
        self.qpos, self.qvel, bad = self.sim.frame_state(self.qpos, self.qvel, acting)
        q = self.q
        self.frames += 1
        self._sense_frame()
        angle = np.degrees(q)
        rows = np.arange(self.num_envs)
        lo, hi = arm_.RANGE_DEG
        crashed = bad | ~np.isfinite(self.qpos).all(axis=1) | ~np.isfinite(self.qvel).all(axis=1)
        crashed |= (np.abs(self.qpos) > MAX_ABS).any(axis=1) | (np.abs(self.qvel) > MAX_ABS).any(axis=1)
        crashed |= (angle < lo - VALID_MARGIN_DEG) | (angle > hi + VALID_MARGIN_DEG)
        target_now = self.targets[rows, self.frames]
        reward = protocol.reward(angle, target_now, sent, self.task.alpha, self.task.omega_max,
                                 self.task.tracking_only)
        left = self.episode_frames - self.frames + 1
        reward = np.where(crashed, -protocol.CRASH_ERROR_DEG * left, reward)
        self.last_reward = reward  # float64; the returned tensor is a float32 cast
        self.last_angle_deg, self.last_target_deg, self.last_crashed = angle, target_now, crashed
        self.last_error_deg = np.abs(angle - target_now)  # the tracking error (evaluate's)
        self.last_activation = self.act.copy()  # in force during this frame (before any auto-reset)
        self.last_excitation, self.last_fatigue = self.excitation.copy(), self.fatigue_state.copy()
        self.last_draws = (self.draw_strength.copy(), self.draw_mass.copy(), self.draw_load.copy())
        self._return += reward
        self._abs_err += np.where(crashed, 0.0, np.abs(angle - target_now))
        time_out = (self.frames >= self.episode_frames) & ~crashed
        done = crashed | time_out
        self.episode_length_buf += 1
        extras = {"time_outs": torch.as_tensor(time_out, device=self.device)}
        finished = np.flatnonzero(done)
        self.last_final_obs = None  # (N, 4 + n) float64 where `done`: each ended episode's last observation
        if finished.size:
            self.last_final_obs = self.observation_array()
            extras["log"] = {"/episode/return": float(self._return[finished].mean()),
                             "/episode/length": float(self.frames[finished].mean()),
                             "/episode/mae_deg": float((self._abs_err[finished] / self.frames[finished]).mean()),
                             "/episode/crash_rate": float(crashed[finished].mean())}
            self._finished.extend(self._return[finished].tolist())
            self._reset(finished)
        return reward, done, extras

    # --- checkpoints --------------------------------------------------------------------------------------------------
    _STATE = ("targets", "target_vel", "frames", "qpos", "qvel", "act", "_return", "_abs_err")

    def state_dict(self) -> dict:
        """Everything that decides the copies' future: physics state (with the constraint solver's warmstart),
        activations, targets, episode progress, every copy's target RNG and, for the sensing options, the delay
        buffer, the noise of the observation now and every copy's noise RNG, so a restored env continues exactly as
        this one would."""
        warm = None if self.sim.warmstart is None else self.sim.warmstart.copy()
        return {"num_envs": self.num_envs, "name": self.name, "rngs": [r.bit_generator.state for r in self.rngs],
                "episode_length_buf": self.episode_length_buf.clone(), "finished": list(self._finished),
                "warmstart": warm, **self._sensing_state(), **self._physiology_state(),
                **{key: getattr(self, key).copy() for key in self._STATE}}

    def load_state_dict(self, state: dict) -> None:
        if (state["name"], state["num_envs"]) != (self.name, self.num_envs):
            raise ValueError(f"env state of {state['num_envs']} copies of {state['name']} cannot be restored into "
                             f"{self.num_envs} copies of {self.name}")
        self._check_physiology(state)
        missing = [k for k in self._STATE if k not in state]
        if missing:
            raise ValueError(f"env state lacks {missing}: it was saved by another version of the model")
        self._load_sensing(state)
        for rng, saved_rng in zip(self.rngs, state["rngs"]):
            rng.bit_generator.state = saved_rng
        for key in self._STATE:
            setattr(self, key, np.array(state[key], copy=True))
        self._load_physiology(state)
        if self.sim.warmstart is not None and state.get("warmstart") is not None:
            self.sim.warmstart[:] = state["warmstart"]
        self.episode_length_buf = state["episode_length_buf"].clone().to(self.device)
        self._finished = list(state["finished"])

    def close(self) -> None:
        self.sim.close()
