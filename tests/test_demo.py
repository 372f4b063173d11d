"""The README's first command on a tiny budget: train -> eval -> leaderboard -> video, everything in --out."""
import imageio
import pytest

from shoulder_bench.cli import main


@pytest.mark.slow
def test_demo_trains_evaluates_ranks_and_renders(tmp_path, capsys):
    out = tmp_path / "demo"
    assert main(["demo", "--frames", "2048", "--seconds", "1", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    for step in ("[1/4] training", "[2/4] evaluated", "[3/4] leaderboard", "[4/4] rendering"):
        assert step in text
    assert (out / "abduction_4m/ppo/0/metrics.json").exists()
    board = (out / "leaderboard/leaderboard.md").read_text()
    assert f"runs: {out}" in board and "shipped agent" in board and "reference controller" in board
    assert (out / "leaderboard/leaderboard.html").exists() and (out / "leaderboard/leaderboard.csv").exists()
    with imageio.get_reader(str(out / "demo.mp4"), format="FFMPEG") as reader:
        frames = [f for f in reader]
    assert abs(len(frames) - 30) <= 1 and frames[0].shape == (360, 480, 3) and frames[0].std() > 10
