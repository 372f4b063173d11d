"""Target trajectories: the paper's generator, CSV files, the fixed test set."""
import hashlib

import numpy as np
import pytest

from shoulder_bench import trajectory as T


@pytest.mark.parametrize("split,frames,lo,hi", [("train", 100, 30, 90), ("test", 200, 20, 100)])
def test_random_trajectory_protocol(split, frames, lo, hi):
    rng = np.random.default_rng(3)
    for _ in range(20):
        tr = T.random_trajectory(rng, split)
        assert tr.frames == frames
        knots = tr.angle_deg[::50]  # segment end points every 5 s
        assert np.all((knots >= lo) & (knots <= hi))
        assert tr.angle_deg.min() >= lo - 1e-9 and tr.angle_deg.max() <= hi + 1e-9  # quintics do not overshoot


def test_quintic_boundary_conditions():
    t = np.array([0.0, 5.0])
    pos, vel = T.quintic(t, 30.0, 80.0, 5.0)
    assert np.allclose(pos, [30, 80]) and np.allclose(vel, 0)
    h = 1e-5
    acc = (T.quintic(np.array([h]), 30, 80, 5)[1] - T.quintic(np.array([0.0]), 30, 80, 5)[1]) / h
    assert abs(acc[0]) < 1e-3


@pytest.mark.parametrize("split", ["train", "test"])
def test_random_targets_in_arrays_are_each_generators_quintic_segments(split):
    """The batched env's resets: one row per generator, each the segments `quintic` gives for the end points that
    generator draws (uniform in the split's range), with from_array's central-difference velocity."""
    angle, velocity = T.random_targets([np.random.default_rng(s) for s in range(4)], split)
    spec = T.SPLITS[split]
    n_seg = int(round(spec["duration_s"] / T.SEGMENT_S))
    t = np.arange(int(round(T.SEGMENT_S / T.FRAME_S))) * T.FRAME_S
    for s in range(4):
        points = np.random.default_rng(s).uniform(*spec["range_deg"], size=n_seg + 1)
        expected = T.from_array(np.concatenate([T.quintic(t, points[k], points[k + 1], T.SEGMENT_S)[0]
                                                for k in range(n_seg)] + [points[-1:]]))
        np.testing.assert_allclose(angle[s], expected.angle_deg, rtol=0, atol=1e-12)
        np.testing.assert_allclose(velocity[s], expected.velocity_deg_s, rtol=0, atol=1e-9)
    assert angle.shape == (4, int(round(spec["duration_s"] / T.FRAME_S)) + 1)


def test_seeded_generator_is_deterministic():
    a = T.random_trajectory(np.random.default_rng(5), "train")
    b = T.random_trajectory(np.random.default_rng(5), "train")
    assert np.array_equal(a.angle_deg, b.angle_deg)


def test_fixed_test_set_checksum_and_regeneration():
    path = T.test_set_path()
    recorded = path.with_suffix(".sha256").read_text().split()[0]
    assert hashlib.sha256(path.read_bytes()).hexdigest() == recorded
    stored = T.load_test_set()
    assert len(stored) == 100 and all(t.frames == 200 for t in stored)
    fresh = T.make_test_set()
    assert np.allclose([t.angle_deg for t in stored], [t.angle_deg for t in fresh], atol=1e-6)


def _write(tmp_path, text, name="t.csv"):
    p = tmp_path / name
    p.write_text(text)
    return p


def test_csv_any_rate_is_resampled_to_frames(tmp_path):
    t = np.arange(0, 3.0001, 0.01)
    rows = "".join(f"{a:.2f},{40 + 10 * np.sin(a):.5f}\n" for a in t)
    (tr,) = T.load_csv(_write(tmp_path, "time_s,angle_deg\n" + rows))
    assert tr.frames == 30
    assert tr.angle_deg[10] == pytest.approx(40 + 10 * np.sin(1.0), abs=1e-4)


def test_csv_with_several_trajectories(tmp_path):
    p = _write(tmp_path, "trajectory,time_s,angle_deg\na,0,30\na,1,40\nb,0,50\nb,2,60\n")
    a, b = T.load_csv(p)
    assert a.frames == 10 and b.frames == 20


@pytest.mark.parametrize("text,match", [
    ("time,angle\n0,1\n", r"missing column.*time_s"),
    ("time_s,angle_deg\n0,30\n0.1,nan\n", r"row 3.*angle"),
    ("time_s,angle_deg\n0,30\n0.2,31\n0.1,32\n", r"row 4.*does not increase"),
    ("time_s,angle_deg\n0,30\n0.1,200\n", r"row 3.*range"),
    ("time_s,angle_deg\n0,30\n0.1,abc\n", r"row 3.*not numbers"),
    ("time_s,angle_deg\n", r"no data rows"),
])
def test_bad_csv_names_file_row_and_fix(tmp_path, text, match):
    p = _write(tmp_path, text, "bad.csv")
    with pytest.raises(ValueError, match=match) as info:
        T.load_csv(p)
    assert "bad.csv" in str(info.value)


def test_from_array_rejects_out_of_range():
    with pytest.raises(ValueError, match="range"):
        T.from_array([30, 40, 500])


def test_combing_profile_is_synthetic_and_shaped_like_the_paper():
    c = T.combing()
    assert "synthetic" in c.name and c.frames == 175
    assert 95 <= c.angle_deg.max() <= 103 and c.angle_deg.min() >= 19.9
    up = c.angle_deg > 80
    assert np.count_nonzero(np.diff(up.astype(int)) == 1) == 2  # two lifts


def test_csv_utf8_bom_and_spaces_around_header_names(tmp_path):
    """Excel's "CSV UTF-8" starts with a byte-order mark; hand-written headers often carry spaces."""
    p = tmp_path / "excel.csv"
    p.write_bytes("\ufefftrajectory , time_s ,  angle_deg\r\n a , 0 , 30\r\na,1,40\r\n\r\n".encode("utf-8"))
    (tr,) = T.load_csv(p)
    assert tr.frames == 10 and tr.angle_deg[0] == pytest.approx(30.0) and tr.angle_deg[-1] == pytest.approx(40.0)
    assert tr.name == "excel.csv:a"


def test_non_utf8_csv_names_the_file_and_the_encoding(tmp_path):
    p = tmp_path / "latin1.csv"
    p.write_bytes("time_s,angle_deg,épaule\n0,30,1\n1,40,1\n".encode("latin-1"))  # what an old Excel writes
    with pytest.raises(ValueError, match=r"latin1\.csv: not UTF-8 text \(invalid continuation byte at byte 17\); "
                                         r"save it as UTF-8 CSV"):
        T.load_csv(p)


def test_csv_messages_print_plain_numbers(tmp_path):
    with pytest.raises(ValueError, match=r"row 3: angle nan deg is not") as info:
        T.load_csv(_write(tmp_path, "time_s,angle_deg\n0,30\n0.1,nan\n"))
    assert "np.float64" not in str(info.value)
    with pytest.raises(ValueError, match=r"sample 2: angle 500 deg is not"):
        T.from_array([30, 40, 500])


def test_a_directory_as_trajectory_is_a_clear_error(tmp_path):
    import shoulder_bench

    with pytest.raises(ValueError, match=rf"trajectory path {tmp_path} is a directory, not a CSV file"):
        T.load_csv(tmp_path)
    with pytest.raises(ValueError, match=rf"trajectory path {tmp_path} is a directory"):
        shoulder_bench.load("abduction_4m", trajectory=tmp_path)
    with pytest.raises(ValueError, match=rf"trajectory path {tmp_path} is a directory"):
        shoulder_bench.load("abduction_4m", trajectory=str(tmp_path))
