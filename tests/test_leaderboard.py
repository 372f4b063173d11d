"""The leaderboard from the shipped agents: md, csv and html with rows for ppo, dqn, bdq, reference and the paper,
ranked, the qualitative measures; from runs: seeds pooled with intervals, suites and their gaps, sample-efficiency
curves; the measures themselves on signals with known answers."""
import csv
import json

import numpy as np
import pytest
import torch

from shoulder_bench.cli import main
from shoulder_bench.eval import leaderboard
from shoulder_bench.eval.measures import early_late_share, sawtooth_rate


def test_leaderboard_from_pretrained_agents(tmp_path, capsys):
    assert main(["leaderboard", "--out", str(tmp_path)]) == 0
    md = (tmp_path / "leaderboard.md").read_text()
    for algo in ("| ppo |", "| dqn |", "| bdq |", "reference controller", "paper PPO-4"):
        assert algo in md
    assert "Saw-tooth, one muscle (ssp)" in md and "ssp + isp share of the summed activation, PPO-4" in md
    rows = list(csv.DictReader((tmp_path / "leaderboard.csv").open()))
    assert len(rows) == 9 and all(r["test_mae_mean"] for r in rows)
    scored = [r for r in rows if r["rank"]]
    assert len(scored) == 6 and all(r["ci_over"] == "100 trajectories" and r["seeds"] == "1" for r in scored)
    for r in scored:  # one seed: the interval over the trajectories holds the value; every measure was taken
        assert float(r["test_mae_lo"]) < float(r["test_mae_mean"]) < float(r["test_mae_hi"])
        assert 0 <= float(r["success_mean"]) <= 1 and float(r["effort_mean"]) > 0
        assert float(r["mean_abs_delta_mean"]) > 0
        assert 0 <= float(r["co_contraction_mean"]) < 1
    by_set = {}
    for r in scored:  # within a muscle set, ranks 1, 2, ... in order of success, then MAE
        by_set.setdefault(r["task"].removesuffix("_discrete"), []).append(r)
    for group in by_set.values():
        assert [int(r["rank"]) for r in group] == list(range(1, len(group) + 1))
        keys = [(-float(r["success_mean"]), float(r["test_mae_mean"])) for r in group]
        assert keys == sorted(keys)
    learned = {r["algo"] + " " + r["task"]: r for r in rows if r["source"] == "shipped agent"}
    assert float(learned["dqn abduction_ssp_discrete"]["sawtooth_per_s_mean"]) > float(
        learned["ppo abduction_ssp"]["sawtooth_per_s_mean"])  # the paper's saw-tooth finding, on the shipped agents
    assert 0 < float(learned["ppo abduction_4m"]["early_share_mean"]) < 1
    html = (tmp_path / "leaderboard.html").read_text()
    assert "<table>" in html and "data:image/png;base64," in html and "synthetic" in html and "<li>" in html
    assert "No row has an evaluation history" in html and "under 2 deg on at least 90 %" in html


def _still_run(root, seed, metrics=None, history=None, **config):
    """A finished run folder of a policy that never moves, with config.json as `shoulder-bench train` writes it,
    metrics.json (default: MAE 1, wall 2 + seed s) and optionally a TensorBoard test/mae_deg history."""
    from torch.utils.tensorboard import SummaryWriter

    from shoulder_bench.train.policy import save_policy

    class Still(torch.nn.Module):
        def forward(self, obs: torch.Tensor) -> torch.Tensor:
            return torch.zeros(obs.shape[0], obs.shape[1] - 4)

    run = root / "abduction_ssp" / "ppo" / str(seed)
    run.mkdir(parents=True)
    cfg = {"task": "abduction_ssp", "algo": "ppo", "seed": seed, "frames": 1000, "muscle_model": "fem",
           "config": {"lr": 1e-3}} | config
    (run / "config.json").write_text(json.dumps(cfg))
    (run / "metrics.json").write_text(json.dumps(metrics or {"mae_deg": 1.0, "wall_s": 2.0 + seed}))
    if history:
        with SummaryWriter(str(run / "tb")) as w:
            for step, mae in history:
                w.add_scalar("test/mae_deg", mae, step)
    save_policy(Still(), run / "policy.pt", {"task": "abduction_ssp", "algo": "ppo", "seed": seed,
                                            "muscle_model": cfg["muscle_model"]})


def test_runs_of_different_muscle_models_are_separate_rows(tmp_path, monkeypatch, capsys):
    few = leaderboard.trajectories_for
    monkeypatch.setattr(leaderboard, "trajectories_for", lambda spec: few(spec)[:2])  # tiny inputs
    runs, out = tmp_path / "runs", tmp_path / "board"
    _still_run(runs, 0)
    _still_run(runs, 1)  # the same setting, another seed: averaged with seed 0
    _still_run(runs, 2, muscle_model="hill")  # differs only in the muscle model: a row of its own
    assert main(["leaderboard", "--runs", str(runs), "--out", str(out)]) == 0
    rows = [r for r in csv.DictReader((out / "leaderboard.csv").open()) if r["source"].startswith("runs:")]
    rows.sort(key=lambda r: r["muscle_model"])  # the board's order is the rank's
    assert [(r["muscle_model"], r["seeds"], r["options"], r["model_version"], r["ci_over"]) for r in rows] == [
        ("fem", "2", "{}", "1", "2 seeds"), ("hill", "1", "{}", "1", "2 trajectories")]
    assert float(rows[0]["wall_s_mean"]) == pytest.approx(2.5) and float(rows[1]["wall_s_mean"]) == 4.0
    md = (out / "leaderboard.md").read_text()
    assert "| muscle model | options | model version |" in md and "variant" not in md
    assert "| abduction_ssp | ppo | hill | default | 1 | runs: " in md


def test_suites_gaps_accuracy_and_sample_efficiency_curves(tmp_path, monkeypatch, capsys):
    few = leaderboard.trajectories_for
    monkeypatch.setattr(leaderboard, "trajectories_for", lambda spec: few(spec)[:2])  # tiny inputs
    hidden = tmp_path / "hidden"
    hidden.mkdir()
    (hidden / "a.csv").write_text("time_s,angle_deg\n" + "".join(f"{t / 10:.1f},{20 + 3 * t}\n" for t in range(21)))
    runs, out = tmp_path / "runs", tmp_path / "board"
    for seed in (0, 1):
        to = {"2.0": {"frames": 1000 * (seed + 1), "wall_s": 4.0 + seed}, "1.0": None, "0.5": None}
        _still_run(runs, seed, metrics={"mae_deg": 9.0, "frames": 3000, "wall_s": 10.0, "to_accuracy": to,
                                        "frames_to_paper_accuracy": None},
                   history=[(1000, 30.0 - seed), (2000, 20.0 - seed)])
    assert main(["leaderboard", "--runs", str(runs), "--suite", "paper", "adl", str(hidden), "--out", str(out)]) == 0
    rows = list(csv.DictReader((out / "leaderboard.csv").open()))
    run = next(r for r in rows if r["source"].startswith("runs:"))
    for label in ("adl", "hidden_hidden"):  # gap = the suite's MAE minus the paper test MAE (both seeds identical)
        gap = float(run[f"suite_{label}_mae_mean"]) - float(run["test_mae_mean"])
        assert float(run[f"gap_{label}_mean"]) == pytest.approx(gap) and gap != 0
    assert float(run["frames_to_2deg"]) == 1500 and float(run["wall_s_to_2deg"]) == 4.5
    assert run["seeds_reaching_2deg"] == "2/2" and run["seeds_reaching_1deg"] == "0/2"
    assert run["seeds_reaching_5.15deg"] == "0/2"
    md = (out / "leaderboard.md").read_text()
    assert "| adl MAE (deg) | gap adl − paper (deg) | hidden hidden MAE (deg) |" in md
    assert "| – (0/2) | 1,500 · 4.5 s (2/2) | – (0/2) |" in md  # to 5.15, 2 and 1 deg
    html = (out / "leaderboard.html").read_text()
    assert "<h2>Sample efficiency</h2><p><img" in html and "No row has an evaluation history" not in html
    board = leaderboard.collect(runs)
    curve = next(r for r in board if r["source"].startswith("runs:"))["curve"]
    assert curve["n"] == 2 and curve["frames"].tolist() == [1000, 2000, 3000]  # the final evaluation appended
    assert curve["mean"].tolist() == pytest.approx([29.5, 19.5, 9.0])


def test_an_unknown_suite_fails_before_evaluating(tmp_path, monkeypatch, capsys):
    def forbidden(*a, **k):
        raise AssertionError("evaluated before the suites were checked")

    monkeypatch.setattr(leaderboard, "evaluate", forbidden)
    assert main(["leaderboard", "--suite", "paper", "nosuch", "--out", str(tmp_path / "b")]) == 2
    err = capsys.readouterr().err
    assert "--suite nosuch: not a suite name (paper, fast, wide, adl, robust)" in err and not (tmp_path / "b").exists()


def test_a_row_is_everything_but_the_seed():
    base = {"task": "abduction_4m", "algo": "ppo", "seed": 0, "frames": 1000, "muscle_model": "fem",
            "config": {"lr": 1e-3, "seed": 0}}
    old = leaderboard.setting_of(base)  # from before options and model versions were recorded
    assert old["options"] == {} and old["model_version"] == "1" and "seed" not in old
    assert leaderboard.setting_of(base | {"seed": 5, "config": {"lr": 1e-3, "seed": 5}}) == old
    assert leaderboard.setting_of(base | {"options": {}, "model_version": "1"}) == old
    for change in ({"frames": 2000}, {"config": {"lr": 3e-4}}, {"options": {"alpha": 0.2}}, {"model_version": "2"}):
        assert leaderboard.setting_of(base | change) != old, change
    settings = [old, leaderboard.setting_of(base | {"frames": 2000}), leaderboard.setting_of(base | {"config": {}}),
                leaderboard.setting_of(base | {"options": {"alpha": 0.2}})]
    variants = leaderboard._variants(settings)
    assert variants[0].startswith("1,000 frames · config ") and variants[1].startswith("2,000 frames · config ")
    assert variants[2].startswith("1,000 frames · config ") and variants[2] != variants[0]
    assert variants[3] == ""  # other options: its own columns tell it apart
    assert leaderboard.options_text({"init": "zero", "alpha": 0.2}) == "alpha=0.2, init=zero"


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


def test_the_reference_controller_is_ranked_under_each_rows_options(tmp_path, monkeypatch):
    few = leaderboard.trajectories_for
    monkeypatch.setattr(leaderboard, "trajectories_for", lambda spec: few(spec)[:2])  # tiny inputs
    runs = tmp_path / "runs"
    _still_run(runs, 0, options={"delay_frames": 1})
    board = leaderboard.collect(runs)
    ref = {(r["task"], json.dumps(r["options"], sort_keys=True)) for r in board
           if r["algo"] == "reference controller"}
    assert ref == {(t, o) for t in ("abduction_ssp", "abduction_4m") for o in ("{}", '{"delay_frames": 1}')}
    run = next(r for r in board if r["source"].startswith("runs:"))
    same = next(r for r in board if r["algo"] == "reference controller" and r["task"] == "abduction_ssp"
                and r["options"] == {"delay_frames": 1})
    assert run["options"] == {"delay_frames": 1} and same["test_mae"][0] > 0
