"""N copies of a 3-DOF task (`tasks.track3d`) in lockstep as an rsl-rl `VecEnv`: MuJoCo's RK4 with the compiled
callbacks (`simulator.BatchSimulator`, engine "mujoco"), one `rollout` of a frame's 10 physics steps for all copies;
auto-reset, episode statistics.

Copy i draws its targets as `shoulder_bench.load(name, seed=seed + i)` does and starts its episodes the same way
(pose, holding activations), so a batched episode follows the single env's with the same actions up to the solver's
warmstart (`rollout` starts every frame from a zero warmstart; `mj_step` carries it: ~1e-10 deg over an episode).
Observation (float32, 25 columns): the three coordinates (deg), their rates (deg/s), the targets and target rates at
the next frame, the 13 activations; the same as the single env's `protocol.flatten`.
"""
from __future__ import annotations

import numpy as np
import torch

from shoulder_bench import full_arm, protocol, randomization, statics_full, trajectory3
from shoulder_bench.arm import harden_couplings
from shoulder_bench.simulator import BatchSimulator
from shoulder_bench.tasks import TASKS_3DOF, check_name, sensing
from shoulder_bench.tasks import options as options_check
from shoulder_bench.tasks.lockstep import Lockstep
from shoulder_bench.tasks.track3d import Track3D, law_for, valid_range_deg


class VecEnv3(Lockstep):
    """`shoulder_bench.make_vec(name, num_envs, ...)` for the 3-DOF tasks; `trajectory`: one target for all copies
    or a list with one per copy (a copy's episodes then repeat its target)."""

    SENSED_DOFS = 3  # plane, elevation, rotation
    DONE_DTYPE = torch.bool  # as its step returned them before `advance` (its runs were trained so)

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
        # the task's condition: its factors and its geometry (ld_transfer: its model and tables)
        self.law = law_for(muscle_model, self.task.line_of_action, self.task.factors, self.task.geometry,
                           self.task.tendon)
        # MuJoCo's RK4 with the compiled callbacks, one rollout per frame (the law reads each tendon's length);
        # randomize: one model per copy, compiled without the textures (randomization.physics_only_xml)
        model_file = full_arm.model_file(self.task.geometry)
        source = {"path": model_file} if self.task.randomize is None else {
            "xml": randomization.physics_only_xml(model_file)}
        self.sim = BatchSimulator(self.law, self.num_envs, nthread=nthread, prepare=harden_couplings,
                                  engine="mujoco", **source)
        m = self.model = self.sim.model
        self.pose = full_arm.Pose(m)
        self.statics = statics_full.Statics(self.law, self.pose)
        self.qadr, self.dadr = self.pose.qadr, self.pose.dadr
        self.valid_lo, self.valid_hi = valid_range_deg(m)
        self.rngs = [np.random.default_rng(None if seed is None else seed + i) for i in range(self.num_envs)]
        self._setup_sensing(seed)
        self._setup_physiology(seed, randomization.groups(m, full_arm.ACTUATORS, self.muscles))
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
        self.last_angle_deg = np.zeros((self.num_envs, 3))
        self.last_target_deg = np.zeros((self.num_envs, 3))
        self.last_activation = np.zeros((self.num_envs, self.n))
        self._reset(np.arange(self.num_envs))

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
        self._sense_reset(idx)
        self._physiology_reset(idx)

    def _sense(self) -> np.ndarray:
        """(N, 6 + n): the true angles (deg), velocities (deg/s) and activations now."""
        return sensing.state(np.degrees(self.qpos[:, self.qadr]), np.degrees(self.qvel[:, self.dadr]), self.act)

    def observation_array(self) -> np.ndarray:
        """(N, 12 + n): the sensed terms delay_frames late and noisy (`shoulder_bench.tasks.sensing`), the targets
        current."""
        rows = np.arange(self.num_envs)
        k = np.minimum(self.frames + 1, self.episode_frames)
        angle, velocity, act = self._sensed()
        return np.concatenate([angle, velocity, self.targets[rows, k], self.target_vel[rows, k], act], axis=1)

    def error_deg(self) -> np.ndarray:
        """(N,) the angle between each copy's humerus orientation and its target's now (deg)."""
        rows = np.arange(self.num_envs)
        target = self.targets[rows, np.minimum(self.frames, self.episode_frames)]
        return full_arm.angular_distance_deg(self.pose.orientation(self.qpos),
                                             self.pose.orientation(self.pose.qpos(target)))

    def advance(self, actions) -> tuple[np.ndarray, np.ndarray, dict]:
        """One frame of every copy (auto-reset of the ended ones): rewards (N,), dones (N,) bool, extras; see
        `Lockstep.step`."""
        a = actions.detach().cpu().numpy() if isinstance(actions, torch.Tensor) else np.asarray(actions)
        applied, sent = protocol.to_delta(a, self.n, self.discrete, batch=self.num_envs)
        acting = self._frame_activations(applied)  # per physics step with the physiology options
        self.qpos, self.qvel, bad = self.sim.frame_state(self.qpos, self.qvel, acting)  # bad: MuJoCo reset it
        angles = np.degrees(self.qpos[:, self.qadr])
        crashed = bad | np.any((angles < self.valid_lo) | (angles > self.valid_hi), axis=1)
        self.qpos[crashed] = np.nan_to_num(self.qpos[crashed])
        self.qvel[crashed] = 0.0
        self.frames += 1
        self.episode_length_buf += 1
        self._sense_frame()
        err = self.error_deg()
        reward = protocol.reward(err, 0.0, sent, self.task.alpha, self.task.omega_max, False)
        reward[crashed] = -protocol.CRASH_ERROR_DEG * (self.episode_frames[crashed] - self.frames[crashed] + 1)
        self.last_error_deg, self.last_crashed = err, crashed
        rows = np.arange(self.num_envs)  # per coordinate |achieved - target| (deg), for the board's columns
        target_now = self.targets[rows, np.minimum(self.frames, self.episode_frames)]
        self.last_coordinate_error_deg = np.abs(angles - target_now)
        # what evaluate(record=True) traces: this frame's coordinates, target and activations, before any auto-reset
        self.last_angle_deg, self.last_target_deg, self.last_activation = angles, target_now, self.act.copy()
        self._return += reward
        timeout = self.frames >= self.episode_frames
        done = crashed | timeout
        extras = {"time_outs": torch.as_tensor(timeout & ~crashed, device=self.device)}
        finished = np.flatnonzero(done)
        if finished.size:
            extras["log"] = {"/episode/return": float(self._return[finished].mean())}
            self._finished.extend(self._return[finished].tolist())
            self._reset(finished)
        return reward, done, extras

    _STATE = ("targets", "target_vel", "frames", "qpos", "qvel", "act", "_return", "episode_frames")

    def state_dict(self) -> dict:
        """Everything that decides the next frames: the copies' state and targets, every RNG, the delay buffer and
        the noise of the observation now, so a restored env continues exactly as this one would."""
        return {"num_envs": self.num_envs, "name": self.name, "rngs": [r.bit_generator.state for r in self.rngs],
                **self._sensing_state(), **self._physiology_state(),
                **{k: getattr(self, k).copy() for k in self._STATE}}

    def load_state_dict(self, state: dict) -> None:
        if state["num_envs"] != self.num_envs or state["name"] != self.name:
            raise ValueError(f"checkpoint env state is for {state['num_envs']} copies of {state['name']}, not "
                             f"{self.num_envs} of {self.name}")
        self._check_physiology(state)
        self._load_sensing(state)
        for r, s in zip(self.rngs, state["rngs"]):
            r.bit_generator.state = s
        for k in self._STATE:
            setattr(self, k, np.array(state[k]))
        self._load_physiology(state)
        # a copy: torch.as_tensor would share the frames array, and both count up each frame (every episode then
        # ran at twice the pace after a restore: a resumed 3-DOF run ended its episodes at half their length)
        self.episode_length_buf = torch.tensor(self.frames, dtype=torch.long, device=self.device)

    def close(self) -> None:
        self.sim.close()
