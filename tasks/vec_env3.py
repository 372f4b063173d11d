"""N copies of a 3-DOF task (`tasks.track3d`) in lockstep as an rsl-rl `VecEnv`: MuJoCo's RK4 with the compiled
callbacks, one `rollout` of a frame's 10 physics steps for all copies; auto-reset, episode statistics.

Copy i draws its targets as `shoulder_bench.load(name, seed=seed + i)` does and starts its episodes the same way
(pose, holding activations), so a batched episode follows the single env's with the same actions up to the solver's
warmstart (`rollout` starts every frame from a zero warmstart; `mj_step` carries it: ~1e-10 deg over an episode).
Observation (float32, 25 columns): the three coordinates (deg), their rates (deg/s), the targets and target rates at
the next frame, the 13 activations; the same as the single env's `protocol.flatten`.
"""
from __future__ import annotations

import mujoco
import numpy as np
import torch
from mujoco import rollout
from tensordict import TensorDict

from shoulder_bench import full_arm, protocol, statics_full, trajectory3
from shoulder_bench.model import attach_law, install_callbacks
from shoulder_bench.tasks import TASKS_3DOF, check_name
from shoulder_bench.tasks import options as options_check
from shoulder_bench.tasks.track3d import Track3D
from shoulder_bench.tasks.vec_env import Lockstep
from shoulder_bench.tendon_law import TendonLaw

START_TIME = 1e3  # every frame's rollout starts at this time, so a MuJoCo reset (time back to 0) shows


class VecEnv3(Lockstep):
    """`shoulder_bench.make_vec(name, num_envs, ...)` for the 3-DOF tasks; `trajectory`: one target for all copies
    or a list with one per copy (a copy's episodes then repeat its target)."""

    def __init__(self, name: str, num_envs: int, device: str = "cpu", seed=None, trajectory=None,
                 muscle_model: str = "fem", nthread: int = 2, **options):
        muscles, discrete, preset, _ = TASKS_3DOF[check_name(name)]
        if isinstance(num_envs, bool) or not isinstance(num_envs, (int, np.integer)) or num_envs < 1:
            raise ValueError(f"num_envs must be an integer >= 1, got {num_envs!r}")
        if muscle_model != "fem":
            raise ValueError(f"muscle_model {muscle_model!r}: the full shoulder has FEM tables only ('fem')")
        seed = options_check.seed(seed)
        self.name, self.num_envs, self.device = name, int(num_envs), torch.device(device)
        fixed = trajectory if isinstance(trajectory, (list, tuple)) else [trajectory] * self.num_envs
        if len(fixed) != self.num_envs:
            raise ValueError(f"{len(fixed)} trajectories for {self.num_envs} environments: give one, or one per copy")
        self.fixed = [trajectory3.as_trajectory(t) for t in fixed]
        self.task = Track3D(muscles, discrete=discrete, **{**preset, **options})
        self.muscles, self.discrete, self.n = tuple(muscles), discrete, len(muscles)
        self.num_actions = self.n
        self.cfg = {"task": name, "muscle_model": muscle_model, **options}
        self.law = TendonLaw.load(muscle_model, groups=full_arm.ACTUATORS)
        m = self.model = full_arm.compile_full()
        attach_law(m, self.law)
        install_callbacks(native=True)  # rollout's threads call them without the GIL
        self.pose = full_arm.Pose(m)
        self.statics = statics_full.Statics(self.law, self.pose)
        self.steps_per_frame = int(round(protocol.FRAME_S / m.opt.timestep))
        names = [m.actuator(i).name for i in range(m.nu)]
        self.ctrl_cols = np.array([names.index(t) for mu in self.muscles for t in full_arm.ACTUATORS[mu]])
        self.ctrl_src = np.array([k for k, mu in enumerate(self.muscles) for _ in full_arm.ACTUATORS[mu]])
        self.qadr, self.dadr = self.pose.qadr, self.pose.dadr
        ranges = np.degrees(m.jnt_range[[m.joint(c).id for c in full_arm.COORDINATES]])
        self.valid_lo = ranges[:, 0] - 30.0
        self.valid_hi = ranges[:, 1] + 30.0
        self._setup_rollout(nthread)
        self.rngs = [np.random.default_rng(None if seed is None else seed + i) for i in range(self.num_envs)]
        split_frames = int(round(trajectory3.SPLITS[self.task.split]["duration_s"] / protocol.FRAME_S))
        self.episode_frames = np.array([split_frames if t is None else t.frames for t in self.fixed])
        self.max_episode_length = int(self.episode_frames.max())
        self.targets = np.zeros((self.num_envs, self.max_episode_length + 1, 3))
        self.target_vel = np.zeros_like(self.targets)
        self.frames = np.zeros(self.num_envs, dtype=np.int64)
        self.qpos = np.zeros((self.num_envs, m.nq))
        self.qvel = np.zeros((self.num_envs, m.nv))
        self.act = np.zeros((self.num_envs, self.n))
        self._return = np.zeros(self.num_envs)
        self._finished: list[float] = []
        self.episode_length_buf = torch.zeros(self.num_envs, dtype=torch.long, device=self.device)
        self.last_error_deg = np.zeros(self.num_envs)
        self.last_crashed = np.zeros(self.num_envs, dtype=bool)
        self.last_coordinate_error_deg = np.zeros((self.num_envs, 3))
        self._reset(np.arange(self.num_envs))

    def _setup_rollout(self, nthread: int) -> None:
        m = self.model
        spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
        d = mujoco.MjData(m)
        probe = np.zeros(mujoco.mj_stateSize(m, spec))
        d.qpos[:], d.qvel[:], d.time = 1e6 + np.arange(m.nq), 2e6 + np.arange(m.nv), 3e6
        mujoco.mj_getState(m, d, probe, spec)
        iq, iv = int(np.flatnonzero(probe == 1e6)[0]), int(np.flatnonzero(probe == 2e6)[0])
        self._iq, self._iv = slice(iq, iq + m.nq), slice(iv, iv + m.nv)
        self._it = int(np.flatnonzero(probe == 3e6)[0])
        mujoco.mj_resetData(m, d)
        base = np.zeros_like(probe)
        mujoco.mj_getState(m, d, base, spec)
        self._state = np.tile(base, (self.num_envs, 1))
        self._ctrl = np.zeros((self.num_envs, self.steps_per_frame, m.nu))
        self._out = np.zeros((self.num_envs, self.steps_per_frame, len(base)))
        self._datas = [mujoco.MjData(m) for _ in range(nthread)]
        self._models = [m] * self.num_envs
        self._rollout = rollout.Rollout(nthread=nthread)

    def _reset(self, idx: np.ndarray) -> None:
        for i in idx:
            target = self.fixed[i] if self.fixed[i] is not None else self.task.draw_target(self.rngs[i])
            k = target.frames + 1
            self.targets[i, :k], self.target_vel[i, :k] = target.angle_deg, target.velocity_deg_s
            self.targets[i, k:], self.target_vel[i, k:] = target.angle_deg[-1], 0.0
            self.episode_frames[i] = target.frames
            self.qpos[i] = self.pose.qpos(target.angle_deg[0])[0]
            self.act[i] = self.statics.holding(target.angle_deg[0])[0] if self.task.init == "hold" else 0.0
        self.qvel[idx] = 0.0
        self.frames[idx] = 0
        self._return[idx] = 0.0
        self.episode_length_buf[torch.as_tensor(idx)] = 0

    def observation_array(self) -> np.ndarray:
        rows = np.arange(self.num_envs)
        k = np.minimum(self.frames + 1, self.episode_frames)
        return np.concatenate([np.degrees(self.qpos[:, self.qadr]), np.degrees(self.qvel[:, self.dadr]),
                               self.targets[rows, k], self.target_vel[rows, k], self.act], axis=1)

    def error_deg(self) -> np.ndarray:
        """(N,) the angle between each copy's humerus orientation and its target's now (deg)."""
        rows = np.arange(self.num_envs)
        target = self.targets[rows, np.minimum(self.frames, self.episode_frames)]
        return full_arm.angular_distance_deg(self.pose.orientation(self.qpos),
                                             self.pose.orientation(self.pose.qpos(target)))

    def step(self, actions) -> tuple[TensorDict, torch.Tensor, torch.Tensor, dict]:
        a = actions.detach().cpu().numpy() if isinstance(actions, torch.Tensor) else np.asarray(actions)
        applied, sent = protocol.to_delta(a, self.n, self.discrete, batch=self.num_envs)
        self.act = np.clip(self.act + applied, 0.0, 1.0)
        self._ctrl[:, :, self.ctrl_cols] = self.act[:, None, self.ctrl_src]
        self._state[:, self._iq], self._state[:, self._iv] = self.qpos, self.qvel
        self._state[:, self._it] = START_TIME
        self._rollout.rollout(self._models, self._datas, self._state, self._ctrl, nstep=self.steps_per_frame,
                              skip_checks=True, state=self._out)
        end = self._out[:, -1]
        self.qpos, self.qvel = end[:, self._iq].copy(), end[:, self._iv].copy()
        angles = np.degrees(self.qpos[:, self.qadr])
        crashed = ~(end[:, self._it] > START_TIME) | ~np.isfinite(end).all(axis=1) | \
            np.any((angles < self.valid_lo) | (angles > self.valid_hi), axis=1)
        self.qpos[crashed] = np.nan_to_num(self.qpos[crashed])
        self.qvel[crashed] = 0.0
        self.frames += 1
        self.episode_length_buf += 1
        err = self.error_deg()
        reward = protocol.reward(err, 0.0, sent, self.task.alpha, self.task.omega_max, False)
        reward[crashed] = -protocol.CRASH_ERROR_DEG * (self.episode_frames[crashed] - self.frames[crashed] + 1)
        self.last_error_deg, self.last_crashed = err, crashed
        rows = np.arange(self.num_envs)  # per coordinate |achieved - target| (deg), for the board's columns
        self.last_coordinate_error_deg = np.abs(angles - self.targets[rows, np.minimum(self.frames,
                                                                                       self.episode_frames)])
        self._return += reward
        timeout = self.frames >= self.episode_frames
        done = crashed | timeout
        extras = {"time_outs": torch.as_tensor(timeout & ~crashed, device=self.device)}
        finished = np.flatnonzero(done)
        if finished.size:
            extras["log"] = {"/episode/return": float(self._return[finished].mean())}
            self._finished.extend(self._return[finished].tolist())
            self._reset(finished)
        obs = self._observation()
        return (obs, torch.as_tensor(reward, dtype=torch.float32, device=self.device),
                torch.as_tensor(done, device=self.device), extras)

    def state_dict(self) -> dict:
        return {"num_envs": self.num_envs, "name": self.name, "rngs": [r.bit_generator.state for r in self.rngs],
                **{k: getattr(self, k).copy() for k in ("targets", "target_vel", "frames", "qpos", "qvel", "act",
                                                         "_return", "episode_frames")}}

    def load_state_dict(self, state: dict) -> None:
        if state["num_envs"] != self.num_envs or state["name"] != self.name:
            raise ValueError(f"checkpoint env state is for {state['num_envs']} copies of {state['name']}, not "
                             f"{self.num_envs} of {self.name}")
        for r, s in zip(self.rngs, state["rngs"]):
            r.bit_generator.state = s
        for k in ("targets", "target_vel", "frames", "qpos", "qvel", "act", "_return", "episode_frames"):
            setattr(self, k, np.array(state[k]))
        self.episode_length_buf = torch.as_tensor(self.frames, dtype=torch.long, device=self.device)

    def close(self) -> None:
        self._rollout.close()
