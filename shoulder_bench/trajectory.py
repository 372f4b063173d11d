"""Target trajectories: the paper's random quintic segments, user CSV files and the fixed test set.

The paper (section "Experiments"): 5 s segments of 5th-order polynomials with zero velocity and acceleration at both
ends, stacked so the end of one is the start of the next; end points uniform in [30, 90] deg for training and
[20, 100] deg for testing; 10 s training episodes, 20 s test trajectories, sampled at the 0.1 s frame rate.
"""
from __future__ import annotations

import csv
import hashlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from shoulder_bench.arm import RANGE_DEG as JOINT_RANGE_DEG

FRAME_S = 0.1
SEGMENT_S = 5.0
SPLITS = {"train": {"duration_s": 10.0, "range_deg": (30.0, 90.0)},
          "test": {"duration_s": 20.0, "range_deg": (20.0, 100.0)}}
TEST_SET_SEED = 20201  # the fixed test set: 100 test trajectories drawn once with this seed
TEST_SET_SIZE = 100


@dataclass(frozen=True)
class Trajectory:
    """Target angle and angular velocity at frames 0, 1, ..., K-1 (0.1 s apart), in degrees and deg/s."""

    angle_deg: np.ndarray
    velocity_deg_s: np.ndarray
    name: str = ""

    @property
    def frames(self) -> int:
        """Number of control steps an episode on this target takes (one fewer than samples)."""
        return len(self.angle_deg) - 1


def quintic(t: np.ndarray, start: float, end: float, duration: float) -> tuple[np.ndarray, np.ndarray]:
    """Rest-to-rest 5th-order polynomial: position and velocity at times t in [0, duration]."""
    s = np.clip(t / duration, 0.0, 1.0)
    pos = start + (end - start) * (10 * s**3 - 15 * s**4 + 6 * s**5)
    vel = (end - start) * (30 * s**2 - 60 * s**3 + 30 * s**4) / duration
    return pos, vel


def random_trajectory(rng: np.random.Generator, split: str = "train") -> Trajectory:
    """Stacked random quintic segments for `split` ("train" or "test"), drawn from `rng`."""
    angle, velocity = random_targets([rng], split)
    return Trajectory(angle[0], velocity[0], name=split)


def random_targets(rngs, split: str = "train") -> tuple[np.ndarray, np.ndarray]:
    """(angle_deg, velocity_deg_s), each (len(rngs), frames + 1): one random trajectory of `split` per generator,
    drawn from it exactly as `random_trajectory(rng, split)` draws it, computed for all at once (the batched env's
    resets). Velocity is the central difference of the samples, as `from_array`'s."""
    if split not in SPLITS:
        raise ValueError(f"unknown split {split!r}; choose one of {sorted(SPLITS)}")
    spec = SPLITS[split]
    lo, hi = spec["range_deg"]
    n_seg = int(round(spec["duration_s"] / SEGMENT_S))
    points = np.array([rng.uniform(lo, hi, size=n_seg + 1) for rng in rngs]).reshape(len(rngs), n_seg + 1)
    per_seg = int(round(SEGMENT_S / FRAME_S))
    s = np.clip(np.arange(per_seg) * FRAME_S / SEGMENT_S, 0.0, 1.0)
    shape = 10 * s**3 - 15 * s**4 + 6 * s**5  # quintic()'s rest-to-rest profile
    start, end = points[:, :-1, None], points[:, 1:, None]
    angle = np.concatenate([(start + (end - start) * shape).reshape(len(rngs), -1), points[:, -1:]], axis=1)
    return angle, np.gradient(angle, FRAME_S, axis=1)


def from_array(angle_deg, name: str = "array") -> Trajectory:
    """A target given as degrees at the frame rate. Its velocity is always the central difference of the samples
    (one definition for generated, CSV and array targets)."""
    a = np.asarray(angle_deg, dtype=float).ravel()
    _check_angles(a, name, rows=None)
    if len(a) < 2:
        raise ValueError(f"trajectory {name} has {len(a)} sample(s); give at least two frames (0.1 s apart)")
    return Trajectory(a, np.gradient(a, FRAME_S), name=name)


def _check_angles(a: np.ndarray, where: str, rows) -> None:
    lo, hi = JOINT_RANGE_DEG
    bad = np.flatnonzero(~np.isfinite(a) | (a < lo) | (a > hi))
    if bad.size:
        k = bad[0]
        row = f" row {rows[k]}" if rows is not None else f" sample {k}"
        raise ValueError(f"{where}:{row}: angle {float(a[k]):g} deg is not a finite number within the model's range "
                         f"[{lo:g}, {hi:g}] deg; fix or drop that row")


def load_csv(path: Path | str) -> list[Trajectory]:
    """Read `time_s,angle_deg[,trajectory]` (any sampling rate) and resample each trajectory to 0.1 s frames.

    UTF-8 with or without a byte-order mark (Excel's "CSV UTF-8"); spaces around header names and values are ignored.
    """
    path = Path(path)
    return [from_array(a, name=name) for name, a in read_frames(path, ("angle_deg",), _check_angles)]


def read_frames(path: Path, values: tuple[str, ...], check) -> list[tuple[str, np.ndarray]]:
    """Each trajectory of a CSV file as (name, values at 0.1 s frames), (K,) for one value column, (K, C) for more:
    the file, header, rows and times checked (errors name the file and row), `check(values, where, rows)` for the
    values, then linear resampling to the frame rate. The 1-DOF and 3-DOF loaders' one reader."""
    if not path.exists():
        raise ValueError(f"trajectory file {path} does not exist")
    if path.is_dir():
        raise ValueError(f"trajectory path {path} is a directory, not a CSV file; give the file itself")
    try:
        groups = _read_rows(path, values)
    except UnicodeDecodeError as exc:
        raise ValueError(f"{path}: not UTF-8 text ({exc.reason} at byte {exc.start}); save it as UTF-8 CSV "
                         f"(Excel: \"CSV UTF-8\")") from None
    except csv.Error as exc:
        raise ValueError(f"{path}: not a readable CSV file ({exc})") from None
    if not groups:
        raise ValueError(f"{path}: no data rows below the header")
    out = []
    for key, (t, a, rows) in groups.items():
        t, a = np.array(t), np.array(a)
        where = f"{path}" + (f" (trajectory {key})" if len(groups) > 1 else "")
        bad_t = np.flatnonzero(~np.isfinite(t))
        if bad_t.size:
            raise ValueError(f"{where}: row {rows[bad_t[0]]}: time_s is not finite; fix that row")
        check(a, where, rows)
        steps = np.flatnonzero(np.diff(t) <= 0)
        if steps.size:
            raise ValueError(f"{where}: row {rows[steps[0] + 1]}: time_s {t[steps[0] + 1]:g} does not increase "
                             f"(previous row {t[steps[0]]:g}); sort the rows by time and remove duplicates")
        frames = np.arange(0.0, t[-1] - t[0] + 1e-9, FRAME_S)
        if len(frames) < 2:
            raise ValueError(f"{where}: spans {t[-1] - t[0]:g} s; a trajectory needs at least 0.1 s (two frames)")
        cols = a.reshape(len(t), -1)
        resampled = np.stack([np.interp(frames + t[0], t, cols[:, c]) for c in range(cols.shape[1])], axis=1)
        out.append((f"{path.name}:{key}", resampled[:, 0] if a.ndim == 1 else resampled))
    return out


def _read_rows(path: Path, values=("angle_deg",)) -> dict[str, tuple[list, list, list]]:
    """(times, value rows, CSV row numbers) per trajectory key; ValueError naming the file for a bad header or row.
    `values`: the value columns (1-DOF: angle_deg; 3-DOF: plane_deg, elevation_deg, rotation_deg); a value row is
    one float for a single column, else a list of them."""
    with path.open(newline="", encoding="utf-8-sig") as f:
        reader = csv.reader(f)
        cols = [c.strip() for c in next(reader, [])]
        missing = [c for c in ("time_s", *values) if c not in cols]
        if missing:
            raise ValueError(f"{path}: missing column(s) {missing} (found {cols}); the header must be "
                             f"`time_s,{','.join(values)}` with an optional `trajectory` column")
        it, iv = cols.index("time_s"), [cols.index(c) for c in values]
        ik = cols.index("trajectory") if "trajectory" in cols else None
        groups: dict[str, tuple[list, list, list]] = {}
        for row_no, row in enumerate(reader, start=2):
            row = [c.strip() for c in row] + [""] * len(cols)  # short rows read as empty cells
            if not any(row):
                continue  # a blank line
            g = groups.setdefault((row[ik] if ik is not None else "") or "0", ([], [], []))
            try:
                t, v = float(row[it]), [float(row[i]) for i in iv]
            except ValueError:
                cells = ", ".join(f"{c}={row[i]!r}" for c, i in zip(("time_s", *values), (it, *iv)))
                raise ValueError(f"{path}: row {row_no}: {cells} are not numbers; fix that row") from None
            g[0].append(t)
            g[1].append(v[0] if len(v) == 1 else v)
            g[2].append(row_no)
    return groups


def write_csv(path: Path | str, trajectories: list[Trajectory]) -> None:
    """Write trajectories (at the frame rate) in the CSV format `load_csv` reads; atomic."""
    path = Path(path)
    tmp = path.with_suffix(path.suffix + ".tmp")
    with tmp.open("w", newline="") as f:
        f.write("trajectory,time_s,angle_deg\n")
        for k, tr in enumerate(trajectories):
            for i, a in enumerate(tr.angle_deg):
                f.write(f"{k},{i * FRAME_S:.1f},{a:.6f}\n")
    tmp.replace(path)


def combing() -> Trajectory:
    """SYNTHETIC activity-of-daily-living profile in the spirit of the paper's in-vivo "combing" recording (Bolsterlee
    2014, not public): 17.5 s, two lifts from 20 deg to about 100 deg with small combing strokes (+-4 deg, 1.25 Hz)
    while up. It is made up, not measured; results on it are labelled synthetic."""
    t = np.arange(0.0, 17.5 + 1e-9, FRAME_S)
    # (start s, end s, from deg, to deg): rest, lift, hold (strokes), lower, rest, lift, hold (strokes), lower
    moves = [(0.5, 3.0, 20.0, 98.0), (6.5, 9.0, 98.0, 25.0), (9.5, 12.0, 25.0, 98.0), (15.0, 17.5, 98.0, 20.0)]
    angle = np.full_like(t, 20.0)
    for t0, t1, a0, a1 in moves:
        seg = t >= t0
        angle[seg] = quintic(t[seg] - t0, a0, a1, t1 - t0)[0]
    for t0, t1 in ((3.0, 6.5), (12.0, 15.0)):  # combing strokes while the arm is up, faded in and out
        up = (t >= t0) & (t <= t1)
        fade = np.sin(np.pi * (t[up] - t0) / (t1 - t0))
        angle[up] += 4.0 * fade * np.sin(2 * np.pi * 1.25 * (t[up] - t0))
    return from_array(angle, name="combing (synthetic)")


def test_set_path() -> Path:
    from importlib.resources import files

    return Path(str(files("shoulder_bench.eval") / "data" / "test_set.csv"))


def make_test_set() -> list[Trajectory]:
    """The fixed test set, generated from TEST_SET_SEED (what `eval/data/test_set.csv` stores)."""
    rng = np.random.default_rng(TEST_SET_SEED)
    return [random_trajectory(rng, "test") for _ in range(TEST_SET_SIZE)]


def checked(path: Path, module: str) -> Path:
    """`path` after checking it against its recorded SHA-256 (`<path stem>.sha256` beside it); ValueError naming
    the `module` that regenerates it otherwise."""
    expected = path.with_suffix(".sha256").read_text().split()[0]
    actual = hashlib.sha256(path.read_bytes()).hexdigest()
    if actual != expected:
        raise ValueError(f"{path} does not match its checksum ({actual} != {expected}); restore it from the repo "
                         f"or regenerate it with `python -m {module}`")
    return path


def load_test_set() -> list[Trajectory]:
    """The 100 stored test trajectories, after checking the file against its recorded SHA-256."""
    path = checked(test_set_path(), "shoulder_bench.trajectory")
    return [Trajectory(t.angle_deg, t.velocity_deg_s, name=f"test:{k}") for k, t in enumerate(load_csv(path))]


def as_trajectory(spec) -> Trajectory | None:
    """What a task tracks: None (random targets), a `Trajectory`, a CSV path holding one, or degrees at 0.1 s."""
    if spec is None or isinstance(spec, Trajectory):
        return spec
    if isinstance(spec, str) or hasattr(spec, "__fspath__"):
        found = load_csv(spec)
        if len(found) != 1:
            raise ValueError(f"{spec} holds {len(found)} trajectories; a task tracks one (pick one with "
                             f"shoulder_bench.trajectory.load_csv(path)[k])")
        return found[0]
    return from_array(spec)


if __name__ == "__main__":
    p = test_set_path()
    p.parent.mkdir(parents=True, exist_ok=True)
    write_csv(p, make_test_set())
    p.with_suffix(".sha256").write_text(hashlib.sha256(p.read_bytes()).hexdigest() + "  test_set.csv\n")
    print(p)
