"""Named evaluation suites (issue 14 §2): fixed, checksummed trajectory sets in `eval/data/`.

  paper  the paper's 100 test trajectories (`test_set.csv`, seed 20201): 20 s, 5 s quintic segments, U[20, 100] deg
  fast   100 x 20 s, quintic segments of 2-3 s (whole frames, drawn uniformly) instead of 5 s, end points
         U[20, 100] deg; seed 20202
  wide   100 x 20 s, 5 s segments, end points U[5, 150] deg over the arm's reachable range; seed 20203. The joint
         range is 0-180 deg, but the four muscles statically hold the arm only up to about 160 deg
         (`benchmarks/feasibility.py`); 5-150 deg keeps a margin from both ends
  adl    the synthetic combing profile (`shoulder_bench.trajectory.combing`; made up, not measured), 1 x 17.5 s
  robust the paper's 100 test trajectories (`test_set.csv`, the paper set's SHA-256) under the task options
         OPTIONS["robust"]: delay_frames=1, obs_noise_deg=0.5 and randomize with muscle strength x U[0.8, 1.2] per
         muscle, a hand load of exactly 1 kg at the elbow and the humerus mass not randomised

The 3-DOF tasks take fast, adl and robust in three dimensions (`SUITES3`, `load_suite(spec, task)`; below).

Training stays on the paper's distribution, so every suite but `paper` measures generalisation. Any other value of
`--suite` is a folder of CSV files (every *.csv, sorted by name): a hidden suite a user supplies.

A suite's task options (`options_for`) go on top of the options a policy was trained with (its row's): they are the
suite's fixed conditions, so every row is scored under the same ones. A policy trained with one of them at the
suite's value (delay_frames=1 on `robust`) is evaluated at that value (not twice the delay); one trained with it at
another non-default value (delay_frames=2, obs_noise_deg=1, another randomize) is refused with an error naming the
option, as is an `--option` that sets one: the suite would no longer be its fixed conditions, nor the policy's. The
draws are seeded: `evaluate` runs trajectory k with the evaluation's seed + k (default 0), so its randomised arm
and its observation noise are fixed and two evaluations of one policy agree exactly. The reference controller plans
with the nominal arm (it is told no draw) and sees the delayed, noisy observation like any policy.

The files are generated once, deterministically, by `python -m shoulder_bench.eval.suites --write`; loading checks
each file against the SHA-256 recorded in SHA256 below (tests regenerate them and compare).
"""
from __future__ import annotations

import hashlib
import io
from pathlib import Path

import numpy as np

from shoulder_bench.trajectory import (
    FRAME_S,
    TEST_SET_SEED,
    Trajectory,
    combing,
    from_array,
    load_csv,
    make_test_set,
    quintic,
    write_csv,
)

DURATION_FRAMES = 200  # 20 s
SUITE_SIZE = 100
FAST_SEED, WIDE_SEED = TEST_SET_SEED + 1, TEST_SET_SEED + 2  # 20202, 20203: distinct from the paper set's
FAST_SEGMENT_FRAMES = (20, 30)  # 2-3 s
WIDE_RANGE_DEG = (5.0, 150.0)
FILES = {"paper": "test_set.csv", "fast": "suite_fast.csv", "wide": "suite_wide.csv", "adl": "suite_adl.csv",
         "robust": "test_set.csv"}
SHA256 = {"paper": "20fac61e28e966c13fdb67c70d2ce89cbde4a82a6aba3dd0b7bd47569aed1126",
          "fast": "d18285362021852ec750c28c42634816fb009a91d84469bc4e84b7b75ce0e841",
          "wide": "963de7ef91d1439ea5ae151bd5ee400e504094313d2f81e4adb61dd555a5b839",
          "adl": "6a8da9b845253198a3a91bda4e73e78e9f2bf43150cc5e154a0e51e9dd5c05d3"}
SHA256["robust"] = SHA256["paper"]  # the paper set's file, under the options below
SUITES = tuple(FILES)
# the task options a suite evaluates under, on top of a policy's own (`options_for`); suites not named: none
OPTIONS = {"robust": {"delay_frames": 1, "obs_noise_deg": 0.5,
                      "randomize": {"strength": 0.2, "mass": 0.0, "load": (1.0, 1.0)}}}

# the 3-DOF tasks' suites (issue 12 §4), the same names in three dimensions: on track_3dof and track_3dof_discrete
#   fast   100 x 20 s, 2-3 s quintic segments (FAST_SEGMENT_FRAMES) in all three coordinates at once, end points
#          uniform in the 3-DOF test ranges (trajectory3.SPLITS["test"]); seed 20213
#   adl    the four synthetic activities of daily living (trajectory3.ADL; made up, not measured)
#   robust the 3-DOF test set (test_set_3dof.csv) under OPTIONS["robust"], the 1-DOF robust's conditions (the 13
#          muscles' strengths drawn, a 1 kg load at the elbow, the delay and the noise)
# elevate_scapular_plane_12m tracks 1-DOF elevations: its suites are the 1-DOF ones in SCAPULAR (wide's 5-150 deg leave
# the pose space's 140), in the scapular plane at rotation 0 (track3d.scapular)
FAST3_SEED = 20213  # trajectory3.TEST_SET_SEED + 1
FILES3 = {"fast": "suite_fast_3dof.csv", "adl": "suite_adl_3dof.csv", "robust": "test_set_3dof.csv"}
SHA256_3 = {"fast": "6e11cd451b0059edbd638e5c3ef2fd3f629035a44de0f36a16bc78cfc47da9c5",
            "adl": "cba2bab1b03f14be166408054412e22da9646d12e2e883009411fafd2f4696d9",
            "robust": "1c9fd160a248fa3f3270a3bdf62059450ed2ae04553b1a3894425220934b2673"}
SUITES3 = tuple(FILES3)
SCAPULAR = ("paper", "fast", "adl", "robust")


def kind(task: str | None) -> str:
    """Which suites `task` takes: "1dof" (the 1-DOF tasks; also no task), "3dof" (SUITES3) or "scapular" (the
    1-DOF ones in the scapular plane)."""
    from shoulder_bench.tasks import TASKS_3DOF, is_3dof

    if task is None or not is_3dof(task):
        return "1dof"
    return "scapular" if TASKS_3DOF[task][2].get("workspace") == "scapular_plane" else "3dof"


def names(task: str | None = None) -> tuple[str, ...]:
    """The named suites `task` takes."""
    return {"1dof": SUITES, "3dof": SUITES3, "scapular": SCAPULAR}[kind(task)]


def segment_angles(points, seg_frames) -> np.ndarray:
    """Rest-to-rest quintic segments through `points` (deg; (K + 1,) or, per coordinate, (K + 1, 3)), segment k
    lasting seg_frames[k] frames: the angles per frame."""
    points = np.asarray(points, dtype=float)
    per = points.reshape(len(points), -1)  # (K + 1, coordinates)
    pos = [np.stack([quintic(np.arange(n) * FRAME_S, per[k, c], per[k + 1, c], n * FRAME_S)[0]
                     for c in range(per.shape[1])], axis=1) for k, n in enumerate(seg_frames)]
    return np.concatenate(pos + [per[-1:]]).reshape((-1,) + points.shape[1:])


def segmented(points, seg_frames, name: str) -> Trajectory:
    """A 1-DOF trajectory of `segment_angles`."""
    return from_array(segment_angles(points, seg_frames), name=name)


def fast_segments(rng: np.random.Generator, total: int = DURATION_FRAMES) -> list[int]:
    """Segment lengths in frames, each in FAST_SEGMENT_FRAMES, summing to `total`; every draw leaves a remainder
    that whole 2-3 s segments can still fill."""
    lo, hi = FAST_SEGMENT_FRAMES
    out, left = [], total
    while left > hi:
        ok = [d for d in range(lo, hi + 1) if lo <= left - d <= hi or left - d >= 2 * lo]
        out.append(int(rng.choice(ok)))
        left -= out[-1]
    return out + [left]


def fast_plan() -> list[tuple[np.ndarray, list[int]]]:
    """(end points, segment frames) of each `fast` trajectory, from FAST_SEED."""
    rng = np.random.default_rng(FAST_SEED)
    plan = []
    for _ in range(SUITE_SIZE):
        seg = fast_segments(rng)
        plan.append((rng.uniform(20.0, 100.0, size=len(seg) + 1), seg))
    return plan


def generate(name: str) -> list[Trajectory]:
    """The suite `name` computed from its definition (what its file stores, before rounding to 1e-6 deg)."""
    if name == "paper":
        return make_test_set()
    if name == "fast":
        return [segmented(p, s, "fast") for p, s in fast_plan()]
    if name == "wide":
        rng = np.random.default_rng(WIDE_SEED)
        return [segmented(rng.uniform(*WIDE_RANGE_DEG, size=5), [50] * 4, "wide") for _ in range(SUITE_SIZE)]
    if name == "adl":
        return [combing()]
    if name == "robust":
        return make_test_set()
    raise ValueError(f"unknown suite {name!r}; choose one of {', '.join(SUITES)} or give a folder of CSV files")


def generate3(name: str) -> list:
    """The 3-DOF suite `name` computed from its definition (`trajectory3.Trajectory3`s)."""
    from shoulder_bench import trajectory3

    if name == "fast":
        rng = np.random.default_rng(FAST3_SEED)
        lo, hi = np.array(trajectory3.SPLITS["test"]["range_deg"]).T
        out = []
        for _ in range(SUITE_SIZE):
            seg = fast_segments(rng)
            out.append(trajectory3.from_array(segment_angles(rng.uniform(lo, hi, size=(len(seg) + 1, 3)), seg),
                                              name="fast"))
        return out
    if name == "adl":
        return [profile() for profile in trajectory3.ADL.values()]
    if name == "robust":
        return trajectory3.make_test_set()
    raise ValueError(f"unknown 3-DOF suite {name!r}; choose one of {', '.join(SUITES3)} or give a folder of 3-DOF "
                     f"CSV files")


def csv_text(trajectories: list[Trajectory]) -> bytes:
    """The bytes `write_csv` writes for these trajectories."""
    buf = io.StringIO()
    buf.write("trajectory,time_s,angle_deg\n")
    for k, tr in enumerate(trajectories):
        for i, a in enumerate(tr.angle_deg):
            buf.write(f"{k},{i * FRAME_S:.1f},{a:.6f}\n")
    return buf.getvalue().encode()


def data_dir() -> Path:
    from importlib.resources import files

    return Path(str(files("shoulder_bench.eval") / "data"))


def suite_path(name: str, three: bool = False) -> Path:
    """A named suite's file (`three`: the 3-DOF tasks' suite of that name)."""
    files = FILES3 if three else FILES
    if name not in files:
        (generate3 if three else generate)(name)  # the error listing the suites
    return data_dir() / files[name]


def load_suite(spec: str, task: str | None = None) -> list:
    """A named suite, checked against its recorded SHA-256, or every *.csv of a folder (a hidden suite), for `task`
    (default a 1-DOF one): 1-DOF `Trajectory`s, or on a 3-DOF task `trajectory3.Trajectory3`s (`kind`)."""
    from shoulder_bench import trajectory3

    where = kind(task)
    if where == "scapular":
        from shoulder_bench.tasks.track3d import scapular

        if spec in FILES and spec not in SCAPULAR:
            raise ValueError(f"--suite {spec}: {task} takes the 1-DOF suites {', '.join(SCAPULAR)} (in the scapular "
                             f"plane) or a folder of 1-DOF CSV files; {spec}'s elevations leave its pose space")
        return [scapular(t.angle_deg, name=t.name) for t in load_suite(spec)]
    three = where == "3dof"
    if spec not in (FILES3 if three else FILES):
        folder = Path(spec)
        if not folder.is_dir():
            raise ValueError(f"--suite {spec}: not a suite name ({', '.join(names(task))}) nor a folder of "
                             f"{'3-DOF ' if three else ''}CSV files")
        paths = sorted(folder.glob("*.csv"))
        if not paths:
            raise ValueError(f"--suite {spec}: the folder holds no *.csv files")
        return [t for p in paths for t in (trajectory3.load_csv(p) if three else load_csv(p))]
    path = suite_path(spec, three)
    actual, recorded = hashlib.sha256(path.read_bytes()).hexdigest(), (SHA256_3 if three else SHA256)[spec]
    if actual != recorded:
        raise ValueError(f"{path} does not match its recorded checksum ({actual} != {recorded}); restore it "
                         f"from the repo or regenerate it with `python -m shoulder_bench.eval.suites --write`")
    if three:
        return [trajectory3.Trajectory3(t.angle_deg, t.velocity_deg_s, name=f"{spec}:{k}")
                for k, t in enumerate(trajectory3.load_csv(path))]
    return [Trajectory(t.angle_deg, t.velocity_deg_s, name=f"{spec}:{k}") for k, t in enumerate(load_csv(path))]


def suite_options(spec: str) -> dict:
    """The task options suite `spec` evaluates under, 1-DOF or 3-DOF (a copy; {} for a suite without any, or a
    folder)."""
    import copy

    return copy.deepcopy(OPTIONS.get(spec, {}))


def _normal(key: str, value):
    """An option's value in a form that compares (randomize's spec checked and filled in; numbers as floats)."""
    from shoulder_bench import randomization

    if key == "randomize":
        return randomization.option(value)
    return None if value is None else float(value)


def options_for(spec: str, options: dict | None, who: str = "the policy") -> dict:
    """`options` (a policy's own, and any --option) with suite `spec`'s on top: an option `options` leaves out or
    sets to its default or to the suite's value takes the suite's; another value is a ValueError naming it (the
    suite's conditions are fixed, so it would no longer be the suite, nor what the policy was trained for)."""
    from shoulder_bench.tasks.options import DEFAULTS

    own = dict(options or {})
    fixed = suite_options(spec)
    for key, value in fixed.items():
        if key in own and _normal(key, own[key]) not in (_normal(key, value), _normal(key, DEFAULTS[key])):
            raise ValueError(f"suite {spec} evaluates under {key}={value!r} (on top of a policy's own options), but "
                             f"{who} sets {key}={own[key]!r}; a suite's conditions are fixed: evaluate it on "
                             f"another suite with --option {key}=..., or train it with {key}={value!r} or without")
    return own | fixed


def note(specs, three: bool = False) -> str:
    """A sentence per suite of `specs` that has task options, saying what they are (for a board's notes; `three`:
    the 3-DOF board's)."""
    test = "each task's test set" if three else "the paper test set"
    return "".join(f" Suite {s}: {test} under {', '.join(f'{k}={v!r}' for k, v in OPTIONS[s].items())} "
                   f"(eval/suites.py OPTIONS), on top of each row's own options, trajectory k seeded k; the "
                   f"reference controller plans with the nominal arm." for s in dict.fromkeys(specs or ())
                   if s in OPTIONS)


def write() -> None:
    """Write the files of the generated suites, 1-DOF and 3-DOF (not the test sets, nor a suite sharing a test set's
    file: `python -m shoulder_bench.trajectory` and `python -m shoulder_bench.trajectory3` write those)."""
    from shoulder_bench import trajectory3

    for name in SUITES:
        if FILES[name] != FILES["paper"]:
            write_csv(suite_path(name), generate(name))
        print(f"{name}: {suite_path(name)} sha256 {hashlib.sha256(suite_path(name).read_bytes()).hexdigest()}")
    for name in SUITES3:  # the 3-DOF ones; robust's file is the 3-DOF test set (`python -m shoulder_bench.trajectory3`)
        path = suite_path(name, three=True)
        if path != trajectory3.test_set_path():
            trajectory3.write_csv(path, generate3(name))
        print(f"{name} (3-DOF): {path} sha256 {hashlib.sha256(path.read_bytes()).hexdigest()}")


if __name__ == "__main__":
    import sys

    if sys.argv[1:] != ["--write"]:
        sys.exit("usage: python -m shoulder_bench.eval.suites --write")
    write()
