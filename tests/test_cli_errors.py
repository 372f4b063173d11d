"""User errors in eval, render, plot, leaderboard, bench and reproduce: return code 2, one line
`shoulder-bench <cmd>: error: <message>` naming the option or file and what is valid, raised before any work (the
rollouts are replaced by a function that fails the test) and leaving nothing written."""
import importlib.metadata
import json

import pytest
import torch

from shoulder_bench.cli import main
from shoulder_bench.train.policy import save_policy


class Still(torch.nn.Module):
    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        return torch.zeros(obs.shape[0], obs.shape[1] - 4)


@pytest.fixture
def no_work(monkeypatch):
    """Any rollout or episode fails the test: the error must come first."""
    def forbidden(*a, **k):
        raise AssertionError("work started before the inputs were checked")

    for target in ("shoulder_bench.eval.evaluate.evaluate", "shoulder_bench.eval.leaderboard.evaluate",
                   "shoulder_bench.eval.render._controller", "shoulder_bench.eval.bench.batched_rate",
                   "shoulder_bench.eval.experiment.train", "shoulder_bench.eval.sweep.sweep"):
        monkeypatch.setattr(target, forbidden)


def _error(capsys, argv) -> str:
    """Run the CLI, check rc 2 and the one-line message; return the message."""
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    prefix = f"shoulder-bench {argv[0]}: error: "
    assert err.startswith(prefix) and "\n" not in err and "Traceback" not in err, err
    assert "np.float64" not in err and "PosixPath" not in err
    return err[len(prefix):]


def _run(root, seed=0, config=True, tb=True, metrics=True):
    """A synthetic run folder: config.json, TensorBoard curves, metrics.json and a still policy."""
    run = root / "abduction_ssp" / "ppo" / str(seed)
    run.mkdir(parents=True)
    if config:
        (run / "config.json").write_text(json.dumps({"task": "abduction_ssp", "algo": "ppo", "seed": seed,
                                                     "frames": 1000, "muscle_model": "fem", "config": {}}))
    if tb:
        from torch.utils.tensorboard import SummaryWriter

        with SummaryWriter(str(run / "tb")) as w:
            for step in (100, 200):
                w.add_scalar("train/mean_return", -step / 100, step)
                w.add_scalar("test/mae_deg", 10 - step / 100, step)
    if metrics:
        (run / "metrics.json").write_text(json.dumps({"mae_deg": 1.0, "wall_s": 2.0}))
    save_policy(Still(), run / "policy.pt", {"task": "abduction_ssp", "algo": "ppo", "seed": seed})
    return run


def test_version_prints_the_package_version(capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["--version"])
    assert exit_.value.code == 0
    assert capsys.readouterr().out.strip() == f"shoulder-bench {importlib.metadata.version('shoulder-bench')}"


@pytest.mark.parametrize("repeats", ["0", "-2"])
def test_bench_rejects_fewer_than_one_repeat(capsys, no_work, repeats):
    assert _error(capsys, ["bench", "--repeats", repeats]) == f"--repeats {repeats}: give a whole number of at least 1"


def test_bench_functions_reject_empty_batches():
    from shoulder_bench.eval.bench import bare_rate

    with pytest.raises(ValueError, match="num_envs 0: give a whole number of at least 1"):
        bare_rate(0, 5)


def test_eval_trajectories_directory(tmp_path, capsys, no_work):
    msg = _error(capsys, ["eval", "--policy", "pretrained:ppo_4m", "--trajectories", str(tmp_path)])
    assert msg == (f"--trajectories {tmp_path} is a directory; give a CSV file with columns "
                   f"time_s,angle_deg[,trajectory]")
    msg = _error(capsys, ["eval", "--policy", "reference", "--trajectories", str(tmp_path / "none.csv")])
    assert msg.startswith(f"--trajectories {tmp_path / 'none.csv'}: no such trajectory file; give test")


def test_eval_policy_that_is_a_checkpoint_or_not_a_policy(tmp_path, capsys, no_work):
    ckpt = tmp_path / "checkpoint.pt"
    torch.save({"frames": 1, "config": {}, "state": {"alg": {"actor_state_dict": {}}}}, ckpt)
    msg = _error(capsys, ["eval", "--policy", str(ckpt)])
    assert msg.startswith(f"policy file {ckpt} is a training checkpoint, not an exported policy")
    assert "give a run folder, its policy.pt, pretrained:NAME or reference" in msg and "actor_state_dict" not in msg
    assert _error(capsys, ["eval", "--policy", str(tmp_path)]) == (
        f"run folder {tmp_path} has no policy.pt yet, only a training checkpoint: the run has not finished "
        f"(shoulder-bench train --resume --out {tmp_path} ... continues it)")
    notes = tmp_path / "notes.txt"
    notes.write_text("not a policy")
    assert _error(capsys, ["plot", "errors", "--policy", str(notes), "--out", str(tmp_path / "e.png")]).startswith(
        f"policy file {notes} is not a policy (not a TorchScript file")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["checkpoint.pt", "notes.txt"]


def test_render_directory_as_trajectory_or_out(tmp_path, capsys, no_work):
    (tmp_path / "d").mkdir()
    assert _error(capsys, ["render", "--trajectory", str(tmp_path / "d"), "--out", str(tmp_path / "x.mp4")]) == (
        f"--trajectory {tmp_path / 'd'} is a directory; give a CSV file with columns time_s,angle_deg[,trajectory]")
    for extra, name in (([], "episode.mp4"), (["--gif"], "episode.gif")):
        msg = _error(capsys, ["render", "--out", str(tmp_path / "d"), *extra])
        assert msg == f"--out {tmp_path / 'd'} is a directory; give a file name such as {tmp_path / 'd' / name}"
    assert [p.name for p in tmp_path.iterdir()] == ["d"] and not any((tmp_path / "d").iterdir())


def test_leaderboard_out_existing_file_fails_before_evaluating(tmp_path, capsys, no_work):
    out = tmp_path / "board"
    out.write_text("keep me")
    assert _error(capsys, ["leaderboard", "--out", str(out)]) == (
        f"--out {out} is an existing file, not a folder; give a folder name")
    assert out.read_text() == "keep me"


def test_leaderboard_bad_runs_fail_before_evaluating(tmp_path, capsys, no_work):
    out = tmp_path / "board"
    assert _error(capsys, ["leaderboard", "--runs", str(tmp_path / "none"), "--out", str(out)]) == (
        f"--runs {tmp_path / 'none'}: no such folder; give a folder of runs (runs/<task>/<algo>/<seed>)")
    runs = tmp_path / "runs"
    _run(runs, 0)
    bad = _run(runs, 1)
    (bad / "metrics.json").write_text("{truncated")
    assert _error(capsys, ["leaderboard", "--runs", str(runs), "--out", str(out)]).startswith(
        f"{bad / 'metrics.json'} is unreadable or not valid JSON")
    (bad / "metrics.json").write_text("{}")
    (bad / "config.json").unlink()
    assert _error(capsys, ["leaderboard", "--runs", str(runs), "--out", str(out)]) == (
        f"run folder {bad} has no config.json: not a shoulder-bench run")
    assert not out.exists()


def test_leaderboard_surgery_folder_without_a_summary_fails_before_evaluating(tmp_path, capsys, no_work):
    out, none = tmp_path / "board", tmp_path / "surgery"
    none.mkdir()
    assert _error(capsys, ["leaderboard", "--surgery", str(none), "--out", str(out)]) == (
        f"--surgery {none}: no summary.json there; give a folder written by `shoulder-bench surgery --out DIR`")
    (none / "summary.json").write_text("{}")
    assert _error(capsys, ["leaderboard", "--surgery", str(none), "--out", str(out)]).startswith(
        f"--surgery {none / 'summary.json'} is not a surgery summary")
    assert not out.exists()


def test_plot_curves_on_bad_run_folders(tmp_path, capsys, no_work):
    out = tmp_path / "curves.png"
    good = _run(tmp_path / "a")
    no_config = _run(tmp_path / "b", config=False)
    no_tb = _run(tmp_path / "c", tb=False)
    empty_tb = _run(tmp_path / "d", tb=False)
    (empty_tb / "tb").mkdir()
    broken = _run(tmp_path / "e")
    (broken / "config.json").write_text(json.dumps({"task": "abduction_ssp", "algo": "ppo"}))
    cases = {tmp_path / "none": f"run folder {tmp_path / 'none'} does not exist",
             no_config: f"run folder {no_config} has no config.json: not a shoulder-bench run",
             no_tb: f"run folder {no_tb} has no tb/ folder (TensorBoard logs): not a shoulder-bench run",
             empty_tb: f"run folder {empty_tb}: tb/ holds none of the training curves (train/mean_return, "
                       f"test/mae_deg); has the run logged anything yet?",
             broken: f"{broken / 'config.json'} lacks seed: not a config.json written by shoulder-bench train"}
    for run, message in cases.items():
        assert _error(capsys, ["plot", "curves", str(good), str(run), "--out", str(out)]) == message
    assert not out.exists() and not out.with_suffix(".svg").exists()
    assert main(["plot", "curves", str(good), "--out", str(out)]) == 0  # the good run alone plots
    assert out.exists() and out.with_suffix(".svg").exists()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no temporary files left


def test_plot_paper_bad_runs_or_out_dir_write_nothing(tmp_path, capsys, no_work):
    figures = tmp_path / "figures"
    assert _error(capsys, ["plot", "paper", "--runs", str(tmp_path / "none"), "--out-dir", str(figures)]) == (
        f"--runs {tmp_path / 'none'}: no such folder; give a folder of runs (runs/<task>/<algo>/<seed>)")
    (tmp_path / "runs").mkdir()
    assert "holds no seed-0 runs" in _error(capsys, ["plot", "paper", "--runs", str(tmp_path / "runs"),
                                                     "--out-dir", str(figures)])
    assert not figures.exists()
    figures.write_text("a file")
    assert _error(capsys, ["plot", "paper", "--out-dir", str(figures)]) == (
        f"--out-dir {figures} is an existing file, not a folder; give a folder name")
    assert _error(capsys, ["plot", "trajectory", "--policy", "reference", "--trajectories", str(tmp_path / "runs"),
                           "--out", str(tmp_path / "t.png")]).startswith(f"--trajectories {tmp_path / 'runs'} is a "
                                                                          f"directory")
    assert _error(capsys, ["plot", "errors", "--policy", "reference", "--out", str(tmp_path / "runs")]) == (
        f"--out {tmp_path / 'runs'} is a directory; give a file name such as {tmp_path / 'runs'}/figure.png")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["figures", "runs"]


def test_a_figure_failing_half_way_leaves_neither_file(tmp_path, monkeypatch):
    from shoulder_bench.eval import plots

    real = plots._savefig

    def svg_fails(fig, fmt, path):
        if fmt == "svg":
            raise OSError("disk full")
        real(fig, fmt, path)

    monkeypatch.setattr(plots, "_savefig", svg_fails)
    with pytest.raises(OSError, match="disk full"):
        plots.plot_curves([_run(tmp_path / "a")], tmp_path / "c.png")
    assert [p.name for p in tmp_path.iterdir()] == ["a"]


def test_reproduce_bad_arguments_fail_before_training(tmp_path, capsys, no_work):
    assert _error(capsys, ["reproduce", "--frames-scale", "0", "--runs", str(tmp_path / "r")]) == (
        "--frames-scale 0.0: give a positive number (e.g. 0.01 to smoke-test)")
    assert _error(capsys, ["reproduce", "--table", str(tmp_path), "--runs", str(tmp_path / "r")]) == (
        f"--table {tmp_path} is a directory; give a file name such as {tmp_path / 'table.md'}")
    assert _error(capsys, ["reproduce", "--workers", "0", "--runs", str(tmp_path / "r")]) == (
        "--workers 0: give at least 1")
    assert list(tmp_path.iterdir()) == []


def test_each_cli_module_registers_the_commands_the_lazy_dispatch_expects():
    """main() imports only the module of the command it is given (cli.REGISTERS): each module must register exactly
    those subcommands, and every module's commands must be known, or a command would vanish."""
    import argparse
    import importlib

    from shoulder_bench import cli

    assert set(cli.REGISTERS) == set(cli.COMMANDS)
    for name in cli.COMMANDS:
        sub = argparse.ArgumentParser().add_subparsers()
        importlib.import_module(name).add_parser(sub)
        assert tuple(sub.choices) == cli.REGISTERS[name], name
    for command in ("tasks", "eval", "model"):
        assert set(cli.build_parser(command)._subparsers._group_actions[0].choices) == {
            c for m, cs in cli.REGISTERS.items() if command in cs for c in cs}


def test_the_program_runs_main_with_fewer_full_collections_and_a_frozen_exit():
    """`run` (the console script, `python -m shoulder_bench.cli`) is `main` on sys.argv with full collections 10x
    rarer and the heap frozen when the command returns (cli.run: start-up time); `main` leaves the collector alone."""
    import subprocess
    import sys

    script = ("import gc, sys\nfrom shoulder_bench.cli import main, run\nbefore = gc.get_threshold()\n"
              "assert main(['tasks']) == 0 and gc.get_threshold() == before and gc.get_freeze_count() == 0\n"
              "sys.argv = ['shoulder-bench', 'tasks']\nassert run() == 0\n"
              "assert gc.get_threshold() == before[:2] + (100,) and gc.get_freeze_count() > 0\nprint('ok')\n")
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
    assert out.returncode == 0 and out.stdout.strip().endswith("ok"), out.stderr[-2000:]
    out = subprocess.run([sys.executable, "-m", "shoulder_bench.cli", "tasks"], capture_output=True, text=True)
    assert out.returncode == 0 and "abduction_4m" in out.stdout, out.stderr[-2000:]
