"""Trajectory tracking in three dimensions with the full shoulder's thirteen muscles (issue 12 §3), as dm_control
tasks.

The model is `models/shoulder_full_task.xml` (docs/model_full.md) with the FEM tables of `models/muscles_full`
(`tendon_law.TendonLaw`). The protocol is the paper's, per coordinate: a frame is 0.1 s; the agent sees, for the
plane of elevation, the elevation and the axial rotation (deg, in that order), the angle and its rate, the target and
its rate at the next frame, and the thirteen activations; it sends a change of activation per muscle (continuous
within +-0.01, or one of 21 levels). Reward: the paper's equation (1) with the tracking term the angle between the
achieved and the target humerus orientation (deg, `full_arm.angular_distance_deg`). Episodes start at rest on the
target with the holding activations (static optimisation, `statics_full`), or with none (init="zero"). A crash (non-
finite state, a MuJoCo instability, a coordinate more than VALID_MARGIN_DEG past its joint range) ends the episode
with the 1-DOF tasks' penalty.

Options (OPTIONS): the reward's alpha and omega_max, init, workspace, line_of_action ("band": the FEM bands' line of
action, `band_lines`; "band_fibres": and their fibres' force), tendon ("compliant": the parent's tendon in series with
every FEM sheet, `tendon_compliance`), what the agent senses, delay_frames and obs_noise_deg
(`sensing`, as the 1-DOF tasks'), and randomize (`shoulder_bench.randomization`, as the 1-DOF tasks': each episode's
muscle strengths through the actuators' gear, all of a muscle's tendons by one draw, on the band's line of action too
(`native.passive` reads the gear), the humerus mass and a load at the elbow, MoBL's humerus frame as the v2 arm's),
and a shoulder condition (`condition`, `tear_fraction`, `weakness_fraction`: `shoulder_bench.conditions`' tears and
weakness scale or remove muscles' tabled forces, `law_for`; ld_transfer reroutes ld1-3 on its own model and tables,
`full_arm.GEOMETRIES`, `pose_for`; the reference controller plans with them), and the muscle physiology
(`activation_dynamics`, `fatigue`: `shoulder_bench.physiology`, the 1-DOF tasks' per-step activation path,
`single_env.SingleEnv`).

Targets (`trajectory3`): random quintic segments per coordinate (train 10 s, test 20 s, wider ranges), a CSV file
(time_s, plane_deg, elevation_deg, rotation_deg), an ADL name, or (K, 3) degrees. `workspace="scapular_plane"`:
the paper's 1-DOF abduction targets (elevation) in the scapular plane (30 deg) at rotation 0, the other two held: the
abduction protocol with all muscles.
"""
from __future__ import annotations

import copy

import numpy as np
from dm_control.mujoco import wrapper
from dm_control.rl import control
from dm_env import specs

from shoulder_bench import (
    band_lines,
    conditions,
    full_arm,
    protocol,
    statics_full,
    tendon_compliance,
    trajectory,
    trajectory3,
)
from shoulder_bench.model import attach_law, install_callbacks
from shoulder_bench.tasks import options as opt
from shoulder_bench.tasks import sensing
from shoulder_bench.tasks.abduction import Physics
from shoulder_bench.tasks.single_env import SingleEnv
from shoulder_bench.tendon_law import TendonLaw

VALID_MARGIN_DEG = 30.0  # as the 1-DOF tasks' (arm.VALID_MARGIN_DEG)
WORKSPACES = ("3dof", "scapular_plane")
SCAPULAR_PLANE_DEG = 30.0
INITS = ("hold", "zero")
OPTIONS = ("alpha", "omega_max", "init", "workspace", "muscle_model", "line_of_action", "tendon", "delay_frames",
           "obs_noise_deg", "randomize", "condition", "tear_fraction", "weakness_fraction", "activation_dynamics",
           "fatigue")  # what the 3-DOF tasks accept
LAW_OPTIONS = ("line_of_action", "tendon")  # the options beside the condition that make the muscles' law (law_for)


def scapular(elevation_deg, name: str = "") -> trajectory3.Trajectory3:
    """A 1-DOF elevation target (deg at the frame rate) as a 3-DOF one in the scapular plane at rotation 0."""
    e = np.asarray(elevation_deg, dtype=float)
    angle = np.stack([np.full_like(e, SCAPULAR_PLANE_DEG), e, np.zeros_like(e)], axis=1)
    return trajectory3.Trajectory3(angle, np.gradient(angle, protocol.FRAME_S, axis=0), name=name)


def valid_range_deg(m) -> tuple[np.ndarray, np.ndarray]:
    """(low, high) (3,) deg of each coordinate beyond which the simulation has failed: its joint range widened by
    VALID_MARGIN_DEG (the single env's and the batched env's crash rule). `m`: an mjModel or dm_control's wrapper."""
    jnt = [m.joint(c).id for c in full_arm.COORDINATES]
    ranges = np.degrees(np.asarray(m.jnt_range)[jnt])
    return ranges[:, 0] - VALID_MARGIN_DEG, ranges[:, 1] + VALID_MARGIN_DEG


class Physics3(Physics):
    """The full shoulder with named accessors (degrees at this surface); `step` and its per-physics-step activation
    `plan` (the physiology options) are the 1-DOF tasks' `abduction.Physics`'."""

    def _adr(self):
        adr = self.__dict__.get("_adr3")
        if adr is None:
            m = self.model
            q = np.array([m.jnt_qposadr[m.name2id(c, "joint")] for c in full_arm.COORDINATES])
            v = np.array([m.jnt_dofadr[m.name2id(c, "joint")] for c in full_arm.COORDINATES])
            adr = self.__dict__["_adr3"] = (q, v, *valid_range_deg(m.ptr))
        return adr

    def coordinates_deg(self) -> np.ndarray:
        return np.degrees(self.data.qpos[self._adr()[0]])

    def velocities_deg(self) -> np.ndarray:
        return np.degrees(self.data.qvel[self._adr()[1]])

    def set_activations(self, muscles, values) -> None:
        maps = self.__dict__.setdefault("_ctrl_maps", {})
        key = tuple(muscles)
        if key not in maps:
            pairs = [(self.model.name2id(a, "actuator"), k) for k, m in enumerate(key) for a in full_arm.ACTUATORS[m]]
            maps[key] = (np.array([p[0] for p in pairs]), np.array([p[1] for p in pairs]))
        ids, src = maps[key]
        self.data.ctrl[ids] = np.asarray(values, dtype=float)[src]

    def activations(self, muscles) -> np.ndarray:
        return self.data.ctrl[[self.model.name2id(full_arm.ACTUATORS[m][0], "actuator") for m in muscles]]

    def check_failure(self) -> bool:
        q, v, lo, hi = self._adr()
        finite = bool(np.isfinite(self.data.qpos).all() and np.isfinite(self.data.qvel).all())
        angles = self.coordinates_deg()
        self._failed = bool(self.crashed or not finite or np.any(angles < lo) or np.any(angles > hi))
        return self._failed


class Track3D(SingleEnv, control.Task):
    """Track a 3-DOF target with the full shoulder's muscles. Bad options raise ValueError naming the option."""

    dofs = DOFS = 3
    ACTUATORS = full_arm.ACTUATORS

    def __init__(self, muscles=full_arm.MUSCLES, discrete=False, split="train", trajectory_=None,
                 alpha=protocol.DEFAULT_ALPHA, omega_max=protocol.DEFAULT_OMEGA_MAX, init="hold", workspace="3dof",
                 line_of_action="mjcf", tendon="rigid", delay_frames=0, obs_noise_deg=0.0, randomize=None,
                 condition=None, tear_fraction=None, weakness_fraction=None, activation_dynamics=False, fatigue=False,
                 random=None, **unknown):
        super().__init__()
        if unknown:
            raise ValueError(f"option(s) {sorted(unknown)} are not offered on the 3-DOF tasks (yet); they accept "
                             f"{', '.join(OPTIONS)}")
        self.muscles = tuple(muscles)
        self.discrete = bool(discrete)
        self.split = opt.choice("split", split, tuple(trajectory3.SPLITS))
        self.alpha = opt.number("alpha", alpha, 0.0, protocol.MAX_ALPHA)
        self.omega_max = opt.number("omega_max", omega_max, 0.0)
        self.init = opt.choice("init", init, INITS)
        self.workspace = opt.choice("workspace", workspace, WORKSPACES)
        self.line_of_action = opt.choice("line_of_action", line_of_action, band_lines.LINES)
        self.tendon = opt.choice("tendon", tendon, tendon_compliance.TENDONS)
        self.geometry = conditions.geometry(condition)  # ld_transfer: its model and tables (full_arm.GEOMETRIES)
        # sensing, condition, physiology; the generators (SingleEnv)
        self._setup_options(delay_frames, obs_noise_deg, condition, tear_fraction, weakness_fraction,
                            activation_dynamics, fatigue, randomize, random)
        self.fixed = trajectory_
        self.target: trajectory3.Trajectory3 | None = None
        self.frame = 0
        self.sent = np.zeros(len(self.muscles))
        self.statics: statics_full.Statics | None = None
        self.pose: full_arm.Pose | None = None

    def draw_target(self, rng: np.random.Generator | None = None) -> trajectory3.Trajectory3:
        """The next episode's target: the fixed one, or drawn from `rng` (default the task's own)."""
        if self.fixed is not None:
            return self.fixed
        rng = self.rng if rng is None else rng
        if self.workspace == "scapular_plane":
            return scapular(trajectory.random_trajectory(rng, self.split).angle_deg, name=self.split)
        return trajectory3.random_trajectory(rng, self.split)

    # --- dm_control Task API -------------------------------------------------------------------------------------
    def action_spec(self, physics):
        n = len(self.muscles)
        if self.discrete:
            return specs.BoundedArray((n,), np.int64, 0, protocol.LEVELS - 1, name="levels")
        return specs.BoundedArray((n,), np.float64, -protocol.ACTION_LIMIT, protocol.ACTION_LIMIT,
                                  name="activation_change")

    def initialize_episode(self, physics):
        if self.pose is None:  # on a copy of the nominal model: randomize writes each episode's arm into physics'
            self.pose = full_arm.Pose(copy.copy(physics.model.ptr))
            self.statics = statics_full.Statics(physics.law, self.pose)
        self.target = self.draw_target()
        self.frame = 0
        self.sent = np.zeros(len(self.muscles))
        physics.crashed = physics._failed = False
        physics.data.qpos[:] = self.pose.qpos(self.target.angle_deg[0])[0]
        physics.data.qvel[:] = 0.0
        physics.data.ctrl[:] = 0.0
        if self.init == "hold":  # the nominal arm's, randomised or not (as the 1-DOF tasks')
            physics.set_activations(self.muscles, self.statics.holding(self.target.angle_deg[0])[0])
        self._start_episode(physics)

    def before_step(self, action, physics):
        applied, sent = protocol.to_delta(action, len(self.muscles), self.discrete)
        self.sent = sent[0]
        self._apply_change(physics, applied[0])

    def _ctrl_activations(self, physics) -> np.ndarray:
        return physics.activations(self.muscles)

    def after_step(self, physics):
        self.frame += 1
        physics.check_failure()
        self._sense_step(physics)

    def sense(self, physics) -> np.ndarray:
        """(1, 6 + n): the true angles (deg), velocities (deg/s) and activations now."""
        return sensing.state(physics.coordinates_deg()[None], physics.velocities_deg()[None],
                             self.activations_now(physics))

    def get_observation(self, physics):
        k = min(self.frame + 1, len(self.target.angle_deg) - 1)
        sensed = self.history[0] if self.history is not None else self.sense(physics)  # delay_frames late
        angle, velocity = sensing.noisy(sensed[:, :3], sensed[:, 3:6], self.obs_noise_deg, self.noise_z)
        return {"angle": angle[0].copy(), "angular_velocity": velocity[0].copy(),
                "target_angle": self.target.angle_deg[k].copy(),
                "target_velocity": self.target.velocity_deg_s[k].copy(), "activations": sensed[0, 6:].copy()}

    def error_deg(self, physics) -> float:
        """The angle between the achieved and the target humerus orientation now (deg)."""
        target = self.pose.qpos(self.target.angle_deg[min(self.frame, self.target.frames)])
        now = physics.data.qpos.copy()[None]
        return float(full_arm.angular_distance_deg(self.pose.orientation(now), self.pose.orientation(target))[0])

    def get_reward(self, physics):
        if physics.failed():
            return -protocol.CRASH_ERROR_DEG * (self.target.frames - self.frame + 1)
        r = protocol.reward(self.error_deg(physics), 0.0, self.sent[None, :], self.alpha, self.omega_max, False)
        return float(r[0])

    def get_termination(self, physics):
        if physics.failed():
            return 0.0
        if self.frame >= self.target.frames:
            return 1.0
        return None


def law_for(muscle_model: str = "fem", line_of_action: str = "mjcf", factors: dict | None = None,
            geometry: str | None = None, tendon: str = "rigid") -> TendonLaw:
    """The full shoulder's law: its muscles along `line_of_action`, each muscle's tabled force (active and passive)
    with its `tendon` ("rigid" or "compliant": `tendon_compliance`) times its factor of a condition
    (`conditions.factors`; none: intact; the tendon's curve is normalised by F0, so scaling after the compliance is
    the same as scaling before it); a condition's `geometry` (`conditions.geometry`: ld_transfer) reads its rerouted
    tendons' tables (`full_arm.GEOMETRIES`)."""
    law = TendonLaw.load(muscle_model, groups=full_arm.ACTUATORS, line_of_action=line_of_action, geometry=geometry,
                         tendon=tendon)
    return law.scaled(factors) if factors else law


def pose_for(geometry: str | None = None) -> full_arm.Pose:
    """The full shoulder posed on the model of a condition's `geometry` (None: intact): what the law's moment arms
    and the statics are read on."""
    return full_arm.Pose(full_arm.compile_full(geometry))


def condition_law(condition: str | None = None, muscles=full_arm.MUSCLES, tear_fraction: float | None = None,
                  weakness_fraction: float | None = None, muscle_model: str = "fem",
                  line_of_action: str = "mjcf", tendon: str = "rigid") -> tuple[TendonLaw, full_arm.Pose]:
    """(law, posed model) of the full shoulder under a shoulder `condition` of a task with `muscles`: its factors
    (`conditions.factors`) scale the law, its geometry (`conditions.geometry`: ld_transfer) gives both the rerouted
    tables and the rerouted model; what the reference controller, the board's co-contraction and the statics of
    `surgery` and `benchmarks/workspace_3dof.py` plan with."""
    geometry = conditions.geometry(condition)
    factors = conditions.factors(condition, muscles, tear_fraction, weakness_fraction)
    return law_for(muscle_model, line_of_action, factors, geometry, tendon), pose_for(geometry)


def make_physics(muscle_model: str = "fem", line_of_action: str = "mjcf", factors: dict | None = None,
                 geometry: str | None = None, tendon: str = "rigid") -> Physics3:
    law = law_for(muscle_model, line_of_action, factors, geometry, tendon)
    model = full_arm.compile_full(geometry)
    attach_law(model, law)
    install_callbacks()
    physics = Physics3.from_model(wrapper.MjModel(model))
    physics.law = law
    return physics


def make_env(muscles, discrete=False, split="train", seed=None, trajectory=None, muscle_model="fem",
             **options) -> control.Environment:
    """A dm_control Environment of a 3-DOF task; options are checked before the model is built."""
    if muscle_model != "fem":
        raise ValueError(f"muscle_model {muscle_model!r}: the full shoulder has FEM tables only ('fem')")
    task = Track3D(muscles, discrete=discrete, split=split, trajectory_=trajectory3.as_trajectory(trajectory),
                   random=seed, **options)
    return control.Environment(make_physics(muscle_model, task.line_of_action, task.factors, task.geometry,
                                            task.tendon), task,
                               time_limit=float("inf"),
                               control_timestep=protocol.FRAME_S)
