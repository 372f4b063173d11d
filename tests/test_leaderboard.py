"""The leaderboard from the shipped agents: md, csv and html with rows for ppo, dqn, bdq, reference and the paper."""
import csv

import pytest

from shoulder_bench.cli import main


def test_leaderboard_from_pretrained_agents(tmp_path, capsys):
    assert main(["leaderboard", "--out", str(tmp_path)]) == 0
    md = (tmp_path / "leaderboard.md").read_text()
    for algo in ("| ppo |", "| dqn |", "| bdq |", "reference controller", "paper PPO-4"):
        assert algo in md
    rows = list(csv.DictReader((tmp_path / "leaderboard.csv").open()))
    assert len(rows) == 9 and all(r["test_mae_mean"] for r in rows)
    html = (tmp_path / "leaderboard.html").read_text()
    assert "<table>" in html and "data:image/png;base64," in html and "synthetic" in html


def test_leaderboard_without_runs_in_the_folder(tmp_path):
    with pytest.raises(FileNotFoundError, match="no finished runs"):
        from shoulder_bench.eval.leaderboard import collect

        collect(tmp_path)
