"""Named evaluation suites (issue 14 §2): the shipped files are what the generator makes, carry their recorded
checksums, have the shape and ranges they claim, and `shoulder-bench eval --suite` runs them; `robust`'s task options
apply, merge with a policy's own by the documented rule, and its evaluations are deterministic."""
import hashlib
import json

import numpy as np
import pytest

from shoulder_bench.cli import main
from shoulder_bench.eval import suites
from shoulder_bench.trajectory import FRAME_S, load_csv, load_test_set, quintic, write_csv


@pytest.mark.parametrize("name", suites.SUITES)
def test_files_match_the_generator_and_their_checksums(name):
    path = suites.suite_path(name)
    data = path.read_bytes()
    assert hashlib.sha256(data).hexdigest() == suites.SHA256[name]
    made = suites.generate(name)
    assert data == suites.csv_text(made)  # byte for byte, as `--write` writes it
    stored = suites.load_suite(name)
    assert len(stored) == len(made)
    for s, m in zip(stored, made):
        np.testing.assert_allclose(s.angle_deg, np.round(m.angle_deg, 6), rtol=0, atol=1e-9)


def test_paper_is_the_test_set():
    assert suites.suite_path("paper").name == "test_set.csv"
    assert suites.SHA256["paper"] == (suites.data_dir() / "test_set.sha256").read_text().split()[0]
    for a, b in zip(suites.load_suite("paper"), load_test_set()):
        np.testing.assert_array_equal(a.angle_deg, b.angle_deg)


def test_seeds_are_distinct_from_the_paper_set():
    assert len({suites.FAST_SEED, suites.WIDE_SEED, 20201}) == 3


def test_a_changed_file_is_refused(tmp_path, monkeypatch):
    (tmp_path / "suite_fast.csv").write_bytes(suites.suite_path("fast").read_bytes().replace(b"\n0,0.0,", b"\n0,0.0,1"))
    monkeypatch.setattr(suites, "data_dir", lambda: tmp_path)
    with pytest.raises(ValueError, match="does not match its recorded checksum"):
        suites.load_suite("fast")


def test_shapes_and_ranges():
    for name in ("paper", "fast", "wide"):
        trajs = suites.load_suite(name)
        assert len(trajs) == 100 and all(len(t.angle_deg) == 201 for t in trajs), name  # 20 s at 0.1 s
    paper, wide = suites.load_suite("paper"), suites.load_suite("wide")
    assert 20 <= min(t.angle_deg.min() for t in paper) and max(t.angle_deg.max() for t in paper) <= 100
    lo, hi = min(t.angle_deg.min() for t in wide), max(t.angle_deg.max() for t in wide)
    assert 5 <= lo < 10 and 145 < hi <= 150  # covers 5-150 deg
    ends = np.concatenate([t.angle_deg[::50] for t in wide])  # 5 s segment end points
    assert np.histogram(ends, bins=5, range=(5, 150))[0].min() > 50  # spread over the whole range
    (adl,) = suites.load_suite("adl")
    assert len(adl.angle_deg) == 176


def test_fast_segments_are_2_to_3_s():
    """The segment ends come from the generator's plan; the stored samples show them: the angle between two ends is
    a rest-to-rest quintic of that length, so the target velocity reaches zero at each end, 2-3 s apart."""
    plans = suites.fast_plan()
    stored = suites.load_suite("fast")
    lengths = []
    for (points, seg), traj in zip(plans, stored):
        assert sum(seg) == 200
        lengths += seg
        ends = np.concatenate([[0], np.cumsum(seg)])
        a = traj.angle_deg
        for k, n in enumerate(seg):
            t = np.arange(n + 1) * FRAME_S
            pos, vel = quintic(t, a[ends[k]], a[ends[k + 1]], n * FRAME_S)
            np.testing.assert_allclose(a[ends[k]:ends[k + 1] + 1], pos, atol=2e-6)  # this quintic and no other
            assert vel[0] == 0 and vel[-1] == 0
        # sampled velocity (central difference) nearly zero at the ends, against a peak of 1.875 x step / duration
        step = np.abs(np.diff(points))
        assert np.all(np.abs(traj.velocity_deg_s[ends[1:-1]]) < 0.05 * 1.875 * np.maximum(step[:-1], step[1:]) / 2.0
                      + 1e-6)
    lengths = np.array(lengths) * FRAME_S
    assert lengths.min() >= 2.0 - 1e-9 and lengths.max() <= 3.0 + 1e-9
    assert {20, 30} <= set(np.rint(lengths * 10).astype(int))  # both ends of the range occur
    ends = np.concatenate([p for p, _ in plans])
    assert 20 <= ends.min() and ends.max() <= 100


def test_fast_segment_draws_always_fill_20_s():
    rng = np.random.default_rng(0)
    for total in range(20, 400):
        seg = suites.fast_segments(rng, total) if not 30 < total < 40 else None
        if seg is not None:
            assert sum(seg) == total and all(20 <= s <= 30 for s in seg)


def test_eval_suite_runs_and_names_the_valid_ones(capsys):
    assert main(["eval", "--policy", "reference", "--suite", "fast", "--json"]) == 0
    m = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert m["n_trajectories"] == 100 and m["crashes"] == 0 and m["mae_deg"] < 5
    assert main(["eval", "--policy", "reference", "--suite", "nope"]) == 2
    err = capsys.readouterr().err
    assert "--suite nope: not a suite name (paper, fast, wide, adl, robust)" in err
    assert main(["eval", "--policy", "reference", "--suite", "fast", "--trajectories", "test"]) == 2
    assert "give --suite or --trajectories, not both" in capsys.readouterr().err
    with pytest.raises(ValueError, match="choose one of paper, fast, wide, adl, robust"):
        suites.generate("nope")


def test_default_is_paper_and_trajectories_still_work(capsys):
    assert main(["eval", "--policy", "reference", "--suite", "adl", "--json"]) == 0
    adl = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert main(["eval", "--policy", "reference", "--trajectories", "combing", "--json"]) == 0
    combing = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert adl["n_trajectories"] == combing["n_trajectories"] == 1
    assert abs(adl["mae_deg"] - combing["mae_deg"]) < 1e-3  # the same profile, stored at 1e-6 deg


def test_a_folder_is_a_hidden_suite(tmp_path, capsys):
    fast = suites.load_suite("fast")
    write_csv(tmp_path / "b.csv", fast[1:3])
    write_csv(tmp_path / "a.csv", fast[:1])
    (tmp_path / "notes.txt").write_text("ignored")
    got = suites.load_suite(str(tmp_path))
    assert [t.name for t in got] == ["a.csv:0", "b.csv:0", "b.csv:1"]
    np.testing.assert_allclose(got[2].angle_deg, fast[2].angle_deg, atol=1e-9)
    assert main(["eval", "--policy", "reference", "--suite", str(tmp_path), "--json"]) == 0
    out = capsys.readouterr().out
    assert f"(suite {tmp_path}" in out and json.loads(out.strip().splitlines()[-1])["n_trajectories"] == 3
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(ValueError, match="holds no"):
        suites.load_suite(str(empty))
    assert load_csv(tmp_path / "a.csv")[0].frames == 200


ROBUST = {"delay_frames": 1, "obs_noise_deg": 0.5, "randomize": {"strength": 0.2, "mass": 0.0, "load": (1.0, 1.0)}}


def test_robust_is_the_paper_set_under_fixed_options():
    assert suites.FILES["robust"] == "test_set.csv" and suites.SHA256["robust"] == suites.SHA256["paper"]
    assert suites.OPTIONS == {"robust": ROBUST} and suites.suite_options("robust") == ROBUST
    for a, b in zip(suites.load_suite("robust"), suites.load_suite("paper")):
        np.testing.assert_array_equal(a.angle_deg, b.angle_deg)
    assert suites.load_suite("robust")[7].name == "robust:7"
    suites.suite_options("robust")["randomize"]["strength"] = 9  # a copy: the constant stays
    assert suites.OPTIONS["robust"]["randomize"]["strength"] == 0.2
    assert suites.suite_options("fast") == {} and suites.options_for("fast", {"delay_frames": 2}) == {"delay_frames": 2}


def test_robust_draws_strength_within_20_percent_and_exactly_1_kg():
    import shoulder_bench

    venv = shoulder_bench.make_vec("abduction_4m", 20, seed=0, trajectory=suites.load_suite("robust")[:20],
                                   **suites.options_for("robust", {}))
    draws = [venv.draws(i) for i in range(20)]
    assert venv.delay_frames == 1 and venv.obs_noise_deg == 0.5
    venv.close()
    strength = np.array([d["strength"] for d in draws])
    assert strength.shape == (20, 4) and np.all(np.abs(strength - 1.0) <= 0.2)
    assert np.abs(strength - 1.0).max() > 0.15 and len(np.unique(strength)) == strength.size  # spread over +-20 %
    assert [d["mass_scale"] for d in draws] == [1.0] * 20 and [d["load_kg"] for d in draws] == [1.0] * 20


def test_robust_options_merge_with_a_policys_own():
    """The suite's options go on top; the policy's own at the suite's value or at the default agree; another value
    is an error naming the option; options the suite leaves alone stay the policy's."""
    merged = suites.options_for("robust", {"activation_dynamics": True, "delay_frames": 1})
    assert merged == {"activation_dynamics": True} | ROBUST  # delay 1 trained, delay 1 evaluated (not 2)
    assert suites.options_for("robust", {"delay_frames": 0, "obs_noise_deg": 0.0, "randomize": None}) == ROBUST
    same = {"randomize": "strength=0.2,load=1:1", "obs_noise_deg": 0.5}  # the suite's values, written otherwise
    assert suites.options_for("robust", same) == ROBUST
    for key, value in (("delay_frames", 2), ("obs_noise_deg", 1.0), ("randomize", True),
                       ("randomize", {"strength": 0.2, "mass": 0.0, "load": (0.0, 2.0)})):
        with pytest.raises(ValueError, match=f"suite robust evaluates under {key}=.*but run X sets {key}="):
            suites.options_for("robust", {key: value}, who="run X")


def test_robust_evaluation_is_deterministic_and_seeded_per_trajectory():
    from shoulder_bench.eval.evaluate import evaluate
    from shoulder_bench.eval.reference import ReferenceController

    trajs = suites.load_suite("robust")[:3]
    policy = ReferenceController("abduction_4m")
    opts = suites.options_for("robust", {})
    a = evaluate(policy, "abduction_4m", trajs, options=opts)
    b = evaluate(policy, "abduction_4m", trajs, options=opts)
    assert a["per_trajectory"] == b["per_trajectory"] and a["mae_deg"] == b["mae_deg"]  # exactly
    # trajectory k is seeded seed + k: the first two alone score as they do among three
    two = evaluate(policy, "abduction_4m", trajs[:2], options=opts)
    assert two["per_trajectory"]["mae_deg"] == a["per_trajectory"]["mae_deg"][:2]
    other = evaluate(policy, "abduction_4m", trajs, options=opts, seed=1)
    assert other["per_trajectory"]["mae_deg"] != a["per_trajectory"]["mae_deg"]  # the draws follow the seed
    paper = evaluate(policy, "abduction_4m", trajs)
    assert a["mae_deg"] > paper["mae_deg"] + 1.0  # the perturbations act (nominal-arm controller, 1 kg load)


def _few(monkeypatch, n=2):
    load = suites.load_suite
    monkeypatch.setattr(suites, "load_suite", lambda spec, task=None: load(spec, task)[:n])  # tiny inputs


def test_eval_suite_robust_records_its_options(monkeypatch, capsys):
    _few(monkeypatch)
    assert main(["eval", "--policy", "reference", "--suite", "robust", "--json"]) == 0
    out = capsys.readouterr().out.strip().splitlines()
    m = json.loads(out[-1])
    assert m["suite"] == "robust" and m["n_trajectories"] == 2
    assert m["suite_options"] == json.loads(json.dumps(ROBUST)) and m["options"] == m["suite_options"]
    assert "(suite robust, delay_frames=1, obs_noise_deg=0.5, randomize=" in out[-2]
    assert main(["eval", "--policy", "reference", "--suite", "robust", "--option", "activation_dynamics=True",
                 "--json"]) == 0
    assert json.loads(capsys.readouterr().out.strip().splitlines()[-1])["options"]["activation_dynamics"] is True
    assert main(["eval", "--policy", "reference", "--suite", "robust", "--option", "delay_frames=2"]) == 2
    assert "suite robust evaluates under delay_frames=1" in capsys.readouterr().err


def _run(root, seed, options):
    """A finished run folder of a policy that never moves, trained (so its config says) with `options`."""
    import torch

    from shoulder_bench.train.policy import save_policy

    class Still(torch.nn.Module):
        def forward(self, obs: torch.Tensor) -> torch.Tensor:
            return torch.zeros(obs.shape[0], obs.shape[1] - 4)

    run = root / "abduction_ssp" / "ppo" / str(seed)
    run.mkdir(parents=True)
    meta = {"task": "abduction_ssp", "algo": "ppo", "seed": seed, "muscle_model": "fem", "options": options}
    (run / "config.json").write_text(json.dumps(meta | {"frames": 1000}))
    (run / "metrics.json").write_text(json.dumps({"mae_deg": 1.0, "wall_s": 2.0}))
    save_policy(Still(), run / "policy.pt", meta)


def test_leaderboard_suite_robust(tmp_path, monkeypatch, capsys):
    import csv

    from shoulder_bench.eval import leaderboard

    _few(monkeypatch)
    few = leaderboard.trajectories_for
    monkeypatch.setattr(leaderboard, "trajectories_for", lambda spec: few(spec)[:2])
    calls = []
    real = leaderboard.evaluate
    monkeypatch.setattr(leaderboard, "evaluate", lambda *a, **k: calls.append(k["options"]) or real(*a, **k))
    runs, out = tmp_path / "runs", tmp_path / "board"
    _run(runs, 0, {"delay_frames": 1})
    assert main(["leaderboard", "--runs", str(runs), "--suite", "paper", "robust", "--out", str(out)]) == 0
    assert {"delay_frames": 1} in calls and ROBUST in calls  # the run's own on paper; the suite's for the reference
    # the run (delay 1 = the suite's) and four reference rows: both tasks, default options and the run's delay 1
    assert sum(o == ROBUST for o in calls) == 5
    rows = list(csv.DictReader((out / "leaderboard.csv").open()))
    scored = [r for r in rows if r["rank"]]
    assert len(scored) == 5
    for r in scored:
        gap = float(r["suite_robust_mae_mean"]) - float(r["test_mae_mean"])
        assert float(r["gap_robust_mean"]) == pytest.approx(gap)
    md = (out / "leaderboard.md").read_text()
    assert "| robust MAE (deg) | gap robust − paper (deg) |" in md and "Suite robust: the paper test set under " \
        "delay_frames=1, obs_noise_deg=0.5, randomize=" in md
    _run(runs, 1, {"delay_frames": 2})  # conflicts with the suite: refused before any evaluation
    calls.clear()
    assert main(["leaderboard", "--runs", str(runs), "--suite", "robust", "--out", str(tmp_path / "b")]) == 2
    err = capsys.readouterr().err
    assert "suite robust evaluates under delay_frames=1" in err and "sets delay_frames=2" in err
    assert calls == [] and not (tmp_path / "b").exists()
