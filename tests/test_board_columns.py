"""The leaderboard's ranking columns on synthetic data with known answers: success, effort, smoothness,
co-contraction, the rank order, seeds against trajectories for the intervals, frames to accuracy, curves."""
import numpy as np
import pytest

from shoulder_bench.eval import board_columns as board
from shoulder_bench.eval.measures import co_contraction, effort, mean_abs_delta, successes, tracking_error


def _trace(err_rows, T):
    """A trace whose angle exceeds the target by each row's errors (NaN-padded to T frames)."""
    angle = np.full((len(err_rows), T), np.nan)
    for b, e in enumerate(err_rows):
        angle[b, :len(e)] = 50.0 + np.asarray(e, dtype=float)
    return {"angle_deg": angle, "target_deg": np.full((len(err_rows), T), 50.0)}


def test_success_is_under_2_deg_on_90_percent_of_frames():
    ok = [1.0] * 90 + [5.0] * 10  # 90 % under 2 deg: succeeds
    short = [1.0] * 89 + [5.0] * 11  # 89 %: fails
    edge = [1.999] * 90 + [2.0] * 10  # strictly under: 2.0 itself is not
    crash = [0.1] * 85 + [np.nan] * 15  # crashed at frame 85: the missing frames count as failed
    brief = [0.5] * 10  # a 10-frame trajectory, all under: succeeds
    trace = _trace([ok, short, edge, crash, brief], 100)
    frames = [100, 100, 100, 100, 10]
    err = tracking_error(trace, frames)
    assert err[3, 85:].tolist() == [180.0] * 15 and np.isnan(err[4, 10:]).all()
    assert successes(err, frames).tolist() == [True, False, True, False, True]
    crash_late = _trace([[0.1] * 95 + [np.nan] * 5], 100)  # crashed late: 95 % of the frames were under 2 deg
    assert successes(tracking_error(crash_late, [100]), [100]).tolist() == [True]
    with pytest.raises(ValueError, match="frame counts"):
        successes(err, [100, 100, 100, 100, 101])


def test_effort_and_mean_abs_delta():
    act = np.full((2, 4, 2), np.nan)
    act[0, :3] = [[0.1, 0.2], [0.3, 0.2], [0.3, 0.4]]  # sum a^2: 0.05, 0.13, 0.25
    act[1, :2] = [[0.0, 0.5], [0.0, 0.5]]  # 0.25, 0.25
    assert effort(act) == pytest.approx((0.05 + 0.13 + 0.25 + 0.25 + 0.25) / 5)
    # |delta a| pairs: traj 0 (0.2, 0), (0, 0.2); traj 1 (0, 0): six muscle-frames, 0.4 in all
    assert mean_abs_delta(act) == pytest.approx(0.4 / 6)


class _Law:
    """Two muscles with fixed isometric torques per unit activation: +10 N m (an elevator), -4 N m (an adductor)."""
    muscles = ("up", "down")

    def torque(self, angle, velocity, activation):
        assert np.all(velocity == 0)  # the measure is isometric
        return activation * np.array([10.0, -4.0])


def test_co_contraction_is_the_activation_share_against_the_net_torque():
    angle = np.array([[30.0, 40.0, 50.0, np.nan]])
    act = np.array([[[0.2, 0.1], [0.1, 0.5], [0.3, 0.0], [0.9, 0.9]]])
    # frame 0: net +1.6, 'down' opposes (0.1); frame 1: net -1.0, 'up' opposes (0.1); frame 2: nothing opposes
    assert co_contraction(angle, act, _Law()) == pytest.approx((0.1 + 0.1) / (0.3 + 0.6 + 0.3))
    with pytest.raises(ValueError, match="activations for a law"):
        co_contraction(angle, act[..., :1], _Law())


def test_co_contraction_with_the_task_law():
    law = board.law_for("abduction_4m", None, {})
    angle = np.full((1, 3), 60.0)
    act = np.zeros((1, 3, 4))
    act[0, :, 0] = 0.5  # ssp alone: nothing opposes it
    assert co_contraction(angle, act, law) == pytest.approx(0.0)
    up = law.torque(np.radians([60.0]), np.zeros(1), np.full((1, 4), 0.5))[0]  # every muscle at 0.5
    act[0, :] = 0.5
    expected = (np.sign(up) != np.sign(up.sum())).sum() / 4  # equal activations: the share of opposing muscles
    assert co_contraction(angle, act, law) == pytest.approx(expected)
    assert 0.0 < expected < 1.0  # some of the four muscles work against the others at 60 deg


def _row(task, success, mae, effort_):
    return {"task": task, "success": (success, 0.0), "test_mae": (mae, mae, mae), "effort": (effort_, 0.0)}


def test_rank_is_success_then_mae_then_effort_within_a_muscle_set():
    rows = [_row("abduction_4m", 0.80, 0.5, 0.10),  # a: lower success than b and c
            _row("abduction_4m_discrete", 0.90, 0.9, 0.10),  # b: the best success but the worst MAE of the two
            _row("abduction_4m", 0.90, 0.4, 0.30),  # c: success ties with b, better MAE
            _row("abduction_ssp", 0.0, 5.0, 0.50),  # another muscle set: ranked on its own
            _row("abduction_4m", 0.80, 0.5, 0.05),  # d: ties with a on success and MAE, less effort
            _row("abduction_ssp_discrete", float("nan"), 4.0, 0.1)]  # no success measured: last
    out = board.ranked(rows)
    order = [(r["task"], r["success"][0], r["test_mae"][0], r["effort"][0], r["rank"]) for r in out]
    assert order[:4] == [("abduction_4m", 0.9, 0.4, 0.3, 1), ("abduction_4m_discrete", 0.9, 0.9, 0.1, 2),
                         ("abduction_4m", 0.8, 0.5, 0.05, 3), ("abduction_4m", 0.8, 0.5, 0.1, 4)]
    assert [(r["task"], r["rank"]) for r in out[4:]] == [("abduction_ssp", 1), ("abduction_ssp_discrete", 2)]


def _entry(mae, frames_to=None, n_traj=4):
    abs_sum = np.full(n_traj, mae * 10.0)
    return {"test_mae": mae, "test_rmse": mae * 1.5, "crashes": 0, "abs_sum": abs_sum, "sq_sum": abs_sum * mae,
            "frames": np.full(n_traj, 10), "suites": {"fast": mae + 1.0},
            "per_trajectory": {"mae_deg": [mae] * n_traj, "rmse_deg": [mae] * n_traj},
            "accuracy": board.accuracy_of({"frames_to_paper_accuracy": None, "to_accuracy": frames_to}
                                          if frames_to is not None else {})}


def test_intervals_over_seeds_or_over_trajectories():
    two = board.aggregate([_entry(1.0), _entry(3.0)], ["fast"])
    assert two["ci_over"] == "2 seeds" and two["test_mae"] == (pytest.approx(2.0), pytest.approx(1.0),
                                                               pytest.approx(3.0))
    assert two["gap:fast"] == (pytest.approx(1.0), pytest.approx(0.0)) and two["suite:fast"][0] == pytest.approx(3.0)
    one = _entry(2.0)
    one["abs_sum"] = np.array([10.0, 10.0, 30.0, 30.0])  # trajectory MAEs 1, 1, 3, 3 (10 frames each)
    single = board.aggregate([one], [])
    assert single["ci_over"] == "4 trajectories" and single["test_mae"][0] == pytest.approx(2.0)
    assert 1.0 <= single["test_mae"][1] < 2.0 < single["test_mae"][2] <= 3.0


def test_frames_and_wall_time_to_accuracy():
    reached = {"2.0": {"frames": 1000, "wall_s": 10.0}, "1.0": None}
    later = {"2.0": {"frames": 3000, "wall_s": 30.0}, "1.0": {"frames": 5000, "wall_s": 50.0}}
    row = board.aggregate([_entry(1.0, reached), _entry(2.0, later), _entry(3.0)], [])
    assert row["to:2.0"] == {"frames": 2000.0, "wall_s": 20.0, "reached": 2, "of": 2}
    assert row["to:1.0"] == {"frames": 5000.0, "wall_s": 50.0, "reached": 1, "of": 2}
    assert board.to_text(row["to:1.0"]) == "5,000 · 50.0 s (1/2)" and board.to_text(row["to:5.15"]) == "– (0/2)"
    none = board.aggregate([_entry(1.0)], [])  # no record (a shipped agent, the reference): '-'
    assert none["to:2.0"]["of"] == 0 and board.to_text(none["to:2.0"]) == "–"


def test_curve_band_over_seeds():
    a = ([100, 200, 300], [8.0, 4.0, 2.0])
    b = ([100, 250, 300, 400], [6.0, 3.0, 2.0, 1.0])
    c = board.curve_band([a, b, None])
    assert c["n"] == 2 and c["frames"].tolist() == [100, 200, 250, 300]  # the range both cover
    assert c["mean"][0] == pytest.approx(7.0) and c["lo"][0] == pytest.approx(6.0) and c["hi"][0] == 8.0
    assert c["mean"][1] == pytest.approx((4.0 + np.interp(200, b[0], b[1])) / 2)
    single = board.curve_band([a])
    assert single["n"] == 1 and np.isnan(single["lo"]).all() and single["mean"].tolist() == [8.0, 4.0, 2.0]
    assert board.curve_band([None]) is None


def test_history_from_recorded_evaluations_or_nothing(tmp_path):
    recorded = {"evaluations": [{"frames": 200, "training_s": 2.0, "mae_deg": 2.0},
                                {"frames": 100, "training_s": 1.0, "mae_deg": 4.0}], "frames": 200, "mae_deg": 2.0}
    assert board.history(tmp_path, recorded) == ([100, 200], [4.0, 2.0])
    assert board.history(tmp_path, {"frames": 200, "mae_deg": 2.0}) is None  # neither evaluations nor tb/
