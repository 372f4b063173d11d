"""The replay buffer of the DQN and BDQ agents (`train/dqn.py`): transitions of all copies of the batched env, in
torch tensors on the CPU, saved whole in a checkpoint for an exact resume."""
from __future__ import annotations

import torch


class ReplayBuffer:
    """Circular buffer of (obs, levels, scaled reward, next obs, terminated) on the CPU."""

    def __init__(self, capacity: int, obs_dim: int, n: int):
        self.capacity, self.pos, self.size = int(capacity), 0, 0
        self.obs = torch.zeros(self.capacity, obs_dim)
        self.next_obs = torch.zeros(self.capacity, obs_dim)
        self.act = torch.zeros(self.capacity, n, dtype=torch.uint8)
        self.rew = torch.zeros(self.capacity)
        self.term = torch.zeros(self.capacity, dtype=torch.bool)

    def __len__(self) -> int:
        return self.size

    def add(self, obs, act, rew, next_obs, term) -> None:
        idx = (self.pos + torch.arange(len(obs))) % self.capacity
        self.obs[idx], self.act[idx], self.rew[idx] = obs, act, rew
        self.next_obs[idx], self.term[idx] = next_obs, term
        self.pos = int((self.pos + len(obs)) % self.capacity)
        self.size = min(self.size + len(obs), self.capacity)

    def sample(self, batch: int, gen: torch.Generator):
        i = torch.randint(self.size, (batch,), generator=gen)
        return self.obs[i], self.act[i].long(), self.rew[i], self.next_obs[i], self.term[i]

    def state_dict(self) -> dict:
        s = self.size
        return {"pos": self.pos, "size": s, "obs": self.obs[:s].clone(), "next_obs": self.next_obs[:s].clone(),
                "act": self.act[:s].clone(), "rew": self.rew[:s].clone(), "term": self.term[:s].clone()}

    def load_state_dict(self, d: dict) -> None:
        s = d["size"]
        for key in ("obs", "next_obs", "act", "rew", "term"):
            getattr(self, key)[:s] = d[key]
        self.pos, self.size = d["pos"], s
