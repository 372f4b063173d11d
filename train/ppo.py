"""PPO on the batched env with rsl-rl-lib: its `PPO` algorithm and `MLPModel` actor/critic, our loop around them.

The loop is rsl-rl's `OnPolicyRunner.learn` (collect `steps_per_env` steps, compute returns, update) written out so
the run can log against frames, checkpoint atomically, evaluate on the test set and resume.
Networks as in the paper: one hidden layer of 256 for one muscle, 3 x 250 for four; ReLU; Adam. The policy acts in
[-1, 1] per muscle and the env receives that times 0.01 (the +-1 % per frame of the protocol).
"""
from __future__ import annotations

import contextlib
import copy
import io
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, dataclass, field

import numpy as np
import torch
from rsl_rl.runners import OnPolicyRunner
from rsl_rl.storage import RolloutStorage
from tensordict import TensorDict

from shoulder_bench import protocol
from shoulder_bench.train.config import at_least, one_of, positive, sizes, unit_interval
from shoulder_bench.train.policy import ScaledPolicy


@dataclass
class PPOConfig:
    # num_envs, num_learning_epochs, num_mini_batches, steps_per_env: the wall-clock search of docs/training.md
    # ("Training defaults", benchmarks/wallclock.py); before its round 1: 256, 5, 4, 24; before round 3: 64, 1, 8, 24
    num_envs: int = 64
    steps_per_env: int = 12
    hidden_dims: list[int] = field(default_factory=list)  # empty: the paper's ([256] or [250, 250, 250])
    critic_hidden_dims: list[int] = field(default_factory=list)  # the value network's; empty: as the policy's
    activation: str = "relu"
    learning_rate: float = 1e-3
    schedule: str = "adaptive"  # rsl-rl: adapt the learning rate to keep the KL near desired_kl
    desired_kl: float = 0.01
    anneal_kl: bool = False  # the adaptive schedule's KL target falls linearly to 0 over the run's frame budget
    # (so its learning rate with it, to rsl-rl's floor of 1e-5): updates shrink as the budget ends
    num_learning_epochs: int = 1
    num_mini_batches: int = 8
    clip_param: float = 0.2
    gamma: float = 0.99  # the paper's
    lam: float = 0.95
    entropy_coef: float = 0.001
    value_loss_coef: float = 1.0
    max_grad_norm: float = 1.0
    init_std: float = 0.5  # in units of the 1 %/frame limit
    reward_scale: float = 1.0  # rewards are multiplied by this for learning (rsl-rl does not normalise values)
    error_features: bool = False  # append (target - angle) / 5 deg and (target vel - vel) / 10 deg/s to the input
    update_threads: int = 1  # torch threads in alg.update() only (collection and inference keep 1: the env's
    # rollout threads own the cores then)
    fused_adam: bool = True  # torch's fused Adam step in place of rsl-rl's foreach Adam (fuse_optimizer)
    overlap_env: bool = False  # collect the next rollout in a thread during the update, with the policy from before
    # it (`Collector`: each update learns from the policy one update behind); docs/training.md "Round 6": 1.27 x the
    # frames/s but 1.7 x the frames to 1 deg, so off
    checkpoint_every: int = 10  # iterations


# Per-task settings on top of the defaults. track_3dof: the tracking errors as inputs (docs/tasks_3dof.md "Results":
# test MAE 1.26 deg at 0.9 M frames with them, 2.62 deg at best without, seed 0; one seed, not a search), and the KL
# target annealed (three seeds at 1 M frames: 1.68, 1.46, 1.47 deg with it, 1.69, 1.47, 4.22 without; seed 2 had
# collapsed late). The 3-DOF tasks keep 24 steps per iteration and rsl-rl's Adam: their results were measured so, and
# the searches that chose 12 steps and the fused Adam (rounds 3 and 5) ran on abduction_4m
# abduction_4m: a value network of 2 x 128 under the paper's 3 x 250 policy (the wall-clock search's round 8,
# docs/training.md: the update 0.75 x the time, test MAE <= 1 deg in the same frames, 13.0 against 16.5 s, 5 seeds)
PRESETS = {"track_3dof": {"error_features": True, "steps_per_env": 24, "fused_adam": False, "anneal_kl": True},
           "elevate_scapular_plane_12m": {"steps_per_env": 24, "fused_adam": False},
           "abduction_4m": {"critic_hidden_dims": [128, 128]}}


def config_for(task: str) -> PPOConfig:
    """The defaults with the task's preset (PRESETS) applied."""
    return PPOConfig(**PRESETS.get(task, {}))


LIMITS = {"num_envs": at_least(1), "steps_per_env": at_least(1), "hidden_dims": sizes(), "critic_hidden_dims": sizes(),
          "activation": one_of("elu", "selu", "relu", "crelu", "lrelu", "tanh", "sigmoid", "softplus", "gelu",
                               "swish", "mish", "identity"),
          "learning_rate": positive(), "schedule": one_of("adaptive", "fixed"), "desired_kl": positive(),
          "num_learning_epochs": at_least(1), "num_mini_batches": at_least(1), "clip_param": positive(),
          "gamma": unit_interval(open_low=True), "lam": unit_interval(), "entropy_coef": at_least(0),
          "value_loss_coef": at_least(0), "max_grad_norm": positive(), "init_std": positive(),
          "reward_scale": positive(), "update_threads": at_least(1), "checkpoint_every": at_least(1)}


def frames_per_iteration(cfg: PPOConfig) -> int:
    """Frames one collect-and-update iteration simulates: budgets are whole iterations."""
    return cfg.num_envs * cfg.steps_per_env


class ErrorFeatures(torch.nn.Module):
    """Appends the tracking errors to the observation: the policy needs them at ~1 deg resolution, which standardised
    absolute angles (0-100 deg) blur. Part of the exported policy, so it still takes the task's observation.
    `dofs`: the task's coordinates (1, or 3 on the full shoulder: observation = angles, rates, targets, target rates,
    activations, each block `dofs` wide)."""

    def __init__(self, dofs: int = 1):
        super().__init__()
        self.dofs = int(dofs)

    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        d = self.dofs
        err = (obs[:, 2 * d:3 * d] - obs[:, 0:d]) / 5.0
        derr = (obs[:, 3 * d:4 * d] - obs[:, d:2 * d]) / 10.0
        return torch.cat([obs, err, derr], dim=1)


class ScaledActions:
    """The VecEnv seen by rsl-rl: actions in [-1, 1] become changes of activation within +-0.01; rewards scaled by
    `reward_scale`; observations optionally extended by `ErrorFeatures`."""

    def __init__(self, venv, reward_scale: float = 1.0, error_features: bool = False):
        self.venv = venv
        self.reward_scale = reward_scale
        self.dofs = getattr(venv.task, "dofs", 1)  # the 3-DOF tasks' Track3D has 3
        self.features = ErrorFeatures(self.dofs) if error_features else None
        for key in ("num_envs", "num_actions", "max_episode_length", "device", "cfg"):
            setattr(self, key, getattr(venv, key))

    @property
    def episode_length_buf(self):
        return self.venv.episode_length_buf

    @episode_length_buf.setter
    def episode_length_buf(self, value):
        self.venv.episode_length_buf = value

    def _features(self, obs):
        if self.features is not None:
            for key in ("policy", "critic"):
                obs[key] = self.features(obs[key])
        return obs

    def get_observations(self):
        return self._features(self.venv.get_observations())

    def step(self, actions):
        obs, rewards, dones, extras = self.venv.step(torch.clamp(actions, -1.0, 1.0) * protocol.ACTION_LIMIT)
        return self._features(obs), rewards * self.reward_scale, dones, extras


def rsl_config(cfg: PPOConfig, n_muscles: int) -> dict:
    hidden = cfg.hidden_dims or ([256] if n_muscles == 1 else [250, 250, 250])
    model = {"class_name": "MLPModel", "hidden_dims": hidden, "activation": cfg.activation, "obs_normalization": True}
    return {
        "num_steps_per_env": cfg.steps_per_env, "save_interval": 10**9, "obs_groups": {"actor": ["policy"],
                                                                                       "critic": ["critic"]},
        "actor": {**model, "distribution_cfg": {"class_name": "GaussianDistribution", "init_std": cfg.init_std,
                                                "std_type": "scalar"}},
        "critic": dict(model, hidden_dims=cfg.critic_hidden_dims or hidden),
        "algorithm": {"class_name": "PPO", "learning_rate": cfg.learning_rate, "schedule": cfg.schedule,
                      "desired_kl": cfg.desired_kl, "num_learning_epochs": cfg.num_learning_epochs,
                      "num_mini_batches": cfg.num_mini_batches, "clip_param": cfg.clip_param, "gamma": cfg.gamma,
                      "lam": cfg.lam, "entropy_coef": cfg.entropy_coef, "value_loss_coef": cfg.value_loss_coef,
                      "max_grad_norm": cfg.max_grad_norm},
        "logger": "tensorboard", "check_for_nan": True,
    }


def train(run, venv, cfg: PPOConfig, frames: int, evaluate_every, on_eval,
          init: dict | None = None) -> torch.nn.Module:
    """Train until `run.frames` reaches `frames`; returns the exported (scripted) policy. init: the state a fresh
    fine-tune starts from (`plan.init_source`)."""
    env = ScaledActions(venv, cfg.reward_scale, cfg.error_features)
    with contextlib.redirect_stdout(io.StringIO()):  # rsl-rl prints the networks; the config already records them
        runner = OnPolicyRunner(env, rsl_config(cfg, venv.num_actions), log_dir=None, device=str(venv.device))
    alg = runner.alg
    if cfg.fused_adam:
        fuse_optimizer(alg)
    collector = Collector(alg, cfg.steps_per_env) if cfg.overlap_env else None  # draws its seed before a resume
    if run.checkpoint is not None:  # restores torch's RNG, so after that draw
        try:
            alg.load(run.checkpoint["state"]["alg"], None, True)
            torch.set_rng_state(run.checkpoint["state"]["torch_rng"])
            if collector is not None:
                collector.load_state_dict(run.checkpoint["state"]["collector"])
        except (KeyError, RuntimeError, TypeError) as exc:
            raise ValueError(f"{run.dir / 'checkpoint.pt'} holds no PPO state this config can load ({exc}); delete "
                             f"it to start over") from exc
    elif init is not None:
        load_init(alg, init)
    obs = env.get_observations()
    alg.train_mode()
    per_iteration = frames_per_iteration(cfg)
    iteration, next_eval = run.frames // per_iteration, evaluate_every(run.frames)
    with ThreadPoolExecutor(1, thread_name_prefix="ppo-env") as pool:  # its thread starts at the first submit
        while run.frames < frames:
            t0 = time.perf_counter()
            if cfg.anneal_kl:  # the target of this iteration's update (rsl-rl reads alg.desired_kl there)
                alg.desired_kl = cfg.desired_kl * max(1.0 - run.frames / frames, 0.0)
            if collector is None:
                obs = collect(alg, env, obs, cfg.steps_per_env, run.returns)
                losses = update(alg, cfg.update_threads)
            else:
                if not collector.pending:  # the first rollout
                    obs = collector.collect(env, obs, run.returns)
                collecting = collector.start(pool, env, obs, run.returns)
                losses = update(alg, cfg.update_threads)
                obs = collector.finish(collecting)
            iteration += 1
            dt = time.perf_counter() - t0
            scalars = {f"loss/{k}": v for k, v in losses.items()}
            std = float(alg.get_policy().output_std.detach().mean())
            scalars.update({"perf/fps": per_iteration / dt, "policy/std": std,
                            "policy/learning_rate": alg.learning_rate,
                            "train/mean_return": np.mean(run.returns) if run.returns else None})
            run.advance(per_iteration, scalars)
            if run.frames >= next_eval or run.frames >= frames:
                on_eval(export(alg, cfg.error_features, env.dofs))
                next_eval = evaluate_every(run.frames)
            if iteration % cfg.checkpoint_every == 0 or run.frames >= frames:
                state = {"alg": alg.save(), "torch_rng": torch.get_rng_state()}
                if collector is not None:
                    state["collector"] = collector.state_dict()
                run.save_checkpoint(state)
    return export(alg, cfg.error_features, env.dofs)


def collect(agent, env, obs, steps: int, returns) -> TensorDict:
    """One rollout of `steps` steps per env into `agent.storage`, with its returns and advantages; the last
    observations. `agent`: rsl-rl's PPO (the learner, or `Collector.behaviour`)."""
    with torch.inference_mode():
        for _ in range(steps):
            obs, rewards, dones, extras = env.step(agent.act(obs))
            agent.process_env_step(obs, rewards, dones, extras)
            returns.extend(env.venv.finished_returns())
        agent.compute_returns(obs)
    return obs


def update(alg, threads: int) -> dict:
    """`alg.update()` with `threads` torch threads (the rollout threads of the env own the cores otherwise)."""
    before = torch.get_num_threads()
    torch.set_num_threads(threads)
    try:
        return alg.update()
    finally:
        torch.set_num_threads(before)


ROLLOUT = ("actions", "rewards", "dones", "values", "actions_log_prob", "returns", "advantages")


class Collector:
    """`PPOConfig.overlap_env`: the env steps while the update runs. A copy of the policy (`behaviour`: rsl-rl's PPO
    with its own actor, critic, rollout storage and action noise) collects the next rollout in a thread during
    `alg.update()` on the last one; the copy is the policy from before that update, so each update learns from a
    rollout of the policy one update behind (asynchronous PPO with a policy lag of one update). PPO's ratio is taken
    to the log-probabilities stored with the rollout, so the clip bounds the step from the policy that acted, and the
    values and advantages are the acting critic's. Why a thread is enough: MuJoCo's rollout threads and torch's
    kernels both release the GIL. The copy's action noise has its own generator (the update's shuffling draws from
    torch's global one in the other thread), so a run is deterministic; the checkpoint carries the collected rollout
    not yet learned from and the generator, so a resumed run equals the uninterrupted one."""

    def __init__(self, alg, steps: int):
        self.alg, self.steps = alg, steps
        b = self.behaviour = copy.copy(alg)  # its hyperparameters (gamma, lam, ...) are the learner's
        b.actor, b.critic = copy.deepcopy(alg.actor), copy.deepcopy(alg.critic)
        b.storage, b.transition = copy.deepcopy(alg.storage), RolloutStorage.Transition()
        self.generator = torch.Generator().manual_seed(int(torch.randint(2**62, (1,))))
        dist = b.actor.distribution  # rsl-rl's Gaussian samples with torch's global generator: draw from ours
        dist.sample = lambda: torch.normal(dist.mean, dist.std, generator=self.generator)
        self.pending = False  # the learner's storage holds a collected rollout not yet learned from

    def collect(self, env, obs, returns) -> TensorDict:
        """A rollout with the learner's current policy into the learner's storage (nothing beside it)."""
        self._sync()
        obs = collect(self.behaviour, env, obs, self.steps, returns)
        self._swap()
        return obs

    def start(self, pool, env, obs, returns):
        """Start collecting the next rollout in `pool`'s thread with the policy as it is now (a future)."""
        self._sync()
        return pool.submit(collect, self.behaviour, env, obs, self.steps, returns)

    def finish(self, future) -> TensorDict:
        """After `alg.update()`: wait for the rollout `start` began and hand it to the learner; the last
        observations."""
        obs = future.result()
        self._swap()
        return obs

    def _sync(self) -> None:
        self.behaviour.actor.load_state_dict(self.alg.actor.state_dict())
        self.behaviour.critic.load_state_dict(self.alg.critic.state_dict())

    def _swap(self) -> None:
        self.alg.storage, self.behaviour.storage = self.behaviour.storage, self.alg.storage
        self.pending = True

    def state_dict(self) -> dict:
        st = self.alg.storage
        rollout = None if not self.pending else {
            "observations": {k: v.clone() for k, v in st.observations.items()},
            "distribution_params": [p.clone() for p in st.distribution_params], "step": st.step,
            **{k: getattr(st, k).clone() for k in ROLLOUT}}
        return {"generator": self.generator.get_state(), "rollout": rollout}

    def load_state_dict(self, state: dict) -> None:
        self.generator.set_state(state["generator"])
        rollout, st = state["rollout"], self.alg.storage
        if rollout is not None:
            for key, value in rollout["observations"].items():
                st.observations[key].copy_(value)
            for key in ROLLOUT:
                setattr(st, key, rollout[key].clone())
            st.distribution_params = tuple(p.clone() for p in rollout["distribution_params"])
            st.step = rollout["step"]
            self.pending = True


def fuse_optimizer(alg) -> None:
    """Swap rsl-rl's Adam (torch's multi-tensor `foreach` step) for torch's fused Adam over the same parameters, at
    the same learning rate: the same update up to rounding, one update of the default config in 0.78 x the time
    (`benchmarks/ppo_update.py`, docs/training.md "Round 5"). The state dict has the same layout, so checkpoints load
    either way."""
    groups = alg.optimizer.param_groups
    params = [p for group in groups for p in group["params"]]
    alg.optimizer = torch.optim.Adam(params, lr=groups[0]["lr"], fused=True)


def load_init(alg, init: dict) -> None:
    """A fine-tune's starting state (`plan.init_source`): the whole PPO state of a checkpoint, or an exported policy's
    actor and observation normaliser (the critic's normaliser starts from the same statistics; the action std is the
    config's init_std)."""
    try:
        if "checkpoint" in init:
            alg.load(init["checkpoint"]["alg"], None, True)
            return
        actor = {}
        for key, value in init["policy"].items():  # ScaledPolicy: actor.<net>, or actor.1.<net> after ErrorFeatures
            if key.startswith("actor."):
                key = key[len("actor."):]
                actor[key[2:] if key.startswith("1.") else key] = value
        missing, unexpected = alg.get_policy().load_state_dict(actor, strict=False)
        if unexpected or any("distribution" not in k for k in missing):
            raise RuntimeError(f"missing {missing}, unexpected {unexpected}")
        norm = {k[len("obs_normalizer."):]: v for k, v in actor.items() if k.startswith("obs_normalizer.")}
        if norm:
            alg._raw_critic.obs_normalizer.load_state_dict(norm)
    except (KeyError, RuntimeError, TypeError) as exc:
        raise ValueError(f"the initial policy holds no PPO actor this config can load ({exc}); a fine-tune keeps the "
                         f"network of the policy it starts from (hidden_dims, error_features)") from exc


def export(alg, error_features: bool = False, dofs: int = 1) -> torch.nn.Module:
    actor = alg.get_policy().as_jit()
    if error_features:
        actor = torch.nn.Sequential(ErrorFeatures(dofs), actor)
    return torch.jit.script(ScaledPolicy(torch.jit.script(actor), protocol.ACTION_LIMIT))


def config_dict(cfg: PPOConfig) -> dict:
    return asdict(cfg)
