"""Shoulder abduction trajectory tracking, the paper's protocol, as dm_control tasks.

A frame (control step) is 0.1 s. The agent sees the angle and angular velocity of the humerus, the target angle and
velocity at the next frame and the current activations; it sends a change of activation per muscle (continuous within
+-0.01, or one of 21 levels). Episodes follow a random target (train: 10 s, end points U[30, 90] deg; test: 20 s,
U[20, 100] deg) or a given one. Numerical failure ends the episode with a penalty and `crashed` set.
"""
from __future__ import annotations

import math

import numpy as np
from dm_control.mujoco import wrapper
from dm_control.mujoco.engine import Physics as _Physics
from dm_control.rl import control
from dm_control.rl.control import PhysicsError
from dm_env import specs

from shoulder_bench import arm as arm_
from shoulder_bench import protocol, statics, trajectory
from shoulder_bench.model import DEFAULT_MUSCLE_MODEL, attach_law, install_callbacks, law_of
from shoulder_bench.tasks import options as opt
from shoulder_bench.tasks import sensing
from shoulder_bench.tasks.single_env import SingleEnv
from shoulder_bench.trajectory import as_trajectory

VALID_MARGIN_DEG = arm_.VALID_MARGIN_DEG  # beyond the joint range by more than this = the simulation has failed
MAX_JOINT_DAMPING = 10.0  # N m s/rad: the sensitivity runs use 0.1-1.0; far above, RK4 at 50 ms is not stable
INITS = ("hold", "zero")  # start at rest on the target with the holding activations, or with none


class Physics(_Physics):
    """The shoulder (the locked v2 arm, `shoulder_bench.arm`) with named accessors (degrees at this surface, radians
    inside MuJoCo). The angle is the thoracohumeral elevation `shoulder_elv`; the girdle joints follow it."""

    crashed = False  # set when MuJoCo reported an instability during the last step
    _failed = False
    plan = None  # (muscles, (nstep, n)): the activation of each physics step of the next `step` (physiology options)

    def _adr(self) -> tuple[int, int]:
        adr = self.__dict__.get("_elevation_adr")
        if adr is None:
            jnt = self.model.name2id(arm_.JOINT, "joint")
            adr = self.__dict__["_elevation_adr"] = (int(self.model.jnt_qposadr[jnt]), int(self.model.jnt_dofadr[jnt]))
        return adr

    def angle_deg(self) -> float:
        return float(np.degrees(self.data.qpos[self._adr()[0]]))

    def angular_velocity_deg(self) -> float:
        return float(np.degrees(self.data.qvel[self._adr()[1]]))

    def activations(self, muscles) -> np.ndarray:
        """Activation of each muscle (the ctrl of its first actuator; all its actuators carry the same)."""
        return self.data.ctrl[self.actuator_ids(muscles)]

    def actuator_ids(self, muscles) -> list[int]:
        """The first actuator of each muscle."""
        return [self.model.name2id(arm_.ACTUATORS[m][0], "actuator") for m in muscles]

    def set_activations(self, muscles, values) -> None:
        """Write each muscle's activation into all its actuators."""
        maps = self.__dict__.setdefault("_ctrl_maps", {})
        key = tuple(muscles)
        if key not in maps:
            pairs = [(self.model.name2id(a, "actuator"), k) for k, m in enumerate(key) for a in arm_.ACTUATORS[m]]
            maps[key] = (np.array([p[0] for p in pairs]), np.array([p[1] for p in pairs]))
        ids, src = maps[key]
        self.data.ctrl[ids] = np.asarray(values, dtype=float)[src]

    def set_angle(self, angle_deg: float) -> None:
        """Pose the arm at rest at `angle_deg` elevation, the girdle on its coupling."""
        self.data.qpos[:] = arm_.arm().qpos(np.radians(angle_deg))[0]
        self.data.qvel[:] = 0.0

    def step(self, nstep: int = 1) -> None:
        """Step; a MuJoCo instability marks the physics as crashed instead of raising inside a training loop. With a
        `plan` (set by the task for one frame), each physics step first gets its own activations."""
        plan, self.plan = self.plan, None
        try:
            if plan is None:
                super().step(nstep)
                return
            for k in range(nstep):
                self.set_activations(plan[0], plan[1][k])
                super().step(1)
        except PhysicsError:
            self.crashed = True

    def failed(self) -> bool:
        """Whether the simulation has failed (as of the last `check_failure`)."""
        return self._failed

    def check_failure(self) -> bool:
        """Non-finite state, a MuJoCo instability, or the arm more than VALID_MARGIN_DEG past the joint range."""
        qa, va = self._adr()
        q, v = float(self.data.qpos[qa]), float(self.data.qvel[va])
        lo, hi = (np.radians(x) for x in (arm_.RANGE_DEG[0] - VALID_MARGIN_DEG, arm_.RANGE_DEG[1] + VALID_MARGIN_DEG))
        finite = bool(np.isfinite(self.data.qpos).all() and np.isfinite(self.data.qvel).all())
        self._failed = bool(self.crashed or not (finite and math.isfinite(q) and math.isfinite(v)) or not lo <= q <= hi)
        return self._failed


def make_physics(muscles, muscle_model: str, condition: dict | None = None) -> Physics:
    """The physics of `muscles` with the law of `muscle_model`; condition: `Abduction.condition` (the condition and
    its fractions, `shoulder_bench.conditions`), default the intact shoulder. A condition with a geometry
    (ld_transfer) gets that geometry's model and tables (`arm.arm_for`)."""
    the_arm = arm_.arm_for((condition or {}).get("condition"))
    law = the_arm.load_law(muscle_model, muscles, **(condition or {}))  # checked before the (slower) compile
    model = arm_.compile_arm(the_arm.geometry)
    attach_law(model, law)
    install_callbacks()
    return Physics.from_model(wrapper.MjModel(model))


class Abduction(SingleEnv, control.Task):
    """Track a target abduction angle with the activations of `muscles`. Bad options raise ValueError naming the
    option and what it accepts (`shoulder_bench.tasks.options`)."""

    ACTUATORS = arm_.ACTUATORS

    def __init__(self, muscles, discrete=False, split="train", trajectory_=None, tracking_only=None,
                 alpha=protocol.DEFAULT_ALPHA, omega_max=protocol.DEFAULT_OMEGA_MAX, init="hold", joint_damping=0.0,
                 delay_frames=0, obs_noise_deg=0.0, condition=None, tear_fraction=None, weakness_fraction=None,
                 activation_dynamics=False, randomize=None, fatigue=False, random=None, **unknown):
        super().__init__()
        opt.check_names(unknown)
        if unknown:  # options of the 3-DOF tasks only
            raise ValueError(f"option(s) {sorted(unknown)} apply to the 3-DOF tasks only")
        self.muscles = tuple(muscles)
        self.discrete = bool(discrete)
        self.split = opt.choice("split", split, tuple(trajectory.SPLITS))
        self.fixed = trajectory_
        tracking_only = opt.flag("tracking_only", tracking_only)
        self.tracking_only = len(self.muscles) == 1 if tracking_only is None else tracking_only
        self.alpha = opt.number("alpha", alpha, 0.0, protocol.MAX_ALPHA)
        self.omega_max = opt.number("omega_max", omega_max, 0.0)
        self.init = opt.choice("init", init, INITS)
        # viscous damping of the elevation joint (N m s/rad); the model has none (docs/model_v2.md "Damping")
        self.joint_damping = opt.number("joint_damping", joint_damping, 0.0, MAX_JOINT_DAMPING)
        # sensing, condition (applied to the law by make_physics), physiology; the generators (SingleEnv)
        self._setup_options(delay_frames, obs_noise_deg, condition, tear_fraction, weakness_fraction,
                            activation_dynamics, fatigue, randomize, random)
        self.target: trajectory.Trajectory | None = None
        self.frame = 0
        self.sent = np.zeros(len(self.muscles))
        self.law = None

    # --- dm_control Task API -------------------------------------------------------------------------------------
    def action_spec(self, physics):
        n = len(self.muscles)
        if self.discrete:
            if n == 1:
                return specs.DiscreteArray(protocol.LEVELS, dtype=np.int64, name="level")
            return specs.BoundedArray((n,), np.int64, 0, protocol.LEVELS - 1, name="levels")
        return specs.BoundedArray((n,), np.float64, -protocol.ACTION_LIMIT, protocol.ACTION_LIMIT,
                                  name="activation_change")

    def initialize_episode(self, physics):
        if self.fixed is not None:
            self.target = self.fixed
        else:
            self.target = trajectory.random_trajectory(self.rng, self.split)
        self.frame = 0
        self.sent = np.zeros(len(self.muscles))
        self._ids = physics.actuator_ids(self.muscles)
        physics.crashed = False
        physics._failed = False
        physics.set_angle(self.target.angle_deg[0])
        physics.data.ctrl[:] = 0.0
        if self.init == "hold":
            physics.set_activations(self.muscles,
                                    statics.holding_activation(self._law(physics), self.target.angle_deg[0])[0])
        self._start_episode(physics)

    def _law(self, physics):
        if self.law is None:
            self.law = law_of(physics.model.ptr)
        return self.law

    def before_step(self, action, physics):
        """Validate, then apply: bad input raises ValueError before anything changes."""
        delta, sent = self.action_to_delta(action)
        self.sent = sent
        self._apply_change(physics, delta)

    def _ctrl_activations(self, physics) -> np.ndarray:
        return physics.data.ctrl[self._ids]

    def action_to_delta(self, action) -> tuple[np.ndarray, np.ndarray]:
        """(applied change, change as sent) from an action; raises ValueError for NaN/inf or a wrong shape."""
        applied, sent = protocol.to_delta(action, len(self.muscles), self.discrete)
        return applied[0], sent[0]

    def after_step(self, physics):
        self.frame += 1
        physics.check_failure()
        self._sense_step(physics)

    def sense(self, physics) -> np.ndarray:
        """(1, 2 + n): the true angle (deg), velocity (deg/s) and activations now."""
        return sensing.state(physics.angle_deg(), physics.angular_velocity_deg(), self.activations_now(physics))

    def get_observation(self, physics):
        k = min(self.frame + 1, len(self.target.angle_deg) - 1)
        if self.history is not None:  # delay_frames > 0: the state of frame t - delay_frames
            old = self.history[0].copy()  # the observation must not alias the buffer
            angle, velocity, act = old[:, 0], old[:, 1], old[0, 2:]
        else:
            angle, velocity, act = physics.angle_deg(), physics.angular_velocity_deg(), self.activations_now(physics)
        angle, velocity = sensing.noisy(angle, velocity, self.obs_noise_deg, self.noise_z)
        obs = protocol.observation(angle, velocity, self.target.angle_deg[k], self.target.velocity_deg_s[k], act)
        return {key: v[0] for key, v in obs.items()}

    def get_reward(self, physics):
        if physics.failed():
            return -protocol.CRASH_ERROR_DEG * (self.target.frames - self.frame + 1)
        r = protocol.reward(physics.angle_deg(), self.target.angle_deg[self.frame], self.sent[None, :],
                            self.alpha, self.omega_max, self.tracking_only)
        return float(r[0])

    def get_termination(self, physics):
        if physics.failed():
            return 0.0
        if self.frame >= self.target.frames:
            return 1.0  # end of the target: a time limit, not a terminal state
        return None

    def target_deg(self) -> float:
        return float(self.target.angle_deg[min(self.frame, len(self.target.angle_deg) - 1)])


def make_env(muscles, discrete=False, split="train", seed=None, trajectory=None, muscle_model=DEFAULT_MUSCLE_MODEL,
             **options) -> control.Environment:
    """A dm_control Environment of the abduction task (see `Abduction` for the options); options are checked before
    the model is built."""
    target = as_trajectory(trajectory)
    task = Abduction(muscles, discrete=discrete, split=split, trajectory_=target, random=seed, **options)
    physics = make_physics(tuple(muscles), muscle_model, task.condition)
    physics.model.dof_damping[physics._adr()[1]] = task.joint_damping
    return control.Environment(physics, task, time_limit=float("inf"), control_timestep=protocol.FRAME_S)
