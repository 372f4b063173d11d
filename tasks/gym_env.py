"""The tasks as gymnasium environments: `gymnasium.make("ShoulderBench/<name>-v0", **options)`, and batched:
`gymnasium.make_vec("ShoulderBench/<name>-v0", num_envs=N, vectorization_mode="vector_entry_point", **options)`
(`shoulder_bench.tasks.gym_vector`)."""
from __future__ import annotations

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from shoulder_bench import protocol
from shoulder_bench.arm import RANGE_DEG as JOINT_RANGE_DEG
from shoulder_bench.arm import VALID_MARGIN_DEG
from shoulder_bench.tasks import options as opt


def observation_space(n: int) -> spaces.Box:
    """Angle within the joint range plus the crash margin, target angle within the joint range, activations in [0, 1]
    (degrees); the velocities have no bound."""
    lo, hi = JOINT_RANGE_DEG
    low = [lo - VALID_MARGIN_DEG, -np.inf, lo, -np.inf] + [0.0] * n
    high = [hi + VALID_MARGIN_DEG, np.inf, hi, np.inf] + [1.0] * n
    return spaces.Box(np.array(low, np.float32), np.array(high, np.float32), dtype=np.float32)


def observation_space_3dof(n: int) -> spaces.Box:
    """The 3-DOF tasks' (`tasks.track3d`): the three coordinates within their joint ranges plus the crash margin, the
    targets within the tables' pose space, activations in [0, 1]; rates unbounded."""
    from shoulder_bench import full_arm
    from shoulder_bench.tasks.track3d import VALID_MARGIN_DEG as MARGIN

    m = full_arm.compile_full()
    joint = np.degrees(m.jnt_range[[m.joint(c).id for c in full_arm.COORDINATES]])
    pose = np.array([full_arm.POSE_RANGE_DEG[c] for c in full_arm.COORDINATES])
    inf = np.full(3, np.inf)
    low = np.concatenate([joint[:, 0] - MARGIN, -inf, pose[:, 0], -inf, np.zeros(n)])
    high = np.concatenate([joint[:, 1] + MARGIN, inf, pose[:, 1], inf, np.ones(n)])
    return spaces.Box(low.astype(np.float32), high.astype(np.float32), dtype=np.float32)


def action_space(n: int, discrete: bool) -> spaces.Space:
    if discrete:
        return spaces.Discrete(protocol.LEVELS) if n == 1 else spaces.MultiDiscrete([protocol.LEVELS] * n)
    return spaces.Box(-protocol.ACTION_LIMIT, protocol.ACTION_LIMIT, shape=(n,), dtype=np.float32)


def in_space(obs: np.ndarray, space: spaces.Box) -> np.ndarray:
    """float32 observations (rows or one) inside `space`: only the last observation of a crash can lie outside (the
    arm past the margin, or a non-finite state); there NaN reads 0 and values are clipped to the bounds."""
    obs = np.nan_to_num(np.asarray(obs, dtype=np.float32), nan=0.0, posinf=np.inf, neginf=-np.inf)
    return np.clip(obs, space.low, space.high)


class ShoulderEnv(gym.Env):
    """A gymnasium view of a dm_control shoulder task: flat float32 observation in the order
    angle, angular_velocity, target_angle, target_velocity, activations (degrees, deg/s, [0, 1]).

    `step()` before `reset()` or after the episode ended (terminated or truncated) raises gymnasium's `ResetNeeded`.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": int(1 / protocol.FRAME_S)}

    def __init__(self, name: str, render_mode: str | None = None, **options):
        from shoulder_bench.tasks import load

        self.name = name
        self.env = load(name, **options)
        self.task = self.env.task
        n = len(self.task.muscles)
        self.dofs = getattr(self.task, "dofs", 1)
        self.observation_space = observation_space_3dof(n) if self.dofs == 3 else observation_space(n)
        self.action_space = action_space(n, self.task.discrete)
        self.render_mode = render_mode
        self._needs_reset = True

    def _obs(self, ts) -> np.ndarray:
        return in_space(protocol.flatten(ts.observation), self.observation_space)

    def _info(self) -> dict:
        """The true state; with the physiology options also `excitations` (activation_dynamics), `fatigue` ((n, 3)
        M_A, M_R, M_F) and `randomization` (the episode's draw: strength (n,), mass_scale, load_kg)."""
        physics, task = self.env.physics, self.task
        if self.dofs == 3:
            info = {"angle_deg": physics.coordinates_deg(), "target_deg": task.target.angle_deg[
                min(task.frame, task.target.frames)].copy(), "error_deg": task.error_deg(physics),
                "activations": task.activations_now(physics), "crashed": bool(physics.failed())}
        else:
            info = {"angle_deg": physics.angle_deg(), "target_deg": task.target_deg(),
                    "activations": task.activations_now(physics), "crashed": bool(physics.failed())}
        if task.activation_dynamics:
            info["excitations"] = task.excitation.copy()
        if task.fatigue is not None:
            info["fatigue"] = task.fatigue_state.copy()
        if task.randomize is not None:
            info["randomization"] = {k: np.copy(v) if k == "strength" else v for k, v in task.arm_draw.items()}
        return info

    def reset(self, *, seed=None, options=None):
        seed = opt.seed(seed)
        super().reset(seed=seed)
        if seed is not None:
            self.task.reseed(seed)
        ts = self.env.reset()
        self._needs_reset = False
        return self._obs(ts), self._info()

    def step(self, action):
        if self._needs_reset:
            raise gym.error.ResetNeeded(f"{self.name}: the episode has ended (or never started); call reset() "
                                        f"before step()")
        ts = self.env.step(action)
        terminated = ts.last() and ts.discount == 0.0
        truncated = ts.last() and not terminated
        self._needs_reset = ts.last()
        return self._obs(ts), float(ts.reward), terminated, truncated, self._info()

    def render(self):
        if self.render_mode == "rgb_array":
            return self.env.physics.render(height=480, width=640, camera_id="front")
        return None


def register_all() -> None:
    from shoulder_bench.tasks import TASKS, TASKS_3DOF

    for name in (*TASKS, *TASKS_3DOF):
        env_id = f"ShoulderBench/{name}-v0"
        if env_id not in gym.registry:  # the batched vector entry point is the 1-DOF tasks' (gym_vector)
            vector = {"vector_entry_point": "shoulder_bench.tasks.gym_vector:ShoulderVectorEnv"} if name in TASKS \
                else {}
            gym.register(env_id, entry_point="shoulder_bench.tasks.gym_env:ShoulderEnv", kwargs={"name": name},
                         **vector)
