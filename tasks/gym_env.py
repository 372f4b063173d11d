"""The tasks as gymnasium environments: `gymnasium.make("ShoulderBench/<name>-v0", **options)`."""
from __future__ import annotations

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from shoulder_bench import protocol


class ShoulderEnv(gym.Env):
    """A gymnasium view of a dm_control shoulder task: flat float32 observation in the order
    angle, angular_velocity, target_angle, target_velocity, activations (degrees, deg/s, [0, 1])."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": int(1 / protocol.FRAME_S)}

    def __init__(self, name: str, render_mode: str | None = None, **options):
        from shoulder_bench.tasks import load

        self.name = name
        self.env = load(name, **options)
        self.task = self.env.task
        n = len(self.task.muscles)
        self.observation_space = spaces.Box(-np.inf, np.inf, shape=(4 + n,), dtype=np.float32)
        if self.task.discrete:
            self.action_space = spaces.Discrete(protocol.LEVELS) if n == 1 else spaces.MultiDiscrete(
                [protocol.LEVELS] * n)
        else:
            self.action_space = spaces.Box(-protocol.ACTION_LIMIT, protocol.ACTION_LIMIT, shape=(n,), dtype=np.float32)
        self.render_mode = render_mode

    def _obs(self, ts) -> np.ndarray:
        return protocol.flatten(ts.observation)

    def _info(self) -> dict:
        physics = self.env.physics
        return {"angle_deg": physics.angle_deg(), "target_deg": self.task.target_deg(),
                "activations": physics.activations(self.task.muscles).copy(),
                "crashed": bool(physics.failed())}

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        if seed is not None:
            self.task.reseed(seed)
        ts = self.env.reset()
        return self._obs(ts), self._info()

    def step(self, action):
        ts = self.env.step(action)
        terminated = ts.last() and ts.discount == 0.0
        truncated = ts.last() and not terminated
        return self._obs(ts), float(ts.reward), terminated, truncated, self._info()

    def render(self):
        if self.render_mode == "rgb_array":
            return self.env.physics.render(height=480, width=640, camera_id="front")
        return None


def register_all() -> None:
    from shoulder_bench.tasks import TASKS

    for name in TASKS:
        env_id = f"ShoulderBench/{name}-v0"
        if env_id not in gym.registry:
            gym.register(env_id, entry_point="shoulder_bench.tasks.gym_env:ShoulderEnv", kwargs={"name": name})
