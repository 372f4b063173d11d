"""The batched simulator as a gymnasium `VectorEnv`, the `vector_entry_point` of every ShoulderBench id:

    envs = gymnasium.make_vec("ShoulderBench/abduction_4m-v0", num_envs=1024, vectorization_mode="vector_entry_point")

numpy in and out: observations (N, 4 + n) float32 (as the single env's), rewards float64, terminations (crashes) and
truncations (end of the target) bool. Options as for `gymnasium.make`, plus `seed` (see `reset`).

Autoreset: gymnasium's `AutoresetMode.SAME_STEP`, as the rsl-rl VecEnv underneath does it. The step that ends copy i's
episode returns that episode's last reward, termination and truncation and already the first observation of the next
episode; the episode's last observation and info are in `infos["final_obs"][i]` and `infos["final_info"]` (masks
`infos["_final_obs"]`, `infos["_final_info"]`), as `SyncVectorEnv(..., autoreset_mode=AutoresetMode.SAME_STEP)` gives
them. Step infos: `angle_deg`, `target_deg`, `activations`, `crashed` per copy (as the single env's `info`); with
the physiology options also `excitations`, `fatigue` and the randomised arm `strength`, `mass_scale`, `load_kg`.
"""
from __future__ import annotations

import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from shoulder_bench.tasks import TASKS, check_name
from shoulder_bench.tasks import options as opt
from shoulder_bench.tasks.gym_env import action_space, in_space, observation_space
from shoulder_bench.tasks.vec_env import VecEnv


class ShoulderVectorEnv(VectorEnv):
    """N copies of a task in lockstep; copy i draws its targets with seed + i, as gymnasium's SyncVectorEnv seeds its
    copies, so its first episode equals `gymnasium.make(id)`'s after `reset(seed=seed + i)` with the same actions."""

    metadata = {"autoreset_mode": AutoresetMode.SAME_STEP, "render_modes": []}

    def __init__(self, name: str, num_envs: int = 1, seed=None, render_mode: str | None = None, **options):
        if render_mode is not None:
            raise ValueError(f"render_mode must be None for the vector env (got {render_mode!r}); render a single "
                             f"env: gymnasium.make(id, render_mode='rgb_array')")
        muscles, discrete, _ = TASKS[check_name(name)]
        self.name, self.options, self.render_mode = name, options, None
        self.batched = VecEnv(name, num_envs, seed=opt.seed(seed), **options)
        self._fresh = True  # its first targets are drawn and not yet used: the first reset keeps them
        self.num_envs = self.batched.num_envs
        self.single_observation_space = observation_space(len(muscles))
        self.single_action_space = action_space(len(muscles), discrete)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)

    def reset(self, *, seed=None, options=None):
        """All copies start new episodes; `seed` (an int) restarts copy i's target draws with seed + i."""
        if seed is not None:
            seed = opt.seed(seed)
            self.batched.close()
            self.batched = VecEnv(self.name, self.num_envs, seed=seed, **self.options)
            self._fresh = True
        super().reset(seed=seed)
        if not self._fresh:
            self.batched.reset()
        self._fresh = False
        return self._in_space(self.batched.observation_array()), self._infos()

    def step(self, actions):
        b, self._fresh = self.batched, False
        _, _, _, extras = b.step(np.asarray(actions))
        terminated = np.asarray(b.last_crashed, dtype=bool).copy()
        truncated = extras["time_outs"].cpu().numpy().astype(bool)
        done = terminated | truncated
        raw = b.observation_array()
        infos = self._infos()
        if done.any():
            final = self._in_space(b.last_final_obs[done])
            infos["final_obs"] = np.full(self.num_envs, None, dtype=object)
            infos["final_obs"][np.flatnonzero(done)] = list(final)
            infos["_final_obs"] = done.copy()
            last = {"angle_deg": b.last_angle_deg, "target_deg": b.last_target_deg, "activations": b.last_activation,
                    "crashed": terminated}
            last.update(_physiology(b, b.last_excitation, b.last_fatigue, *b.last_draws))
            infos["final_info"] = _masked(last, done)
            infos["_final_info"] = done.copy()
        return self._in_space(raw), np.asarray(b.last_reward, dtype=np.float64).copy(), terminated, truncated, infos

    def _in_space(self, raw: np.ndarray) -> np.ndarray:
        return in_space(raw, self.single_observation_space)

    def _infos(self) -> dict:
        """The single env's info per copy, from the true state (not the delayed or noisy observation); `crashed` is
        False throughout, as a copy whose episode ended already stands at the start of the next (the crash is in
        `final_info`)."""
        b = self.batched
        target = b.targets[np.arange(self.num_envs), np.minimum(b.frames, b.episode_frames)]
        values = {"angle_deg": np.degrees(b.q), "target_deg": target, "activations": b.act.copy(),
                  "crashed": np.zeros(self.num_envs, dtype=bool)}
        values.update(_physiology(b, b.excitation, b.fatigue_state, b.draw_strength, b.draw_mass, b.draw_load))
        return _masked(values, np.ones(self.num_envs, dtype=bool))

    def close_extras(self, **kwargs) -> None:
        self.batched.close()


def _physiology(b, excitation, fatigue, strength, mass, load) -> dict:
    """The physiology options' infos per copy, as the single env's: excitations, fatigue (N, n, 3) and the
    randomised arm (strength (N, n), mass_scale, load_kg), each only with its option."""
    out = {}
    if b.task.activation_dynamics:
        out["excitations"] = excitation
    if b.task.fatigue is not None:
        out["fatigue"] = fatigue
    if b.task.randomize is not None:
        out.update(strength=strength, mass_scale=mass, load_kg=load)
    return out


def _masked(values: dict, mask: np.ndarray) -> dict:
    """gymnasium's vector info layout: each key with its `_key` mask of the copies it holds for."""
    out = {}
    for key, v in values.items():
        out[key] = np.array(v, copy=True)
        out[f"_{key}"] = mask.copy()
    return out
