"""Double DQN (single muscle) and a branching dueling DQN, BDQ (four muscles), on the batched `VecEnv`.

    from shoulder_bench import make_vec
    from shoulder_bench.train.dqn import DQNAgent, config_for
    cfg = config_for("abduction_ssp_discrete")          # or abduction_4m_discrete (branching=True); DQNConfig(...)
    env = make_vec("abduction_ssp_discrete", cfg.num_envs, seed=cfg.seed)
    agent = DQNAgent(cfg, obs_dim=env.get_observations()["policy"].shape[1], n_branches=env.n)
    agent.learn(env, cfg.frames, on_log=print)          # call again to continue; agent.state_dict() to checkpoint
    policy = agent.policy()                              # float32 obs (B, 4+n) -> greedy levels (B, n); scriptable

Why hand-written (CleanRL style) rather than a library (docs: /work/shared/reference/platform_notes.md):
stable-baselines3 has no Double-DQN target without subclassing `train()` and wants gymnasium envs, not our batched
rsl-rl `VecEnv`; tianshou 2.0 has BDQN but brings ~400 MB of dependencies; torchrl pins tensordict<0.15, which conflicts
with rsl-rl. Both algorithms fit in one readable file, and stepping all copies in lockstep needs no adapter.

One network serves both variants (`QNet`): a shared trunk and, per muscle, a 21-way head. Without `branching` it is a
plain Q-network (one head, no value stream) and the target below is exactly Double DQN (van Hasselt et al. 2016).
With `branching` it is the action-branching dueling architecture of Tavakoli et al. 2018: Q_d(s, a) = V(s) + A_d(s, a)
- mean_a A_d(s, a), and every branch regresses onto the "mean" target y = r + gamma * mean_d Q_d^target(s', a*_d) with
a*_d = argmax_a Q_d^online(s', a); the Huber loss is averaged over branches. (BDQ's per-branch hidden layers and its
1/(n+1) gradient rescaling of the trunk are left out; each head here is one linear layer.)

Observations are degrees, deg/s and activations. `ObsNormalizer`, inside the network (so the exported policy takes raw
observations), standardises each column with the mean/std of the warm-up data (random actions, the first
`learning_starts` frames), then frozen, and appends the tracking errors (target - angle) / 5 deg and
(target velocity - velocity) / 10 deg/s of each coordinate (one on the 1-DOF tasks; plane, elevation and rotation on
the 3-DOF ones), which the policy needs at a ~1 deg resolution that standardised angles blur.

Episode ends under auto-reset: when a copy's episode ends the VecEnv returns the NEXT episode's first observation, and
the true final observation is lost. A crash (done and not a time-out) is terminal: stored with terminated=True, its
target is r and the wrong next observation is never used. A time-out is a truncation: bootstrapping would need the
lost observation, so that transition is not stored at all (1 transition in 100 on the training split; the agent
still receives the earlier rewards of the episode, and the state has no clock, so nothing else depends on it).
Rewards are multiplied by `reward_scale` before storage (the paper's reward is -|error| in degrees per frame).
With `n_step` > 1 a stored transition holds the return of up to n frames of its copy (`replay.NStepWindow`), not
corrected for the ε-greedy frames inside it (as in Rainbow's n-step DQN, Hessel et al. 2018).

Counting: a frame is one step of one copy, so a vec step of N copies is N frames; `learn(env, frames)` runs whole vec
steps until at least `frames` more have been simulated, and `agent.frames` is the exact count. ε, learning start,
gradient steps, target updates, logging and checkpoint callbacks all follow the global counters, so learn(a) then
learn(b) equals learn(a + b) on the same env, and `state_dict()` (networks, optimiser, replay buffer, counters, RNG
states) makes a resumed run deterministic given the same env seed. The networks are tiny: on a few CPU cores
`torch.set_num_threads(1)` is fastest (left to the caller).
"""
from __future__ import annotations

import copy
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, dataclass

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

from shoulder_bench.protocol import LEVELS  # 21 levels of change of activation per muscle
from shoulder_bench.train.config import at_least, positive, sizes, unit_interval
from shoulder_bench.train.replay import NStepWindow, ReplayBuffer


@dataclass
class DQNConfig:
    frames: int = 300_000  # training budget in frames (one step of one copy); a runner passes it to learn()
    num_envs: int = 32  # batched copies the runner should create
    buffer_size: int = 200_000  # transitions
    batch_size: int = 256
    lr: float = 5e-4  # Adam
    gamma: float = 0.99  # paper
    n_step: int = 1  # returns over n frames of a copy before bootstrapping (replay.NStepWindow); 1 = one-step
    overlap_env: bool = True  # step the env in a thread during the gradient steps (they sample the steps before it);
    # 1.2 x the frames/s of BDQ-4 on 2 cores (docs/training.md "Round 5"); runs before 2026-12-06 had it off
    target_update_every: int = 250  # gradient steps between target updates
    target_tau: float = 1.0  # target <- tau * online + (1 - tau) * target at each update; 1.0 = hard copy
    eps_start: float = 1.0
    eps_end: float = 0.02
    eps_decay_frames: int = 100_000  # linear decay from frame 0
    learning_starts: int = 10_000  # frames of uniformly random actions before the first gradient step
    updates_per_step: float = 1.0  # gradient steps per vec step (fractions accumulate)
    hidden: tuple[int, ...] = (256,)  # paper: one hidden layer of 256, ReLU (single muscle)
    branching: bool = False  # dueling heads, one per muscle, with the mean target (BDQ)
    reward_scale: float = 0.1  # rewards are stored multiplied by this
    huber_delta: float = 1.0
    max_grad_norm: float = 10.0
    seed: int = 0
    log_every: int = 5_000  # frames between on_log calls
    checkpoint_every: int = 50_000  # frames between on_checkpoint calls
    save_buffer: bool = True  # include the replay buffer in state_dict() (exact resume; 46 / 73 bytes per transition
    # for 1 / 4 muscles, i.e. 9 / 15 MB when full)


LIMITS = {"frames": at_least(1), "num_envs": at_least(1), "buffer_size": at_least(1), "batch_size": at_least(1),
          "lr": positive(), "gamma": unit_interval(open_low=True), "n_step": at_least(1),
          "target_update_every": at_least(1),
          "target_tau": unit_interval(open_low=True), "eps_start": unit_interval(), "eps_end": unit_interval(),
          "eps_decay_frames": at_least(0), "learning_starts": at_least(0), "updates_per_step": at_least(0),
          "hidden": sizes(), "reward_scale": positive(), "huber_delta": positive(), "max_grad_norm": positive(),
          "seed": at_least(0), "log_every": at_least(1), "checkpoint_every": at_least(1)}


def frames_per_iteration(cfg: DQNConfig) -> int:
    """Frames of one vec step: `learn` runs whole vec steps, so budgets are multiples of this."""
    return cfg.num_envs


# settings used for the numbers in benchmarks/dqn_curve.py (the paper gives only gamma and the single-muscle network)
PRESETS = {
    "abduction_ssp_discrete": {},
    "abduction_4m_discrete": {"branching": True, "hidden": (256, 256), "frames": 500_000},
    "track_3dof_discrete": {"branching": True, "hidden": (256, 256), "frames": 500_000, "lr": 2.5e-4},  # half the lr
}  # track_3dof_discrete: docs/tasks_3dof.md "BDQ's preset searched" (before 2026-12-06 the 4-muscle one, lr 5e-4)


def config_for(task: str, **overrides) -> DQNConfig:
    """The preset for a discrete task, with DQNConfig fields overridden."""
    if task not in PRESETS:
        raise KeyError(f"no DQN preset for {task!r}; DQN needs a discrete task: {', '.join(PRESETS)}")
    kw = {**PRESETS[task], **overrides}
    if "hidden" in kw:
        kw["hidden"] = tuple(kw["hidden"])
    return DQNConfig(**kw)


# --- networks ---------------------------------------------------------------------------------------------------------
class ObsNormalizer(nn.Module):
    """Raw observation (B, 4d+n) -> standardised columns plus the tracking errors (B, 6d+n); d = `dofs`, the task's
    coordinates (1, or 3 on the full shoulder: angles, rates, targets, target rates, activations, each block d wide,
    as `ppo.ErrorFeatures` reads them)."""

    def __init__(self, obs_dim: int, dofs: int = 1):
        super().__init__()
        self.dofs = int(dofs)
        self.register_buffer("mean", torch.zeros(obs_dim))
        self.register_buffer("std", torch.ones(obs_dim))

    @torch.no_grad()
    def fit(self, x: torch.Tensor) -> None:
        self.mean.copy_(x.mean(0))
        self.std.copy_(x.std(0).clamp_min(1e-3))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        # columns: angle, angular velocity, target angle, target velocity, activations (protocol.OBSERVATION_KEYS)
        d = self.dofs
        err = (x[:, 2 * d:3 * d] - x[:, 0:d]) / 5.0
        err_vel = (x[:, 3 * d:4 * d] - x[:, d:2 * d]) / 10.0
        return torch.cat([(x - self.mean) / self.std, err, err_vel], dim=1)


class QNet(nn.Module):
    """Observation -> Q (B, n_branches, LEVELS): ReLU trunk, one linear head per branch, optional dueling value."""

    def __init__(self, obs_dim: int, n_branches: int, hidden: tuple[int, ...], dueling: bool, dofs: int = 1):
        super().__init__()
        self.n, self.levels = n_branches, LEVELS
        self.norm = ObsNormalizer(obs_dim, dofs)
        layers, width = [], obs_dim + 2 * dofs
        for h in hidden:
            layers += [nn.Linear(width, h), nn.ReLU()]
            width = h
        self.trunk = nn.Sequential(*layers)
        self.advantage = nn.Linear(width, n_branches * LEVELS)  # = n separate linear heads
        self.value = nn.Linear(width, 1) if dueling else None

    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        z = self.trunk(self.norm(obs))
        a = self.advantage(z).view(-1, self.n, self.levels)
        if self.value is None:
            return a
        return self.value(z).unsqueeze(-1) + a - a.mean(dim=-1, keepdim=True)


class GreedyPolicy(nn.Module):
    """float32 observations (B, 4+n) -> greedy levels int64 (B, n)."""

    def __init__(self, q: QNet):
        super().__init__()
        self.q = q

    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        return self.q(obs).argmax(dim=-1)


def branching_target(q_online_next, q_target_next, reward, terminated, gamma: float, steps=None) -> torch.Tensor:
    """(B,) target of every branch: r + gamma * (1 - terminated) * mean_d Q_d^target(s', argmax_a Q_d^online(s', a)).

    With one branch this is the Double DQN target. Q arrays are (B, n, LEVELS). steps (B,): frames from s to s' of
    n-step transitions (r is then their discounted return), discounting by gamma ** steps; None: one frame.
    """
    best = q_online_next.argmax(dim=-1, keepdim=True)  # the online net selects ...
    q_next = q_target_next.gather(-1, best).squeeze(-1)  # ... the target net evaluates: (B, n)
    discount = gamma if steps is None else gamma ** steps.float()
    return reward + discount * (1.0 - terminated.float()) * q_next.mean(dim=-1)


# --- agent ------------------------------------------------------------------------------------------------------------
class DQNAgent:
    def __init__(self, cfg: DQNConfig, obs_dim: int, n_branches: int, dofs: int = 1):
        self.cfg, self.obs_dim, self.n, self.dofs = cfg, int(obs_dim), int(n_branches), int(dofs)
        with torch.random.fork_rng():  # seeded initialisation without touching the caller's global RNG
            torch.manual_seed(cfg.seed)
            self.q = QNet(self.obs_dim, self.n, tuple(cfg.hidden), dueling=cfg.branching, dofs=self.dofs)
        self.q_target = copy.deepcopy(self.q).requires_grad_(False)
        self.optim = torch.optim.Adam(self.q.parameters(), lr=cfg.lr, fused=True)
        self.buffer = ReplayBuffer(cfg.buffer_size, self.obs_dim, self.n)
        self.window = NStepWindow(cfg.n_step, cfg.gamma)  # n-step returns per copy, then into the buffer
        self.rng = np.random.default_rng(cfg.seed)  # exploration
        self.gen = torch.Generator().manual_seed(cfg.seed)  # replay sampling
        self.frames = self.vec_steps = self.grad_steps = 0
        self.update_credit = 0.0
        self.normalizer_fitted = False
        self._reset_stats()

    def _reset_stats(self) -> None:
        self.stats = {"episodes": 0, "return_sum": 0.0, "mae_sum": 0.0, "crash_sum": 0.0, "loss_sum": 0.0,
                      "q_sum": 0.0, "updates": 0}

    def epsilon(self) -> float:
        c = self.cfg
        return max(c.eps_end, c.eps_start - (c.eps_start - c.eps_end) * self.frames / max(1, c.eps_decay_frames))

    # --- acting ------------------------------------------------------------------------------------------------------
    @torch.no_grad()
    def act(self, obs, explore: bool) -> np.ndarray:
        """Levels (B, n) int64 for observations (B, 4+n); explore: ε-greedy, each muscle's level drawn independently."""
        obs = torch.as_tensor(obs, dtype=torch.float32).reshape(-1, self.obs_dim)
        levels = self.q(obs).argmax(dim=-1).numpy()
        if explore:
            eps = 1.0 if self.frames < self.cfg.learning_starts else self.epsilon()
            random = self.rng.integers(0, LEVELS, size=levels.shape)
            levels = np.where(self.rng.random(levels.shape) < eps, random, levels)
        return levels.astype(np.int64)

    def policy(self) -> GreedyPolicy:
        """A detached copy of the greedy policy (eval mode, CPU), for evaluation and torch.jit.script/trace export."""
        return GreedyPolicy(copy.deepcopy(self.q)).eval()

    # --- learning ----------------------------------------------------------------------------------------------------
    def _update(self) -> None:
        c = self.cfg
        obs, act, rew, next_obs, term, steps = self.buffer.sample(c.batch_size, self.gen)
        with torch.no_grad():  # (B,); one-step transitions keep the plain gamma (the runs before n_step, unchanged)
            y = branching_target(self.q(next_obs), self.q_target(next_obs), rew, term, c.gamma,
                                 steps if c.n_step > 1 else None)
        q = self.q(obs).gather(-1, act.unsqueeze(-1)).squeeze(-1)  # (B, n): Q of the levels taken
        loss = F.huber_loss(q, y.unsqueeze(-1).expand_as(q), delta=c.huber_delta)  # mean over batch and branches
        self.optim.zero_grad(set_to_none=True)
        loss.backward()
        nn.utils.clip_grad_norm_(self.q.parameters(), c.max_grad_norm)
        self.optim.step()
        self.grad_steps += 1
        if self.grad_steps % c.target_update_every == 0:
            with torch.no_grad():
                for p_t, p in zip(self.q_target.parameters(), self.q.parameters()):
                    p_t.lerp_(p, c.target_tau)
        self.stats["loss_sum"] += loss.item()
        self.stats["q_sum"] += q.mean().item()
        self.stats["updates"] += 1

    def learn(self, env, frames: int, on_log=None, on_checkpoint=None) -> None:
        """Run ε-greedy collection and updates for at least `frames` more frames of `env` (N copies: N per vec step).

        on_log(dict) every `log_every` frames: frames, fps, mean_return / mae_deg / crash_rate (episodes finished since
        the last log; NaN if none), loss, q_mean, epsilon, episodes. on_checkpoint(frames) every `checkpoint_every`.
        """
        c, n_env = self.cfg, env.num_envs
        end = self.frames + int(frames)
        obs = env.get_observations()["policy"].float().cpu()
        self._log_mark = (time.perf_counter(), self.frames)  # the last log's time and frames
        with ThreadPoolExecutor(1, thread_name_prefix="dqn-env") as pool:  # its thread starts at the first submit
            while self.frames < end:
                levels = self.act(obs, explore=True)
                prev, self.frames = self.frames, self.frames + n_env
                self.vec_steps += 1
                if not c.overlap_env:
                    obs = self._store(obs, levels, env.step(torch.as_tensor(levels)))
                    self._train()
                else:  # the copies step in a thread while the gradient steps sample what was stored before
                    stepping = pool.submit(env.step, torch.as_tensor(levels))
                    self._train()
                    obs = self._store(obs, levels, stepping.result())
                if on_log is not None and self.frames // c.log_every > prev // c.log_every:
                    on_log(self._log())
                if on_checkpoint is not None and self.frames // c.checkpoint_every > prev // c.checkpoint_every:
                    on_checkpoint(self.frames)

    def _store(self, obs, levels, stepped):
        """Put one vec step into the n-step window (and what it completes into the buffer); the next observations."""
        td, rew, done, extras = stepped
        next_obs = td["policy"].float().cpu()  # time-outs: the window stores nothing past them (the module's doc)
        done, time_out = done.cpu().bool(), extras["time_outs"].cpu().bool()
        levels_u8 = torch.as_tensor(levels, dtype=torch.uint8)
        ready = self.window.push(obs, levels_u8, rew.cpu().float() * self.cfg.reward_scale, next_obs, done, time_out)
        if ready is not None:
            self.buffer.add(*ready)
        if "log" in extras:  # means over the copies that finished at this step
            k, log = int(done.sum()), extras["log"]
            self.stats["episodes"] += k
            self.stats["return_sum"] += k * log["/episode/return"]
            self.stats["mae_sum"] += k * log.get("/episode/mae_deg", float("nan"))
            self.stats["crash_sum"] += k * log.get("/episode/crash_rate", float("nan"))
        return next_obs

    def _train(self) -> None:
        """The gradient steps owed after a vec step (none before `learning_starts` frames and a full batch)."""
        c = self.cfg
        if self.frames >= c.learning_starts and len(self.buffer) >= c.batch_size:
            if not self.normalizer_fitted:  # fit on the warm-up data, then frozen
                data = self.buffer.obs[:len(self.buffer)]
                self.q.norm.fit(data)
                self.q_target.load_state_dict(self.q.state_dict())
                self.normalizer_fitted = True
            self.update_credit += c.updates_per_step
            while self.update_credit >= 1.0:
                self._update()
                self.update_credit -= 1.0

    def _log(self) -> dict:
        """What on_log gets (means since the last log), and a new log period."""
        now, (t_log, f_log) = time.perf_counter(), self._log_mark
        s, ep, up = self.stats, max(self.stats["episodes"], 1), max(self.stats["updates"], 1)
        nan = float("nan")
        info = {"frames": self.frames, "fps": (self.frames - f_log) / max(now - t_log, 1e-9),
                "mean_return": s["return_sum"] / ep if s["episodes"] else nan,
                "mae_deg": s["mae_sum"] / ep if s["episodes"] else nan,
                "crash_rate": s["crash_sum"] / ep if s["episodes"] else nan,
                "loss": s["loss_sum"] / up if s["updates"] else nan,
                "q_mean": s["q_sum"] / up if s["updates"] else nan,
                "epsilon": self.epsilon(), "episodes": s["episodes"], "grad_steps": self.grad_steps}
        self._reset_stats()
        self._log_mark = (now, self.frames)
        return info

    # --- checkpoints -------------------------------------------------------------------------------------------------
    def state_dict(self) -> dict:
        return {"config": asdict(self.cfg), "obs_dim": self.obs_dim, "n_branches": self.n, "dofs": self.dofs,
                "q": self.q.state_dict(), "q_target": self.q_target.state_dict(), "optim": self.optim.state_dict(),
                "buffer": self.buffer.state_dict() if self.cfg.save_buffer else None,
                "window": self.window.state_dict(),
                "counters": {"frames": self.frames, "vec_steps": self.vec_steps, "grad_steps": self.grad_steps,
                             "update_credit": self.update_credit, "normalizer_fitted": self.normalizer_fitted},
                "rng": {"numpy": self.rng.bit_generator.state, "torch": self.gen.get_state()},
                "stats": dict(self.stats)}

    def load_state_dict(self, d: dict) -> None:
        """Restore into an agent built with the same obs_dim / n_branches / network config."""
        self.q.load_state_dict(d["q"])
        self.q_target.load_state_dict(d["q_target"])
        self.optim.load_state_dict(d["optim"])
        if d["buffer"] is not None:
            self.buffer.load_state_dict(d["buffer"])
        else:  # no stored buffer: refill it before updating again (updates wait for a full batch)
            self.buffer = ReplayBuffer(self.cfg.buffer_size, self.obs_dim, self.n)
        self.window.load_state_dict(d.get("window", []))  # checkpoints from before n_step: one-step, none held
        k = d["counters"]
        self.frames, self.vec_steps, self.grad_steps = k["frames"], k["vec_steps"], k["grad_steps"]
        self.update_credit, self.normalizer_fitted = k["update_credit"], k["normalizer_fitted"]
        self.rng.bit_generator.state = d["rng"]["numpy"]
        self.gen.set_state(d["rng"]["torch"])
        self.stats = dict(d["stats"])

    @classmethod
    def from_state_dict(cls, d: dict) -> DQNAgent:
        cfg = d["config"]
        agent = cls(DQNConfig(**{**cfg, "hidden": tuple(cfg["hidden"])}), d["obs_dim"], d["n_branches"],
                    d.get("dofs", 1))
        agent.load_state_dict(d)
        return agent


# --- the runner's entry (shoulder-bench train --algo dqn|bdq) ---------------------------------------------------------
def train(run, venv, cfg: DQNConfig, frames: int, evaluate_every, on_eval,
          init: dict | None = None) -> torch.nn.Module:
    """Train until `run.frames` reaches `frames`, logging, checkpointing and evaluating through `run`; returns the
    scripted greedy policy of the final agent (no checkpoint selection on the test set). init: the state a fresh
    fine-tune starts from (`plan.init_source`): the networks (online, target; and the optimiser from a checkpoint)
    with their fitted normaliser; the replay buffer, counters and exploration schedule start anew."""
    n = venv.num_actions
    agent = DQNAgent(cfg, obs_dim=venv.get_observations()["policy"].shape[1], n_branches=n,
                     dofs=getattr(venv.task, "dofs", 1))
    if run.checkpoint is not None:
        try:
            agent.load_state_dict(run.checkpoint["state"]["agent"])
        except (KeyError, RuntimeError, TypeError) as exc:
            raise ValueError(f"{run.dir / 'checkpoint.pt'} holds no DQN state this config can load ({exc}); delete "
                             f"it to start over") from exc
    elif init is not None:
        try:
            if "checkpoint" in init:
                saved = init["checkpoint"]["agent"]
                agent.q.load_state_dict(saved["q"])
                agent.q_target.load_state_dict(saved["q_target"])
                agent.optim.load_state_dict(saved["optim"])
            else:
                agent.q.load_state_dict({k[2:]: v for k, v in init["policy"].items() if k.startswith("q.")})
                agent.q_target.load_state_dict(agent.q.state_dict())
        except (KeyError, RuntimeError, TypeError, ValueError) as exc:
            raise ValueError(f"the initial policy holds no Q-network this config can load ({exc}); a fine-tune keeps "
                             f"the network of the policy it starts from (hidden, branching)") from exc
        agent.normalizer_fitted = True  # the initial network's normaliser, not refitted on the new warm-up data
    next_eval = [evaluate_every(run.frames)]

    def on_log(info: dict) -> None:
        if info["episodes"]:
            run.returns.append(info["mean_return"])
        scalars = {"perf/fps": info["fps"], "train/mean_return": info["mean_return"], "train/mae_deg": info["mae_deg"],
                   "loss/q": info["loss"], "train/q_mean": info["q_mean"], "train/epsilon": info["epsilon"]}
        run.advance(info["frames"] - run.frames, {k: v for k, v in scalars.items() if np.isfinite(v)})
        if run.frames >= next_eval[0]:
            on_eval(torch.jit.script(agent.policy()))
            next_eval[0] = evaluate_every(run.frames)

    def on_checkpoint(_frames: int) -> None:
        run.advance(agent.frames - run.frames, {})
        run.save_checkpoint({"agent": agent.state_dict()})

    if agent.frames < frames:
        agent.learn(venv, frames - agent.frames, on_log=on_log, on_checkpoint=on_checkpoint)
    run.advance(agent.frames - run.frames, {})
    run.save_checkpoint({"agent": agent.state_dict()})
    return torch.jit.script(agent.policy())
