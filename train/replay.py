"""The replay buffer of the DQN and BDQ agents (`train/dqn.py`): transitions of all copies of the batched env, in
torch tensors on the CPU, saved whole in a checkpoint for an exact resume; and the n-step window that turns each
copy's last n steps into one stored transition."""
from __future__ import annotations

import torch

FIELDS = ("obs", "next_obs", "act", "rew", "term", "steps")


class ReplayBuffer:
    """Circular buffer of (obs, levels, scaled return, bootstrap obs, terminated, steps to the bootstrap obs)."""

    def __init__(self, capacity: int, obs_dim: int, n: int):
        self.capacity, self.pos, self.size = int(capacity), 0, 0
        self.obs = torch.zeros(self.capacity, obs_dim)
        self.next_obs = torch.zeros(self.capacity, obs_dim)
        self.act = torch.zeros(self.capacity, n, dtype=torch.uint8)
        self.rew = torch.zeros(self.capacity)
        self.term = torch.zeros(self.capacity, dtype=torch.bool)
        self.steps = torch.ones(self.capacity, dtype=torch.uint8)

    def __len__(self) -> int:
        return self.size

    def add(self, obs, act, rew, next_obs, term, steps) -> None:
        idx = (self.pos + torch.arange(len(obs))) % self.capacity
        self.obs[idx], self.act[idx], self.rew[idx] = obs, act, rew
        self.next_obs[idx], self.term[idx], self.steps[idx] = next_obs, term, steps
        self.pos = int((self.pos + len(obs)) % self.capacity)
        self.size = min(self.size + len(obs), self.capacity)

    def sample(self, batch: int, gen: torch.Generator):
        i = torch.randint(self.size, (batch,), generator=gen)
        return self.obs[i], self.act[i].long(), self.rew[i], self.next_obs[i], self.term[i], self.steps[i]

    def state_dict(self) -> dict:
        s = self.size
        return {"pos": self.pos, "size": s, **{key: getattr(self, key)[:s].clone() for key in FIELDS}}

    def load_state_dict(self, d: dict) -> None:
        s = d["size"]
        for key in FIELDS:
            if key != "steps" or key in d:  # checkpoints from before n-step returns hold no "steps": all 1
                getattr(self, key)[:s] = d[key]
        self.pos, self.size = d["pos"], s


class NStepWindow:
    """The last n vec steps of all copies; once n are held, the oldest step's n-step transition of every copy.

    Copy i's transition from step t: R = sum_k gamma^k r_{t+k} over k < n, stopping after a crash (terminal: R alone)
    and before a time-out (the auto-reset lost the observation after it, so the transition bootstraps from the last
    observation it has, with gamma^k; a time-out at t itself stores nothing, as with n = 1). An episode's end closes
    the window, so a return never crosses into the next episode. n = 1 gives the one-step transitions unchanged.
    """

    def __init__(self, n: int, gamma: float):
        self.n, self.gamma, self.steps = int(n), float(gamma), []

    def push(self, obs, act, rew, next_obs, done, time_out):
        """Add one vec step (rewards already scaled); returns the (obs, act, R, boot_obs, term, steps) to store, or
        None while fewer than n steps are held."""
        self.steps.append((obs, act, rew, next_obs, done, time_out))
        if len(self.steps) < self.n:
            return None
        obs0, act0, rew0, boot, done0, out0 = self.steps[0]
        keep, ret, boot = ~out0, rew0.clone(), boot.clone()
        term, k_boot = done0 & ~out0, torch.ones(len(obs0), dtype=torch.uint8)
        open_ = ~done0
        for k, (_, _, r, nxt, done, out) in enumerate(self.steps[1:], start=1):
            use = open_ & ~out  # a time-out closes the window before its step
            ret[use] += self.gamma ** k * r[use]
            boot[use], k_boot[use], term[use] = nxt[use], k + 1, done[use]
            open_ = use & ~done
        self.steps.pop(0)
        return obs0[keep], act0[keep], ret[keep], boot[keep], term[keep], k_boot[keep]

    def state_dict(self) -> list:
        return [tuple(t.clone() for t in step) for step in self.steps]

    def load_state_dict(self, steps: list) -> None:
        self.steps = [tuple(step) for step in steps]
