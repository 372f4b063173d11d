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


def segmented(points, seg_frames, name: str) -> Trajectory:
    """Rest-to-rest quintic segments through `points` (deg), segment k lasting seg_frames[k] frames."""
    pos = []
    for k, n in enumerate(seg_frames):
        pos.append(quintic(np.arange(n) * FRAME_S, points[k], points[k + 1], n * FRAME_S)[0])
    return from_array(np.concatenate(pos + [[points[-1]]]), name=name)


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


def suite_path(name: str) -> Path:
    if name not in FILES:
        generate(name)  # the error listing the suites
    return data_dir() / FILES[name]


def load_suite(spec: str) -> list[Trajectory]:
    """A named suite, checked against its recorded SHA-256, or every *.csv of a folder (a hidden suite)."""
    if spec not in FILES:
        folder = Path(spec)
        if not folder.is_dir():
            raise ValueError(f"--suite {spec}: not a suite name ({', '.join(SUITES)}) nor a folder of CSV files")
        paths = sorted(folder.glob("*.csv"))
        if not paths:
            raise ValueError(f"--suite {spec}: the folder holds no *.csv files")
        return [t for p in paths for t in load_csv(p)]
    path = suite_path(spec)
    actual = hashlib.sha256(path.read_bytes()).hexdigest()
    if actual != SHA256[spec]:
        raise ValueError(f"{path} does not match its recorded checksum ({actual} != {SHA256[spec]}); restore it "
                         f"from the repo or regenerate it with `python -m shoulder_bench.eval.suites --write`")
    return [Trajectory(t.angle_deg, t.velocity_deg_s, name=f"{spec}:{k}") for k, t in enumerate(load_csv(path))]


def suite_options(spec: str) -> dict:
    """The task options suite `spec` evaluates under (a copy; {} for a suite without any, or a folder)."""
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


def note(specs) -> str:
    """A sentence per suite of `specs` that has task options, saying what they are (for a board's notes)."""
    return "".join(f" Suite {s}: the paper test set under {', '.join(f'{k}={v!r}' for k, v in OPTIONS[s].items())} "
                   f"(eval/suites.py OPTIONS), on top of each row's own options, trajectory k seeded k; the "
                   f"reference controller plans with the nominal arm." for s in dict.fromkeys(specs or ())
                   if s in OPTIONS)


def write() -> None:
    """Write the files of the generated suites (not `paper` nor a suite sharing its file: `python -m
    shoulder_bench.trajectory` writes that)."""
    for name in SUITES:
        if FILES[name] != FILES["paper"]:
            write_csv(suite_path(name), generate(name))
        print(f"{name}: {suite_path(name)} sha256 {hashlib.sha256(suite_path(name).read_bytes()).hexdigest()}")


if __name__ == "__main__":
    import sys

    if sys.argv[1:] != ["--write"]:
        sys.exit("usage: python -m shoulder_bench.eval.suites --write")
    write()
