"""What the batched envs share (`Lockstep`: the 1-DOF `vec_env.VecEnv`, the 3-DOF `vec_env3.VecEnv3`): rsl-rl's
`VecEnv` interface over an `advance` in arrays, the sensing options (delay, noise), the physiology options
(activation dynamics, fatigue) and the randomised arm, per copy as the single env seeded seed + i, with their
saved state."""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import torch

from shoulder_bench import physiology, randomization
from shoulder_bench.tasks import sensing

if TYPE_CHECKING:
    from tensordict import TensorDict


class Lockstep:
    """What the batched envs (1-DOF `VecEnv`, 3-DOF `vec_env3.VecEnv3`) share: observations as a TensorDict from
    `observation_array()`, `step` as `advance` (the frame in arrays) plus that TensorDict, reset of every copy
    through `_reset(idx)`, the returns of finished episodes.

    The interface is rsl-rl's `VecEnv` (num_envs, num_actions, max_episode_length, episode_length_buf, device, cfg,
    get_observations, step, reset), which rsl-rl uses by duck typing only; its abstract class is not the base here
    because importing it imports tensordict, and tensordict torch._dynamo (1.4 s of the `eval` command's start-up,
    measured with python -X importtime): evaluation steps the copies with `advance` and reads `observation_array`,
    and only training, which needs the TensorDict, imports it (on the first `step` or `get_observations`)."""

    DONE_DTYPE = torch.long  # of the dones `step` returns

    def observation_tensor(self) -> torch.Tensor:
        """(N, obs) float32 on the env's device: what the policy sees (the TensorDict's "policy" entry)."""
        return torch.as_tensor(self.observation_array(), dtype=torch.float32, device=self.device)

    def _observation(self) -> TensorDict:
        from tensordict import TensorDict

        flat = self.observation_tensor()
        return TensorDict({"policy": flat, "critic": flat.clone()}, batch_size=[self.num_envs], device=self.device)

    def get_observations(self) -> TensorDict:
        return self._observation()

    def reset(self) -> TensorDict:
        self._reset(np.arange(self.num_envs))
        return self._observation()

    def step(self, actions) -> tuple[TensorDict, torch.Tensor, torch.Tensor, dict]:
        """rsl-rl's step: `advance`, then the observations as a TensorDict, rewards (float32) and dones."""
        reward, done, extras = self.advance(actions)
        return (self._observation(), torch.as_tensor(reward, dtype=torch.float32, device=self.device),
                torch.as_tensor(done, dtype=self.DONE_DTYPE, device=self.device), extras)

    def finished_returns(self) -> list[float]:
        """Returns of the episodes that ended since the last call."""
        out, self._finished = self._finished, []
        return out

    # --- what the agent senses (shoulder_bench.tasks.sensing): the delay buffer and the noise, per copy -------------
    SENSED_DOFS = 1  # coordinates whose angle and velocity are sensed (VecEnv3: 3)
    _SENSING = ("obs_history", "noise_z")  # states saved before these options existed lack them: defaults only

    def _setup_sensing(self, seed) -> None:
        """The task's delay_frames and obs_noise_deg, copy i's noise drawn as the single env seeded seed + i's."""
        d = self.SENSED_DOFS
        self.delay_frames, self.obs_noise_deg = self.task.delay_frames, self.task.obs_noise_deg
        self.noise_rngs = [sensing.noise_rng(None if seed is None else seed + i) for i in range(self.num_envs)]
        self.obs_history = np.zeros((self.num_envs, self.delay_frames + 1, 2 * d + self.n))  # oldest first; k > 0
        self.noise_z = np.zeros((self.num_envs, 2 * d))  # standard normals of each copy's observation now

    def _sense_reset(self, idx) -> None:
        """Copies `idx` start an episode: their delay buffer holds the state now, their noise is drawn anew."""
        if self.delay_frames:
            self.obs_history[idx] = self._sense()[idx][:, None, :]
        self._draw_noise(idx)

    def _sense_frame(self) -> None:
        """After a frame of every copy: the state now joins the delay buffer, every copy draws its noise."""
        if self.delay_frames:
            self.obs_history = np.concatenate([self.obs_history[:, 1:], self._sense()[:, None, :]], axis=1)
        self._draw_noise(range(self.num_envs))

    def _draw_noise(self, idx) -> None:
        """Each copy in `idx` draws the noise of its observation now from its own generator, as the single env."""
        if self.obs_noise_deg > 0:
            for i in idx:
                self.noise_z[i] = sensing.draw(self.noise_rngs[i], self.SENSED_DOFS)[0]

    def _sensed(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(angles, velocities, activations) as the agent sees them: delay_frames late, noisy; angles (N,) for one
        sensed coordinate, else (N, d)."""
        d = self.SENSED_DOFS
        s = self.obs_history[:, 0] if self.delay_frames else self._sense()
        angle, velocity = (s[:, 0], s[:, 1]) if d == 1 else (s[:, :d], s[:, d:2 * d])
        angle, velocity = sensing.noisy(angle, velocity, self.obs_noise_deg,
                                        self.noise_z if self.obs_noise_deg > 0 else None)
        return angle, velocity, s[:, 2 * d:]

    def _sensing_state(self) -> dict:
        return {"delay_frames": self.delay_frames, "obs_noise_deg": self.obs_noise_deg,
                "noise_rngs": [r.bit_generator.state for r in self.noise_rngs],
                **{key: getattr(self, key).copy() for key in self._SENSING}}

    def _load_sensing(self, state: dict) -> None:
        """The sensing part of a saved state (`_sensing_state`); ValueError if saved with other sensing options."""
        saved = (state.get("delay_frames", 0), state.get("obs_noise_deg", 0.0))
        if saved != (self.delay_frames, self.obs_noise_deg):
            raise ValueError(f"env state saved with delay_frames={saved[0]}, obs_noise_deg={saved[1]:g} cannot be "
                             f"restored into an env with delay_frames={self.delay_frames}, "
                             f"obs_noise_deg={self.obs_noise_deg:g}")
        for rng, saved_rng in zip(self.noise_rngs, state.get("noise_rngs", [])):
            rng.bit_generator.state = saved_rng
        for key in (k for k in self._SENSING if k in state):
            setattr(self, key, np.array(state[key], copy=True))

    # --- the physiology options (shoulder_bench.physiology: activation dynamics, fatigue; shoulder_bench.randomization:
    # the randomised arm, one model per copy, each episode's draw written into it), per copy as the single env's ------
    _PHYSIOLOGY = ("excitation", "fatigue_state")  # states saved before these options existed lack them
    _DRAWS = ("draw_strength", "draw_mass", "draw_load")  # likewise

    def _setup_physiology(self, seed, groups) -> None:
        """Copy i's physiology state and draws as the single env seeded seed + i keeps them; `groups`: each muscle's
        actuator ids (for the strength draws)."""
        t = self.task
        self.physiology = t.physiology  # the per-step activation path: activation dynamics or fatigue
        self.excitation = np.zeros((self.num_envs, self.n))  # activation_dynamics: the command; else unused
        self.fatigue_state = np.zeros((self.num_envs, self.n, 3))  # fatigue: (M_A, M_R, M_F) per muscle
        self.rand_rngs = [randomization.rng(None if seed is None else seed + i) for i in range(self.num_envs)]
        self.draw_strength = np.ones((self.num_envs, self.n))  # randomize: each copy's episode draw
        self.draw_mass = np.ones(self.num_envs)
        self.draw_load = np.zeros(self.num_envs)
        if t.randomize is not None:
            self._nominal = randomization.Nominal(self.sim.model, groups)
            self.sim.own_models()

    def draws(self, i: int) -> dict | None:
        """Copy i's randomised arm of this episode (randomize; None otherwise), as the single env's `arm_draw`."""
        if self.task.randomize is None:
            return None
        return {"strength": self.draw_strength[i].copy(), "mass_scale": float(self.draw_mass[i]),
                "load_kg": float(self.draw_load[i])}

    def _apply_draws(self, idx) -> None:
        models = self.sim.own_models()
        for i in idx:
            randomization.apply(models[i], self._nominal, self.draws(i))

    def _physiology_reset(self, idx) -> None:
        """Copies `idx` start an episode (their activations set): each draws its arm from its own generator into its
        model; the excitation starts at the activation, the fatigue fresh."""
        if self.task.randomize is not None:
            for i in idx:
                d = randomization.draw(self.rand_rngs[i], self.task.randomize, self.n)
                self.draw_strength[i], self.draw_mass[i], self.draw_load[i] = d["strength"], d["mass_scale"], \
                    d["load_kg"]
            self._apply_draws(idx)
        if self.physiology:
            self.excitation[idx] = self.act[idx]
            self.fatigue_state[idx] = physiology.fresh_fatigue(self.act[idx])

    def _frame_activations(self, applied: np.ndarray) -> np.ndarray:
        """The activations of the next frame from the actions' changes `applied` (N, n): (N, n) held over the frame,
        or with the physiology options (N, steps, n), one row per physics step (`physiology.frame_plan`); the
        activation (and excitation, fatigue) state moves to the frame's end."""
        if not self.physiology:
            self.act = np.clip(self.act + applied, 0.0, 1.0)
            return self.act
        t = self.task
        acting, self.excitation, self.act, self.fatigue_state = physiology.frame(
            self.excitation, self.act, self.fatigue_state, applied, self.sim.steps_per_frame, self.sim.h,
            t.activation_dynamics, t.fatigue)
        return acting

    def _physiology_key(self) -> str:
        t = self.task
        return repr((t.activation_dynamics, t.fatigue, t.randomize))

    def _physiology_state(self) -> dict:
        return {"physiology": self._physiology_key(), "rand_rngs": [r.bit_generator.state for r in self.rand_rngs],
                **{key: getattr(self, key).copy() for key in self._PHYSIOLOGY + self._DRAWS}}

    def _check_physiology(self, state: dict) -> None:
        """ValueError, before anything changes, if `state` was saved with other physiology options."""
        saved = state.get("physiology", repr((False, None, None)))
        if saved != self._physiology_key():
            raise ValueError(f"env state saved with physiology (activation_dynamics, fatigue, randomize) = {saved} "
                             f"cannot be restored into an env with {self._physiology_key()}")

    def _load_physiology(self, state: dict) -> None:
        """The physiology part of a saved state (`_physiology_state`; checked by `_check_physiology`), the randomised
        arms written into the copies' models."""
        for rng, saved_rng in zip(self.rand_rngs, state.get("rand_rngs", [])):
            rng.bit_generator.state = saved_rng
        for key in (k for k in self._PHYSIOLOGY + self._DRAWS if k in state):
            setattr(self, key, np.array(state[key], copy=True))
        if self.task.randomize is not None:
            self._apply_draws(range(self.num_envs))
