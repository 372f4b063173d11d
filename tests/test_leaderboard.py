"""The leaderboard from the shipped agents: md, csv and html with rows for ppo, dqn, bdq, reference and the paper,
the qualitative measures; the measures themselves on signals with known answers."""
import csv

import numpy as np
import pytest

from shoulder_bench.cli import main
from shoulder_bench.eval.measures import early_late_share, sawtooth_rate


def test_leaderboard_from_pretrained_agents(tmp_path, capsys):
    assert main(["leaderboard", "--out", str(tmp_path)]) == 0
    md = (tmp_path / "leaderboard.md").read_text()
    for algo in ("| ppo |", "| dqn |", "| bdq |", "reference controller", "paper PPO-4"):
        assert algo in md
    assert "Saw-tooth, one muscle (ssp)" in md and "ssp + isp share of the summed activation, PPO-4" in md
    rows = list(csv.DictReader((tmp_path / "leaderboard.csv").open()))
    assert len(rows) == 9 and all(r["test_mae_mean"] for r in rows)
    learned = {r["algo"] + " " + r["task"]: r for r in rows if r["source"] == "shipped agent"}
    assert float(learned["dqn abduction_ssp_discrete"]["sawtooth_per_s_mean"]) > float(
        learned["ppo abduction_ssp"]["sawtooth_per_s_mean"])  # the paper's saw-tooth finding, on the shipped agents
    assert 0 < float(learned["ppo abduction_4m"]["early_share_mean"]) < 1
    html = (tmp_path / "leaderboard.html").read_text()
    assert "<table>" in html and "data:image/png;base64," in html and "synthetic" in html and "<li>" in html


def test_leaderboard_without_runs_in_the_folder(tmp_path):
    with pytest.raises(FileNotFoundError, match="no finished runs"):
        from shoulder_bench.eval.leaderboard import collect

        collect(tmp_path)


def test_sawtooth_counts_sign_changes_per_second_and_muscle():
    t = np.arange(101)
    zigzag = 0.5 + 0.01 * (t % 2)  # up, down, up ...: 99 sign changes in 10 s
    ramp = 0.005 * t  # monotone: none
    held = np.where(t % 4 < 2, 0.3, 0.3 + 0.01 * (t % 2))  # still frames between changes are skipped
    act = np.stack([zigzag, ramp], axis=-1)[None]
    assert sawtooth_rate(act) == pytest.approx(99 / (2 * 101 * 0.1))
    padded = np.concatenate([act, np.full((1, 20, 2), np.nan)], axis=1)  # NaN after the end: ignored
    assert sawtooth_rate(padded) == pytest.approx(sawtooth_rate(act))
    assert sawtooth_rate(held[None, :, None]) > 0


def test_early_late_share_splits_at_45_degrees():
    angle = np.array([[30.0, 40.0, 60.0, 80.0]])
    act = np.zeros((1, 4, 4))
    act[0, :2] = [0.3, 0.1, 0.0, 0.0]  # early: only ssp and isp
    act[0, 2:] = [0.1, 0.1, 0.2, 0.0]  # late: half
    early, late = early_late_share(angle, act, ("ssp", "isp", "dmi", "ld"))
    assert (early, late) == (pytest.approx(1.0), pytest.approx(0.5))
    with pytest.raises(ValueError, match="not in this task"):
        early_late_share(angle, act[..., :1], ("ssp",))
