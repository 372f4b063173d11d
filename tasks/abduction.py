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

from shoulder_bench import protocol, statics, trajectory
from shoulder_bench.anatomy import JOINT_RANGE_DEG
from shoulder_bench.model import DEFAULT_MUSCLE_MODEL, SCENE_PATH, attach_law, compile_model, install_callbacks, law_of
from shoulder_bench.tasks import options as opt

VALID_MARGIN_DEG = protocol.VALID_MARGIN_DEG  # beyond the joint limits by more than this = the simulation has failed
INITS = ("hold", "zero")  # start at rest on the target with the holding activations, or with none


class Physics(_Physics):
    """The shoulder with named accessors (degrees at this surface, radians inside MuJoCo)."""

    crashed = False  # set when MuJoCo reported an instability during the last step
    _failed = False

    def angle_deg(self) -> float:
        return float(np.degrees(self.data.qpos[0]))  # the abduction hinge is the model's only joint

    def angular_velocity_deg(self) -> float:
        return float(np.degrees(self.data.qvel[0]))

    def activations(self, muscles) -> np.ndarray:
        return self.data.ctrl[self.actuator_ids(muscles)]

    def actuator_ids(self, muscles) -> list[int]:
        return [self.model.name2id(m, "actuator") for m in muscles]

    def step(self, nstep: int = 1) -> None:
        """Step; a MuJoCo instability marks the physics as crashed instead of raising inside a training loop."""
        try:
            super().step(nstep)
        except PhysicsError:
            self.crashed = True

    def failed(self) -> bool:
        """Whether the simulation has failed (as of the last `check_failure`)."""
        return self._failed

    def check_failure(self) -> bool:
        """Non-finite state, a MuJoCo instability, or the arm more than VALID_MARGIN_DEG past the joint limits."""
        q, v = float(self.data.qpos[0]), float(self.data.qvel[0])
        lo, hi = np.radians(JOINT_RANGE_DEG[0] - VALID_MARGIN_DEG), np.radians(JOINT_RANGE_DEG[1] + VALID_MARGIN_DEG)
        self._failed = bool(self.crashed or not (math.isfinite(q) and math.isfinite(v)) or not lo <= q <= hi)
        return self._failed


def make_physics(muscles, muscle_model: str) -> Physics:
    from shoulder_bench.muscle import ForceLaw

    law = ForceLaw.load(muscle_model, muscles=muscles)  # checks muscle_model before the (slower) compile
    model = compile_model(SCENE_PATH)
    attach_law(model, law)
    install_callbacks()
    return Physics.from_model(wrapper.MjModel(model))


class Abduction(control.Task):
    """Track a target abduction angle with the activations of `muscles`. Bad options raise ValueError naming the
    option and what it accepts (`shoulder_bench.tasks.options`)."""

    def __init__(self, muscles, discrete=False, split="train", trajectory_=None, tracking_only=None,
                 alpha=protocol.DEFAULT_ALPHA, omega_max=protocol.DEFAULT_OMEGA_MAX, init="hold", random=None,
                 **unknown):
        super().__init__()
        opt.check_names(unknown)
        self.muscles = tuple(muscles)
        self.discrete = bool(discrete)
        self.split = opt.choice("split", split, tuple(trajectory.SPLITS))
        self.fixed = trajectory_
        tracking_only = opt.flag("tracking_only", tracking_only)
        self.tracking_only = len(self.muscles) == 1 if tracking_only is None else tracking_only
        self.alpha = opt.number("alpha", alpha, 0.0, protocol.MAX_ALPHA)
        self.omega_max = opt.number("omega_max", omega_max, 0.0)
        self.init = opt.choice("init", init, INITS)
        self.reseed(random)
        self.target: trajectory.Trajectory | None = None
        self.frame = 0
        self.sent = np.zeros(len(self.muscles))
        self.law = None

    def reseed(self, seed) -> None:
        self.rng = np.random.default_rng(opt.seed(seed))

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
        physics.data.qpos[0] = np.radians(self.target.angle_deg[0])
        physics.data.qvel[0] = 0.0
        physics.data.ctrl[:] = 0.0
        if self.init == "hold":
            physics.data.ctrl[self._ids] = statics.holding_activation(self._law(physics), self.target.angle_deg[0])[0]

    def _law(self, physics):
        if self.law is None:
            self.law = law_of(physics.model.ptr)
        return self.law

    def before_step(self, action, physics):
        """Validate, then apply: bad input raises ValueError before anything changes."""
        delta, sent = self.action_to_delta(action)
        ctrl = physics.data.ctrl
        ctrl[self._ids] = np.clip(ctrl[self._ids] + delta, 0.0, 1.0)
        self.sent = sent

    def action_to_delta(self, action) -> tuple[np.ndarray, np.ndarray]:
        """(applied change, change as sent) from an action; raises ValueError for NaN/inf or a wrong shape."""
        applied, sent = protocol.to_delta(action, len(self.muscles), self.discrete)
        return applied[0], sent[0]

    def after_step(self, physics):
        self.frame += 1
        physics.check_failure()

    def get_observation(self, physics):
        k = min(self.frame + 1, len(self.target.angle_deg) - 1)
        obs = protocol.observation(physics.angle_deg(), physics.angular_velocity_deg(), self.target.angle_deg[k],
                                   self.target.velocity_deg_s[k], physics.data.ctrl[self._ids])
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
    target = _as_trajectory(trajectory)
    task = Abduction(muscles, discrete=discrete, split=split, trajectory_=target, random=seed, **options)
    physics = make_physics(tuple(muscles), muscle_model)
    return control.Environment(physics, task, time_limit=float("inf"), control_timestep=protocol.FRAME_S)


def _as_trajectory(spec):
    if spec is None or isinstance(spec, trajectory.Trajectory):
        return spec
    if isinstance(spec, str) or hasattr(spec, "__fspath__"):
        found = trajectory.load_csv(spec)
        if len(found) != 1:
            raise ValueError(f"{spec} holds {len(found)} trajectories; a task tracks one (pick one with "
                             f"shoulder_bench.trajectory.load_csv(path)[k])")
        return found[0]
    return trajectory.from_array(spec)
