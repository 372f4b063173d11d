"""`shoulder-bench fem verify --bands`: the band tables (`bands.py`) against the taut band re-solved at held-out poses,
and against what MuJoCo applies with them (docs/fem.md "Taut bands")."""
from __future__ import annotations

from pathlib import Path

import numpy as np
from tqdm import tqdm

from shoulder_bench import full_arm
from shoulder_bench.authoring.fem.bands import (
    FOOTPRINT_TENDONS,
    BandTable,
    held_out,
    mesh_poses,
    refinement,
    solve_poses,
    table_path,
)
from shoulder_bench.band_lines import BandLines, fibres_path, levels_path


def verify(folder: Path | None = None, tendons=None, resolution: str | None = None, poses=None,
           quiet: bool = False, interpolation: str = "linear", count: int | None = None, jobs: int = 1,
           activations=()) -> int:
    """Two sections, each able to fail (exit status 1):
    1. The taut band re-solved at held-out poses against the scheme: by default all of each tendon's grid's
       (`held_out`: halfway between its poses in every coordinate); `count` N: N of them drawn with a fixed seed
       (`footprint_grid.cells`, one per cell of the tasks' grid, while N is at most their 588; beyond, from all);
       `poses`: these (P, 3) deg for every tendon (length 0: none). Per coordinate the
       torque error at a = 1, F(L_MT(q), 1) |r_MJCF(q) + c(q) - r_band(q)|, in % of the tendon's peak
       |F(L_MT, 1) r_band| over its grid's poses (F: the length-keyed FEM table, `tendon_law`; a = 1, where the
       force is largest and the tables hold the band's line; lower levels with `activations`); bound
       `verify_full.HELD_OUT_TOL`. The band solved as the table's was
       (`solve_poses`, in `jobs` processes). resolution: the sheets' (default: the table's own). interpolation: the
       tables' (`BandTable`). activations (levels in (0, 1]): the same check at each, with the band taken down from
       its a = 1 equilibrium level by level (`footprint_compare.continued`: the least energy of the equilibrium
       continued from the level above and the ramp's): the error
       F(L_MT(q), a) |r_MJCF(q) + c(q, a) - r_band(q, a)|, in % of the same peak, c(q, a) the band table's c(q)
       plus the level table's move from a = 1 where the tendon has one (`band_levels`), else c(q); a pose where the
       band finds no equilibrium at a level counts as unsolved.
    2. What MuJoCo applies with the tables (the task option line_of_action="band", `band_lines`): each tendon alone,
       at every grid pose and activation level, against F(L_band(q), a) r_band(q) (`verify_full.applied_vs_fem`); bound
       `verify_full.APPLIED_TOL`; where every tendon has a fibre table in `folder`, again with line_of_action=
       "band_fibres" (F the mean of its band's fibres')."""
    from shoulder_bench.authoring.fem.footprint_grid import cells
    from shoulder_bench.authoring.fem.verify import report
    from shoulder_bench.authoring.fem.verify_full import APPLIED_TOL, HELD_OUT_TOL, applied_vs_fem
    from shoulder_bench.tendon_law import TendonLaw

    if any(not 0 < a <= 1 for a in activations):
        raise ValueError(f"activation levels lie in (0, 1]; got {', '.join(f'{a:g}' for a in activations)}")
    below = tuple(sorted({float(a) for a in activations if a < 1}, reverse=True))  # continued from a = 1 down
    folder = Path(folder or full_arm.TABLE_FOLDER)
    names = [t for t in (tendons or FOOTPRINT_TENDONS) if tendons or table_path(t, folder).exists()]
    if not names:
        print(f"no band tables in {folder}; build them with `shoulder-bench fem build --bands`")
        return 1

    def held_poses(t: str) -> np.ndarray:
        if poses is not None:
            return np.asarray(poses, float).reshape(-1, 3)
        every = held_out(t)
        if count is None:
            return every
        if not count:
            return every[:0]
        if count <= len(held_out()):  # one sub-cell of each of `count` cells of the tasks' grid, as `footprint_grid`
            return cells(count, refine=refinement(t))[0]
        return every[np.sort(np.random.default_rng(0).choice(len(every), min(count, len(every)), replace=False))]

    pose, failed, checked = full_arm.Pose(), [], False
    print(f"band tables in {folder} ({interpolation}): held-out poses re-solved per tendon; error at activation a in "
          f"% of the tendon's peak |torque| over its grid (bound {HELD_OUT_TOL * 100:g} %): plane, elevation, rotation")
    for t in names:
        held = held_poses(t)
        if not len(held):
            print(f"{t:<5} 0 held-out poses")
            continue
        checked = True
        table = BandTable(table_path(t, folder), interpolation)
        law = TendonLaw.load("fem", tendons=(t,))
        peak = peak_torque(table, law, pose)
        with tqdm(total=len(held), desc=f"verify {t}", unit="pose", disable=quiet, leave=False) as bar:
            band = solve_poses(t, held, resolution or table.meta["resolution"], bar.update, pose, jobs, below)
        line = band["mjcf_m"] + table.correction(held)
        lines = BandLines.load((t,), folder) if below and levels_path(t, folder).exists() else None
        if lines is not None:
            print(f"{t:<5} below a = 1 with its level table ({levels_path(t, folder).name})")
        for a, arms in zip((1.0,) + below, [band["fem_m"]] + list(band["fem_m_at"].transpose(1, 0, 2))):
            moved = 0.0 if lines is None else (lines.correction(held, a) - lines.correction(held, 1.0))[:, 0]
            if not check(t, a, held, tendon_force(law, pose, t, held, a)[:, None] * np.abs(line + moved - arms) / peak
                         * 100):
                failed.append(t if a == 1.0 else f"{t} at a = {a:g}")
    if checked:
        print("all band tables within the bound" if not failed else f"over the bound or unsolved: {', '.join(failed)}")
    sections = [(f"MuJoCo's applied generalised force with the band corrections vs the FEM band's, every grid "
                 f"pose and level (pass: <= {100 * APPLIED_TOL:g} % of the tendon's peak |torque| in that "
                 "coordinate)", applied_vs_fem(folder, "band", names))]
    if all(fibres_path(t, folder).exists() for t in names):  # line_of_action="band_fibres": the force its fibres'
        sections.append(("The same with line_of_action=\"band_fibres\" (the force the mean of the band's fibres' "
                         "law, each at its own length)", applied_vs_fem(folder, "band_fibres", names)))
    applied = report(sections)
    return 1 if failed or applied else 0


def check(tendon: str, a: float, held: np.ndarray, pct: np.ndarray) -> bool:
    """Print one tendon's held-out errors at activation `a` (`pct` (P, 3) % of its peak, NaN where unsolved) and the
    poses over the bound; True if none is over it and every pose was solved."""
    from shoulder_bench.authoring.fem.verify_full import HELD_OUT_TOL

    unsolved = int(np.isnan(pct).any(axis=1).sum())
    if unsolved == len(held):
        print(f"{tendon:<5} a = {a:<4g} 0/{len(held)} solved  FAIL")
        return False
    worst = np.nanmax(pct, axis=0)
    ok = bool(np.all(worst <= HELD_OUT_TOL * 100)) and unsolved == 0
    at = held[int(np.argmax(np.nan_to_num(pct, nan=-np.inf).max(axis=1)))]
    over = np.nan_to_num(pct).max(axis=1) > HELD_OUT_TOL * 100
    print(f"{tendon:<5} a = {a:<4g} {len(held) - unsolved}/{len(held)} solved  largest "
          + " ".join(f"{x:6.2f}" for x in worst)
          + f" %  (at {tuple(float(x) for x in at)} deg; {int(over.sum())} poses over the bound)  "
          + ("pass" if ok else "FAIL"))
    for p, e in list(zip(held[over], pct[over]))[:SHOW_OVER]:
        print(f"      over at {tuple(float(x) for x in p)} deg: " + " ".join(f"{x:.2f}" for x in e) + " %")
    if over.sum() > SHOW_OVER:  # where all of them lie
        lo, hi = held[over].min(axis=0), held[over].max(axis=0)
        print(f"      ... all {int(over.sum())} over the bound within plane {lo[0]:g}-{hi[0]:g}, elevation "
              f"{lo[1]:g}-{hi[1]:g}, rotation {lo[2]:g}-{hi[2]:g} deg")
    for p in held[np.isnan(pct).any(axis=1)][:SHOW_OVER]:
        print(f"      unsolved at {tuple(float(x) for x in p)} deg")
    return ok


SHOW_OVER = 10  # the verify lists at most this many of a tendon's held-out poses over the bound


def peak_torque(table: BandTable, law, pose: full_arm.Pose) -> np.ndarray:
    """(3,) N m: the tendon's peak |F(L_MT, 1) r_band| over its table's grid poses, the scale of the verify's errors."""
    arms = table.arrays["moment_arm_m"].reshape(-1, 3)
    poses = mesh_poses([table.arrays[k] for k in ("plane_deg", "elevation_deg", "rotation_deg")])
    return np.abs(tendon_force(law, pose, table.tendon, poses)[:, None] * arms).max(axis=0)


def tendon_force(law, pose: full_arm.Pose, tendon: str, poses: np.ndarray, activation: float = 1.0) -> np.ndarray:
    """(P,) N: the length-keyed law's force of `tendon` at `activation`, at rest, at `poses` (deg)."""
    n = len(poses)
    return law.force(pose.tendon_geometry(poses, (tendon,))[0], np.zeros((n, 1)), np.full((n, 1), activation))[:, 0]
