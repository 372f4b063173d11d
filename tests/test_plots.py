"""Paper-style figures: trajectory with activations, error box plots, activation patterns, as PNG and SVG."""
import pytest
from PIL import Image

from shoulder_bench.cli import main


def _written(path):
    return path.exists() and path.stat().st_size > 5_000 and path.with_suffix(".svg").exists()


def test_trajectory_errors_and_activation_figures(tmp_path, capsys):
    traj, errors, acts = tmp_path / "traj.png", tmp_path / "errors.png", tmp_path / "acts.png"
    assert main(["plot", "trajectory", "--policy", "pretrained:dqn_ssp", "--policy", "pretrained:ppo_4m",
                 "--index", "3", "--out", str(traj)]) == 0
    assert main(["plot", "errors", "--policy", "pretrained:ppo_ssp", "--policy", "reference", "--out",
                 str(errors)]) == 0
    assert main(["plot", "activations", "--policy", "pretrained:ppo_4m", "--policy", "pretrained:bdq_4m",
                 "--out", str(acts)]) == 0
    assert all(_written(p) for p in (traj, errors, acts))
    assert str(traj.with_suffix(".svg")) in capsys.readouterr().out
    with Image.open(acts) as img:  # one row of (activation, share) panels per policy: 11 x 4 in each at 120 dpi
        assert img.size == (11 * 120, 2 * 4 * 120)


def test_bad_figure_requests_name_the_problem(tmp_path, capsys):
    assert main(["plot", "trajectory", "--policy", "reference", "--index", "100", "--out",
                 str(tmp_path / "t.png")]) == 2
    assert "has 100 trajectories" in capsys.readouterr().err
    assert main(["plot", "activations", "--policy", "pretrained:ppo_4m", "--out", str(tmp_path / "a.txt")]) == 2
    assert ".png, .svg or .pdf" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["plot", "errors", "--out", str(tmp_path / "e.png")])  # --policy is required
