"""Training: PPO (rsl-rl), Double DQN and branching DQN."""
