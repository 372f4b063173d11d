"""Evaluation: the fixed test set, metrics, leaderboard, figures and videos."""
