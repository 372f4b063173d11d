"""Targets in three dimensions for the full shoulder's tasks (issue 12 §3): (plane of elevation, elevation, axial
rotation) in degrees at the 0.1 s frame rate.

Random targets: the paper's 5 s rest-to-rest quintic segments (`trajectory.quintic`'s profile), drawn
independently per coordinate, end points uniform in each split's range (`SPLITS`); train 10 s, test 20 s, the test
ranges wider than the train ones as in the paper. Both lie inside the tables' pose space (`full_arm.POSE_RANGE_DEG`)
and inside the workspace the muscles can hold against gravity (docs/tasks_3dof.md). CSV files:
`time_s,plane_deg,elevation_deg,rotation_deg[,trajectory]`, any rate, read by `trajectory.read_frames` with the 1-DOF
files' error rules; values must lie in the pose space. Synthetic activities of daily living (`ADL`), labelled
synthetic: made up, not measured.
"""
from __future__ import annotations

import hashlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from shoulder_bench.full_arm import COORDINATE_LABELS, COORDINATES, POSE_RANGE_DEG
from shoulder_bench.trajectory import FRAME_S, SEGMENT_S, checked, quintic, read_frames

COLUMNS = ("plane_deg", "elevation_deg", "rotation_deg")
# (plane, elevation, rotation) ranges; every pose of both boxes (10 deg grid) can be held against gravity by the
# muscles (static optimisation, docs/tasks_3dof.md "Workspace"); a test plane of 10 deg could not be at rotation 40
SPLITS = {"train": {"duration_s": 10.0, "range_deg": ((30.0, 70.0), (30.0, 90.0), (-20.0, 30.0))},
          "test": {"duration_s": 20.0, "range_deg": ((20.0, 80.0), (20.0, 100.0), (-30.0, 40.0))}}
TEST_SET_SEED = 20212
TEST_SET_SIZE = 100


@dataclass(frozen=True)
class Trajectory3:
    """Target coordinates (K, 3) deg and their rates (K, 3) deg/s at frames 0, 1, ..., K-1."""

    angle_deg: np.ndarray
    velocity_deg_s: np.ndarray
    name: str = ""

    @property
    def frames(self) -> int:
        return len(self.angle_deg) - 1


def random_targets(rngs, split: str = "train") -> tuple[np.ndarray, np.ndarray]:
    """(angle_deg, velocity_deg_s), each (len(rngs), frames + 1, 3): one random target of `split` per generator.
    Each generator draws the end points of all three coordinates, segment by segment."""
    if split not in SPLITS:
        raise ValueError(f"unknown split {split!r}; choose one of {sorted(SPLITS)}")
    spec = SPLITS[split]
    lo, hi = np.array(spec["range_deg"]).T
    n_seg = int(round(spec["duration_s"] / SEGMENT_S))
    points = np.array([rng.uniform(lo, hi, size=(n_seg + 1, 3)) for rng in rngs])  # (N, segments + 1, 3)
    per_seg = int(round(SEGMENT_S / FRAME_S))
    s = np.arange(per_seg) * FRAME_S
    shape = quintic(s, 0.0, 1.0, SEGMENT_S)[0][None, None, :, None]
    start, end = points[:, :-1, None, :], points[:, 1:, None, :]
    angle = np.concatenate([(start + (end - start) * shape).reshape(len(rngs), -1, 3), points[:, -1:]], axis=1)
    return angle, np.gradient(angle, FRAME_S, axis=1)


def random_trajectory(rng: np.random.Generator, split: str = "train") -> Trajectory3:
    angle, velocity = random_targets([rng], split)
    return Trajectory3(angle[0], velocity[0], name=split)


def check_in_pose_space(a: np.ndarray, where: str, rows=None) -> None:
    """ValueError naming the row (or sample) and coordinate of the first value outside the pose space."""
    a = np.asarray(a, dtype=float).reshape(-1, 3)
    for k, c in enumerate(COORDINATES):
        lo, hi = POSE_RANGE_DEG[c]
        bad = np.flatnonzero(~np.isfinite(a[:, k]) | (a[:, k] < lo) | (a[:, k] > hi))
        if bad.size:
            i = bad[0]
            at = f"row {rows[i]}" if rows is not None else f"sample {i}"
            raise ValueError(f"{where}: {at}: {COLUMNS[k]} {a[i, k]:g} is not a finite number within the pose "
                             f"space [{lo:g}, {hi:g}] deg ({COORDINATE_LABELS[c]}); fix or drop that row")


def from_array(angle_deg, name: str = "array") -> Trajectory3:
    """A target given as (K, 3) degrees at the frame rate; velocity = central differences (as the 1-DOF one)."""
    a = np.asarray(angle_deg, dtype=float)
    if a.ndim != 2 or a.shape[1] != 3:
        raise ValueError(f"trajectory {name}: shape {a.shape}; give (frames, 3) degrees: plane, elevation, rotation")
    if len(a) < 2:
        raise ValueError(f"trajectory {name} has {len(a)} sample(s); give at least two frames (0.1 s apart)")
    check_in_pose_space(a, f"trajectory {name}")
    return Trajectory3(a, np.gradient(a, FRAME_S, axis=0), name=name)


def load_csv(path: Path | str) -> list[Trajectory3]:
    """Read `time_s,plane_deg,elevation_deg,rotation_deg[,trajectory]` and resample to 0.1 s frames."""
    return [from_array(a, name=name) for name, a in read_frames(Path(path), COLUMNS, check_in_pose_space)]


def csv_text(trajectories: list[Trajectory3]) -> bytes:
    """The bytes `write_csv` writes: `trajectory,time_s,plane_deg,elevation_deg,rotation_deg`, 1e-6 deg."""
    lines = ["trajectory,time_s," + ",".join(COLUMNS)]
    for k, tr in enumerate(trajectories):
        lines += [f"{k},{i * FRAME_S:.1f}," + ",".join(f"{x:.6f}" for x in row) for i, row in enumerate(tr.angle_deg)]
    return ("\n".join(lines) + "\n").encode()


def write_csv(path: Path | str, trajectories: list[Trajectory3]) -> None:
    path = Path(path)
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_bytes(csv_text(trajectories))
    tmp.replace(path)


def as_trajectory(spec) -> Trajectory3 | None:
    """None (random targets), a `Trajectory3`, an ADL name, a CSV path holding one, or (K, 3) degrees."""
    if spec is None or isinstance(spec, Trajectory3):
        return spec
    if isinstance(spec, str) and spec in ADL:
        return ADL[spec]()
    if isinstance(spec, str) or hasattr(spec, "__fspath__"):
        found = load_csv(spec)
        if len(found) != 1:
            raise ValueError(f"{spec} holds {len(found)} trajectories; a task tracks one")
        return found[0]
    return from_array(spec)


# --- synthetic activities of daily living (made up, not measured) ----------------------------------------------------
def _profile(name: str, duration_s: float, rest: tuple, moves: list) -> Trajectory3:
    """From `rest`, quintic moves (start s, end s, target (plane, elevation, rotation)) in order."""
    t = np.arange(0.0, duration_s + 1e-9, FRAME_S)
    angle = np.tile(np.array(rest, dtype=float), (len(t), 1))
    here = np.array(rest, dtype=float)
    for t0, t1, target in moves:
        seg = t >= t0
        for k in range(3):
            angle[seg, k] = quintic(t[seg] - t0, here[k], target[k], t1 - t0)[0]
        here = np.array(target, dtype=float)
    return from_array(angle, name=f"{name} (synthetic)")


def combing() -> Trajectory3:
    """SYNTHETIC: lift the arm forward-sideways and rotate externally to the head, comb with small rotation strokes,
    lower; twice. 20 s."""
    tr = _profile("combing", 20.0, (30, 20, 0), [(0.5, 3.0, (45, 95, -25)), (7.0, 9.5, (30, 25, 0)),
                                                   (10.5, 13.0, (45, 95, -25)), (17.0, 19.5, (30, 20, 0))])
    angle = tr.angle_deg.copy()
    t = np.arange(len(angle)) * FRAME_S
    for t0, t1 in ((3.0, 7.0), (13.0, 17.0)):
        up = (t >= t0) & (t <= t1)
        angle[up, 2] += 8.0 * np.sin(np.pi * (t[up] - t0) / (t1 - t0)) * np.sin(2 * np.pi * 1.0 * (t[up] - t0))
    return from_array(angle, name=tr.name)


def reach_back_of_head() -> Trajectory3:
    """SYNTHETIC: raise the hand to the back of the head (elevation ~110 deg in the scapular plane, external
    rotation 40 deg), hold, lower. 12 s."""
    return _profile("reach back of head", 12.0, (30, 20, 0), [(0.5, 4.0, (35, 110, -40)), (7.0, 10.5, (30, 20, 0))])


def reach_opposite_shoulder() -> Trajectory3:
    """SYNTHETIC: reach forward and across towards the other shoulder, as far as the pose space goes (the sagittal
    plane, 90 deg: a true cross-body reach lies beyond it), with internal rotation; hold; return. 12 s."""
    return _profile("reach opposite shoulder", 12.0, (30, 20, 0), [(0.5, 4.0, (90, 85, 45)), (7.0, 10.5, (30, 20, 0))])


def lift_to_shelf() -> Trajectory3:
    """SYNTHETIC: lift forward to a shelf at about shoulder height and above (flexion to 120 deg in a plane of 70
    deg), hold, lower. 12 s."""
    return _profile("lift to shelf", 12.0, (30, 20, 0), [(0.5, 4.5, (70, 120, 0)), (7.0, 11.0, (30, 20, 0))])


ADL = {"combing": combing, "reach_back_of_head": reach_back_of_head, "reach_opposite_shoulder": reach_opposite_shoulder,
       "lift_to_shelf": lift_to_shelf}


def test_set_path() -> Path:
    from importlib.resources import files

    return Path(str(files("shoulder_bench.eval") / "data" / "test_set_3dof.csv"))


def make_test_set() -> list[Trajectory3]:
    """The fixed 3-DOF test set, generated from TEST_SET_SEED (what `eval/data/test_set_3dof.csv` stores)."""
    rng = np.random.default_rng(TEST_SET_SEED)
    return [random_trajectory(rng, "test") for _ in range(TEST_SET_SIZE)]


def load_test_set() -> list[Trajectory3]:
    """The 100 stored 3-DOF test trajectories, after checking the file against its recorded SHA-256."""
    path = checked(test_set_path(), "shoulder_bench.trajectory3")
    return [Trajectory3(t.angle_deg, t.velocity_deg_s, name=f"test3:{k}") for k, t in enumerate(load_csv(path))]


if __name__ == "__main__":
    p = test_set_path()
    write_csv(p, make_test_set())
    p.with_suffix(".sha256").write_text(hashlib.sha256(p.read_bytes()).hexdigest() + "  test_set_3dof.csv\n")
    print(p)
