"""Paper-style figures: trajectory with activations, error box plots, activation patterns, as PNG and SVG."""
import numpy as np
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


def test_wallclock_figure_draws_each_seed_and_the_median(tmp_path):
    from shoulder_bench.eval.plots import save, wallclock_figure

    def run(scale, n):  # one seed's evaluations: MAE falling with time, every 10k frames
        return [{"frames": 10_000 * (i + 1), "training_s": scale * (i + 1), "mae_deg": 20.0 / (i + 1),
                 "rmse_deg": 1.0, "crashes": 0} for i in range(n)]

    fig = wallclock_figure({"a": [run(1.0, 5), run(1.2, 4), run(2.0, 5)], "b": [run(0.8, 5)]}, [(8.0, 1.0, "goal")],
                           "t")
    ax_s, ax_f = fig.axes
    # per config: its seeds' thin lines, then the median over seeds (up to the shortest seed: 4 evaluations)
    assert [len(line.get_xdata()) for line in ax_s.lines[:4]] == [5, 4, 5, 4]
    np.testing.assert_allclose(ax_s.lines[3].get_xdata(), [1.2, 2.4, 3.6, 4.8])  # the seeds' median seconds
    np.testing.assert_allclose(ax_f.lines[3].get_ydata(), [20.0, 10.0, 20.0 / 3, 5.0])
    assert [t.get_text() for t in ax_f.get_legend().get_texts()] == ["a (3 seeds)", "b (1 seeds)"]
    paths = save(fig, tmp_path / "w.png")
    assert [p.name for p in paths] == ["w.png", "w.svg"] and all(_written(p) for p in paths[:1])


def test_curves_name_each_run_by_its_options_and_else_by_its_folder(tmp_path, monkeypatch):
    import json

    from torch.utils.tensorboard import SummaryWriter

    from shoulder_bench.eval import plots

    def run(folder, task="track_3dof", **options):  # a run folder as `train` writes it, with a test/mae_deg history
        folder.mkdir(parents=True)
        cfg = {"task": task, "algo": "ppo", "seed": 0, "frames": 2000, "config": {}}
        (folder / "config.json").write_text(json.dumps(cfg | ({"options": options} if options else {})))
        with SummaryWriter(str(folder / "tb")) as w:
            for step in (1000, 2000):
                w.add_scalar("test/mae_deg", 5.0 / step, step)
        return folder

    runs = [run(tmp_path / "mjcf" / "0"), run(tmp_path / "band" / "0", line_of_action="band"),
            run(tmp_path / "other" / "0")]  # the first and last differ only in their folders (e.g. a config)
    drawn = []
    monkeypatch.setattr(plots, "save", lambda fig, out: drawn.append(fig) or [out])
    assert main(["plot", "curves", *map(str, runs), "--out", str(tmp_path / "c.png")]) == 0
    labels = [t.get_text() for t in drawn[0].axes[1].get_legend().get_texts()]
    assert labels == [f"ppo track_3dof seed 0 ({runs[0]})", "ppo track_3dof seed 0, line_of_action=band",
                      f"ppo track_3dof seed 0 ({runs[2]})"]  # no paper line: its 5.15 deg is a 1-DOF task's
    one_dof = run(tmp_path / "abduction" / "0", task="abduction_4m")
    assert main(["plot", "curves", str(runs[1]), str(one_dof), "--out", str(tmp_path / "d.png")]) == 0
    labels = [t.get_text() for t in drawn[1].axes[1].get_legend().get_texts()]
    assert labels == ["ppo track_3dof seed 0, line_of_action=band", "ppo abduction_4m seed 0",
                      "paper PPO-4 (their model)"]
