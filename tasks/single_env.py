"""What the single envs share (`SingleEnv`: the 1-DOF `abduction.Abduction`, the 3-DOF `track3d.Track3D`), as
`lockstep.Lockstep` is what the batched envs share: the sensing, condition and physiology options checked, the seeds
of their generators, each episode's randomised arm and physiology state, the delay buffer and the noise of the
observation. A task sets `DOFS` (its sensed coordinates) and `ACTUATORS` (each muscle's actuators), and defines
`sense(physics)` and `_ctrl_activations(physics)` (its muscles' activations in force)."""
from __future__ import annotations

import collections

import numpy as np

from shoulder_bench import conditions, physiology, protocol, randomization
from shoulder_bench.tasks import options as opt
from shoulder_bench.tasks import sensing


class SingleEnv:
    DOFS = 1  # sensed coordinates (Track3D: 3)
    ACTUATORS: dict = {}  # muscle -> its actuators' names

    def _setup_options(self, delay_frames, obs_noise_deg, condition, tear_fraction, weakness_fraction,
                       activation_dynamics, fatigue, randomize, random) -> None:
        """Check and keep the options every task takes (`self.muscles` set), and seed the generators."""
        # what the agent senses (shoulder_bench.tasks.sensing): k frames late, with Gaussian noise
        self.delay_frames = opt.integer("delay_frames", delay_frames, 0, sensing.MAX_DELAY_FRAMES)
        self.obs_noise_deg = opt.number("obs_noise_deg", obs_noise_deg, 0.0)
        # the shoulder's condition (shoulder_bench.conditions): its force factors, applied to the law by the physics
        self.factors = conditions.factors(condition, self.muscles, tear_fraction, weakness_fraction)
        self.condition = {k: v for k, v in (("condition", condition), ("tear_fraction", tear_fraction),
                                            ("weakness_fraction", weakness_fraction)) if v is not None}
        # muscle physiology (shoulder_bench.physiology, shoulder_bench.randomization)
        self.activation_dynamics = bool(opt.flag("activation_dynamics", activation_dynamics))
        self.fatigue = physiology.fatigue_option(fatigue)
        self.randomize = randomization.option(randomize)
        self.physiology = self.activation_dynamics or self.fatigue is not None  # the per-step activation path
        self.excitation = self.activation = self.fatigue_state = None  # (n,), (n,), (n, 3) with `physiology`
        self.arm_draw: dict | None = None  # this episode's randomised arm (randomize)
        self._nominal: randomization.Nominal | None = None
        self.history: collections.deque | None = None  # the last delay_frames + 1 sensed states, oldest first
        self.noise_z: np.ndarray | None = None  # (1, 2 DOFS) standard normals of the observation now (None: no noise)
        self.reseed(random)

    def reseed(self, seed) -> None:
        """The targets', the noise's and the randomised arm's generators, from one seed."""
        seed = opt.seed(seed)
        self.rng = np.random.default_rng(seed)
        self.noise_rng = sensing.noise_rng(seed)
        self.randomize_rng = randomization.rng(seed)

    def _start_episode(self, physics) -> None:
        """After the start pose and activations: this episode's randomised arm written into the physics' model, the
        physiology state, the delay buffer, the noise of the first observation."""
        if self.randomize is not None:
            if self._nominal is None:
                m = physics.model.ptr
                self._nominal = randomization.Nominal(m, randomization.groups(m, self.ACTUATORS, self.muscles))
            self.arm_draw = randomization.draw(self.randomize_rng, self.randomize, len(self.muscles))
            randomization.apply(physics.model.ptr, self._nominal, self.arm_draw)
        if self.physiology:
            self.activation = self._ctrl_activations(physics).copy()
            self.excitation = self.activation.copy()
            self.fatigue_state = None if self.fatigue is None else physiology.fresh_fatigue(self.activation)
        if self.delay_frames:
            self.history = collections.deque([self.sense(physics)] * (self.delay_frames + 1),
                                             maxlen=self.delay_frames + 1)
        self.draw_noise()

    def _apply_change(self, physics, delta: np.ndarray) -> None:
        """The action's change of activation (n,): into ctrl, or with the physiology options the activation of each
        physics step of the frame (`physics.plan`, `physiology.frame` with one copy; the task's excitation,
        activation and fatigue state move to the frame's end)."""
        if not self.physiology:
            physics.set_activations(self.muscles, np.clip(self._ctrl_activations(physics) + delta, 0.0, 1.0))
            return
        steps = int(round(protocol.FRAME_S / physics.model.opt.timestep))
        fatigue = None if self.fatigue_state is None else self.fatigue_state[None]
        acting, command, a, state = physiology.frame(self.excitation[None], self.activation[None], fatigue,
                                                     delta[None], steps, float(physics.model.opt.timestep),
                                                     self.activation_dynamics, self.fatigue)
        self.excitation, self.activation = command[0], a[0]
        self.fatigue_state = None if state is None else state[0]
        physics.plan = (self.muscles, acting[0])

    def activations_now(self, physics) -> np.ndarray:
        """(n,) the muscles' activations as observed: the activation state with the physiology options, else the
        activation in force (ctrl)."""
        return self.activation.copy() if self.physiology else self._ctrl_activations(physics).copy()

    def _sense_step(self, physics) -> None:
        """After a step: the state now joins the delay buffer, the next observation's noise is drawn."""
        if self.history is not None:
            self.history.append(self.sense(physics))
        self.draw_noise()

    def draw_noise(self) -> None:
        """The noise of the observation of this frame: drawn once per reset and per step, whoever reads it."""
        self.noise_z = sensing.draw(self.noise_rng, self.DOFS) if self.obs_noise_deg > 0 else None
