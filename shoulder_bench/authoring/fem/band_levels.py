"""The band's line of action below a = 1, tabled (issue 12 §2; docs/fem.md "The activation tabled"): built by
`shoulder-bench fem build --bands` after the band tables (`bands.py`), for the tendons in LEVEL_TENDONS.

The band tables hold the taut band's line at a = 1. Below it the line moves (the band taken down level by level,
`footprint_compare.continued`), by up to 1.4 mm at 30 sampled poses, and for tma that move put 4 of 100 held-out
poses over the 2 % bound at a = 0.5 where a = 1 passes (`fem verify --bands --activation`; docs/fem.md). So
for those tendons a level table holds the band's arms at a = 1 and at LEVELS below, on the tasks' grid (840 poses;
what is exploited: the move is smooth in the pose, so the tasks' step is enough where the line itself needs a finer
one, which the verify below a = 1 checks at the table's held-out poses; where the equilibrium the rule keeps changes
branch between grid poses it jumps, and there the table misses, docs/fem.md); MuJoCo reads the correction at
activation a as the band table's plus (arms(a) - arms(1)) from this one, trilinear in the pose and linear in a
(`band_lines.BandLines`).

The a = 1 equilibrium is the band table's rule (`bands.solve_poses`), so at each grid pose its arms are the band
table's; where the continuation finds no equilibrium at a level, the level's move from a = 1 there is the mean of its
solved neighbours' (as the band tables' unsolved poses; at most `bands.MAX_UNSOLVED` of the grid at each level).
Cached by input hash (the band table's inputs on the tasks' grid, the levels, CODE_VERSION), written atomically,
resumable (the poses solved so far saved every `bands.SAVE_EVERY` beside the table), folder-locked, with a progress
bar.
"""
from __future__ import annotations

import hashlib
import json
import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

from shoulder_bench.authoring.fem import bands
from shoulder_bench.authoring.fem.full import locked_folder
from shoulder_bench.authoring.fem.material import Material
from shoulder_bench.band_lines import AXES, levels_path, read_levels, read_table, table_path
from shoulder_bench.muscle import replacing

CODE_VERSION = "fem-band-levels-1"  # bump when a change alters the level tables; part of their input hash
LEVELS = (0.75, 0.5, 0.25)  # below a = 1, descending in equal steps (`band_lines` reads them linearly)
# tma: the one tendon whose verify below a = 1 missed where a = 1 passes (docs/fem.md "The verify below a = 1"); ssp,
# tmi and pec1 pass at every level over all their held-out poses without one, isp misses only at its corner
LEVEL_TENDONS = ("tma",)
SOLVED = ("fem_m", "fem_m_at", "converged")  # what a level table keeps of `bands.solve_poses` per pose


def input_hash(tendon: str, resolution: str, material: Material) -> str:
    blob = json.dumps({"band": bands.input_hash(tendon, resolution, material, bands.axes()), "levels": LEVELS,
                       "code_version": CODE_VERSION}, sort_keys=True)
    return hashlib.sha256(blob.encode()).hexdigest()


def partial_path(tendon: str, folder: Path) -> Path:
    return folder / f"{tendon}_band_levels.partial.npz"


def build(tendons=LEVEL_TENDONS, coarse: bool = False, out: Path | None = None, jobs: int = 1,
          quiet: bool = False) -> dict[str, dict]:
    """Build (or reuse) the level table of each of `tendons` in LEVEL_TENDONS, beside its band table in `out`
    (default models/muscles_full), `jobs` processes solving its poses. Returns {tendon: meta + cached}."""
    resolution, material, result = "coarse" if coarse else "full", Material(), {}
    with locked_folder(out, coarse, jobs, "band level tables") as folder:
        for t in (t for t in tendons if t in LEVEL_TENDONS):
            band_meta = read_table(table_path(t, folder))[1]
            digest = input_hash(t, resolution, material)
            try:
                meta = read_levels(levels_path(t, folder), band_meta)[1]
            except ValueError:  # missing, unreadable or made for another band table: solve it
                meta = {}
            if meta.get("input_hash") == digest:
                result[t] = dict(meta, cached=True)
                continue
            t0, poses, partial = time.perf_counter(), bands.grid_poses(), partial_path(t, folder)
            known = bands.resumed(partial, digest, SOLVED)
            with tqdm(total=len(poses), initial=0 if known is None else len(known["fem_m"]), unit="pose",
                      desc=f"fem band levels {t}", disable=quiet) as bar:
                solved = _solve(t, poses, resolution, bar.update, int(jobs), known,
                                lambda k, p=partial, d=digest: bands.save_partial(p, d, k, SOLVED))
            meta = _write(folder, t, solved, digest, band_meta, resolution, time.perf_counter() - t0,
                          0 if known is None else len(known["fem_m"]))
            partial.unlink(missing_ok=True)
            result[t] = dict(meta, cached=False)
    return result


def _solve(tendon: str, poses: np.ndarray, resolution: str, progress, jobs: int, known: dict | None, save) -> dict:
    """SOLVED of `poses` in blocks of SAVE_EVERY, continuing `known` (the first poses, solved before an interrupt);
    save(the poses solved so far) after each block."""
    parts = [] if known is None else [known]
    for i in range(0 if known is None else len(known["fem_m"]), len(poses), bands.SAVE_EVERY):
        s = bands.solve_poses(tendon, poses[i:i + bands.SAVE_EVERY], resolution, progress, jobs=jobs,
                              activations=LEVELS)
        parts.append({k: s[k] for k in SOLVED})
        save({k: np.concatenate([p[k] for p in parts]) for k in SOLVED})
    return {k: np.concatenate([p[k] for p in parts]) for k in SOLVED}


def _write(folder: Path, tendon: str, solved: dict, digest: str, band_meta: dict, resolution: str, seconds: float,
           resumed_poses: int) -> dict:
    ax = bands.axes()
    shape = tuple(len(a) for a in ax)
    arms = np.concatenate([solved["fem_m"][:, None], solved["fem_m_at"]], axis=1)  # (P, L, 3): a = 1, then LEVELS
    arms = np.moveaxis(arms.reshape(*shape, len(LEVELS) + 1, 3), 3, 0)  # (L, P, E, R, 3)
    unsolved = np.isnan(arms).any(axis=-1)
    unsolved[1:] |= unsolved[:1]  # a level's move from a = 1 is unknown where either is
    if unsolved.sum(axis=(1, 2, 3)).max() > bands.MAX_UNSOLVED * np.prod(shape):
        raise RuntimeError(f"{tendon}: the band found no equilibrium at {unsolved.sum(axis=(1, 2, 3)).tolist()} of "
                           f"the {np.prod(shape)} grid poses at a = 1, {', '.join(map(str, LEVELS))} (more than "
                           f"{100 * bands.MAX_UNSOLVED:g} %); no level table written")
    # unsolved: the a = 1 arms and each level's move from them, each the mean of the solved neighbours'
    at1 = bands.neighbours_mean(arms[0], unsolved[0])
    filled = np.stack([at1] + [at1 + bands.neighbours_mean(a - arms[0], u) for a, u in zip(arms[1:], unsolved[1:])])
    poses = bands.grid_poses()
    levels = (1.0,) + LEVELS
    meta = {"tendon": tendon, "source": "fem footprint sheet, taut band (rest='pose') taken below a = 1",
            "resolution": resolution, "levels": levels, "band_table_hash": band_meta["input_hash"],
            "scheme": "correction(q, a) = band table's c(q) + lin_a(trilinear(moment_arm_m[a]) - "
                      "trilinear(moment_arm_m[1]))",
            "continuation": "at each level the least energy of the equilibrium continued from the level above "
                            "(Newton, a step it fails on halved) and the ramp's from rest "
                            "(footprint_compare.continued)",
            "unsolved_rule": "the a = 1 arms and each level's move from them: the mean of the solved neighbouring "
                             "grid poses' (one step along each coordinate)",
            "unsolved_poses_deg": {f"{a:g}": poses[u.reshape(-1)].tolist() for a, u in zip(levels, unsolved)},
            "largest_move_mm": (np.abs(filled[1:] - filled[:1]).max(axis=(1, 2, 3)) * 1e3).round(3).tolist(),
            "code_version": CODE_VERSION, "input_hash": digest, "build_seconds": round(seconds, 2),
            "resumed_poses": resumed_poses}
    with replacing(levels_path(tendon, folder)) as tmp:
        np.savez(tmp, **dict(zip(AXES, ax)), activation=np.array(levels), moment_arm_m=filled,
                 unsolved=unsolved, meta=np.array(json.dumps(meta, sort_keys=True)))
    return meta
