"""The 3-DOF tasks' suites (issue 12 §4): fast, adl and robust in three dimensions on track_3dof(_discrete), the
1-DOF ones in the scapular plane on elevate_scapular_plane_12m; the shipped files are what the generator makes and
carry their checksums, robust's options apply, `eval --suite` runs them and the 3-DOF board adds their columns."""
import hashlib
import json

import numpy as np
import pytest

from shoulder_bench import trajectory3
from shoulder_bench.cli import main
from shoulder_bench.eval import suites


@pytest.mark.parametrize("name", suites.SUITES3)
def test_3dof_suite_files_are_what_the_generator_makes(name):
    path = suites.suite_path(name, three=True)
    data = path.read_bytes()
    assert hashlib.sha256(data).hexdigest() == suites.SHA256_3[name]
    assert data == trajectory3.csv_text(suites.generate3(name))  # byte for byte, as `--write` writes it
    stored = suites.load_suite(name, "track_3dof")
    assert all(isinstance(t, trajectory3.Trajectory3) for t in stored) and stored[0].name == f"{name}:0"
    for a, b in zip(stored, suites.generate3(name)):
        np.testing.assert_allclose(a.angle_deg, b.angle_deg, atol=1e-6)


def test_3dof_fast_moves_all_coordinates_faster_within_the_test_ranges():
    """20 s each, inside the test ranges, 2-3 s segments against the test set's 5 s: about twice the speed in every
    coordinate (for the same spread of end points, mean |velocity| scales as 1 / segment duration)."""
    lo, hi = np.array(trajectory3.SPLITS["test"]["range_deg"]).T
    fast, test = suites.load_suite("fast", "track_3dof"), trajectory3.load_test_set()
    assert len(fast) == 100 and {t.frames for t in fast} == {t.frames for t in test} == {200}
    a = np.concatenate([t.angle_deg for t in fast])
    assert np.all(a >= lo - 1e-6) and np.all(a <= hi + 1e-6)
    speed = [np.mean([np.abs(t.velocity_deg_s).mean(axis=0) for t in s], axis=0) for s in (fast, test)]
    assert np.all(speed[0] / speed[1] > 1.6) and np.all(speed[0] / speed[1] < 2.6)
    assert suites.FAST3_SEED not in (trajectory3.TEST_SET_SEED, suites.FAST_SEED, suites.WIDE_SEED)


def test_3dof_adl_is_the_four_synthetic_profiles():
    adl = suites.load_suite("adl", "track_3dof")
    assert len(adl) == len(trajectory3.ADL) == 4
    for got, make in zip(adl, trajectory3.ADL.values()):
        np.testing.assert_allclose(got.angle_deg, make().angle_deg, atol=1e-6)


def test_3dof_robust_is_the_3dof_test_set_under_the_1dof_robusts_options():
    robust = suites.load_suite("robust", "track_3dof_discrete")
    for a, b in zip(robust, trajectory3.load_test_set()):
        np.testing.assert_array_equal(a.angle_deg, b.angle_deg)
    assert suites.suite_options("robust") == suites.OPTIONS["robust"] and suites.suite_options("fast") == {}
    assert suites.options_for("robust", {"line_of_action": "band"}) == {"line_of_action": "band"} | suites.OPTIONS[
        "robust"]
    with pytest.raises(ValueError, match="suite robust evaluates under delay_frames=1.*but run X sets delay_frames=2"):
        suites.options_for("robust", {"delay_frames": 2}, who="run X")


def test_the_scapular_plane_task_takes_the_1dof_suites_in_the_scapular_plane(tmp_path):
    from shoulder_bench.tasks.track3d import SCAPULAR_PLANE_DEG

    got = suites.load_suite("fast", "elevate_scapular_plane_12m")
    for a, b in zip(got[:5], suites.load_suite("fast")):
        np.testing.assert_array_equal(a.angle_deg[:, 1], b.angle_deg)
        assert np.all(a.angle_deg[:, 0] == SCAPULAR_PLANE_DEG) and np.all(a.angle_deg[:, 2] == 0)
    with pytest.raises(ValueError, match="wide's elevations leave its pose space"):
        suites.load_suite("wide", "elevate_scapular_plane_12m")
    with pytest.raises(ValueError, match=r"not a suite name \(fast, adl, robust\) nor a folder of 3-DOF CSV"):
        suites.load_suite("wide", "track_3dof")
    trajectory3.write_csv(tmp_path / "a.csv", [trajectory3.combing()])  # a hidden 3-DOF suite
    (hidden,) = suites.load_suite(str(tmp_path), "track_3dof")
    np.testing.assert_allclose(hidden.angle_deg, trajectory3.combing().angle_deg, atol=1e-6)


def test_eval_runs_a_3dof_suite_under_its_options(monkeypatch, capsys):
    """`eval --suite adl` on a 3-DOF agent: the four profiles; `--suite robust --json` (its first 3 trajectories
    here) reports the suite's options and scores as an evaluation under them, not as one without; --suite and
    --trajectories together are refused."""
    from shoulder_bench.eval.evaluate import evaluate
    from shoulder_bench.train.policy import load_policy

    assert main(["eval", "--policy", "pretrained:ppo_track_3dof", "--suite", "adl", "--json"]) == 0
    out = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert out["n_trajectories"] == 4 and out["suite"] == "adl" and out["suite_options"] == {}
    load = suites.load_suite
    monkeypatch.setattr(suites, "load_suite", lambda spec, task=None: load(spec, task)[:3])
    assert main(["eval", "--policy", "pretrained:ppo_track_3dof", "--suite", "robust", "--json"]) == 0
    robust = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert robust["suite_options"] == json.loads(json.dumps(suites.OPTIONS["robust"]))
    assert robust["options"]["delay_frames"] == 1 and robust["n_trajectories"] == 3
    policy, meta = load_policy("pretrained:ppo_track_3dof")
    test = trajectory3.load_test_set()[:3]
    under = evaluate(policy, "track_3dof", test, options=meta["options"] | suites.OPTIONS["robust"])["mae_deg"]
    plain = evaluate(policy, "track_3dof", test, options=meta["options"])["mae_deg"]
    assert robust["mae_deg"] == pytest.approx(under, rel=1e-9) and abs(under - plain) > 0.1
    assert main(["eval", "--policy", "pretrained:ppo_track_3dof", "--suite", "adl", "--trajectories", "test"]) == 2


def test_the_3dof_board_adds_a_column_per_3dof_suite():
    """board3's rows score each suite the 3-DOF tasks take (paper, wide: the 1-DOF board's), under its options."""
    from shoulder_bench.eval import board3
    from shoulder_bench.eval.evaluate import evaluate
    from shoulder_bench.eval.reference3 import ReferenceController3

    assert board3.suites_of(["paper", "wide", "robust", "adl", "adl", "/some/folder"]) == ["robust", "adl"]
    controller = ReferenceController3("track_3dof")
    got = board3.suite_scores(controller, "track_3dof", ["adl"], None, {})
    assert got["adl"] == pytest.approx(evaluate(controller, "track_3dof", suites.load_suite("adl", "track_3dof"))[
        "mae_deg"])
    row = board3._row("track_3dof", "reference controller", [
        {"mae_deg": 1.0, "rmse_deg": 2.0, "coordinate_mae_deg": {"plane": 1, "elevation": 1, "rotation": 1},
         "crashes": 0, "suites": {"adl": got["adl"]}, **{k: 0.5 for k in board3.MEASURES}}], [])
    assert board3.titles([row])[6] == "adl MAE (deg)" and len(board3._cells(row)) == len(board3.titles([row]))
    md = board3.markdown([row])
    assert f"| {got['adl']:.2f} |" in md and "adl: the four synthetic ADL profiles" in md
    assert "data:image/png;base64," in board3.html([row])  # the suites' figure
