"""Line-of-action tables from the footprint sheets (issue 12 §2; docs/fem.md "Taut bands"):
`shoulder-bench fem build --bands [--tendon T ...] [--jobs N] [--coarse --out DIR]`; `fem verify --bands` is in
`band_verify.py`.

The reduced-order scheme. A tendon's generalised force about (plane, elevation, rotation) is

    F(L_MT(q), a) * (r_MJCF(q) + c(q)),

F the length-keyed FEM table's force (`fem.full`: the sheet with its tendon in series), r_MJCF = -ten_J S the MJCF
tendon's moment arms (exact, as MuJoCo's tendon transmission applies them), and c the footprint sheet's correction:
the taut band's moment arms (`footprint.FootprintSheet`, rest="pose": the sheet over the tendon's real footprint,
stress-free in its draped shape at each pose, activated there, solved with contact) less the MJCF arms, on a pose grid
read trilinearly: the tasks' grid (`full_arm.pose_grid`: plane every 15 deg, elevation 10, rotation 15; 840 poses)
or, for the tendons in REFINE, that grid with its step divided (`band_lines.BandLines` reads all tables on one grid
that nests them, leaving each one's trilinear reading as it is). Exploited: the band's line of action departs
smoothly from the MJCF path's (the MJCF arms turn fast near high elevation, 16 % of peak between grid poses for ssp; a
table of the band's own arms would miss by as much, the correction by < 1 %; docs/fem.md). The band is solved at
a = 1; below it its line moves (up to 1.4 mm, `benchmarks/band_activation.py`), which `band_levels` tables where needed.
Tendons: those whose footprint sheet is resolved (FOOTPRINT_TENDONS; ssc's on the head, inserting on the lesser
tuberosity: its 40 mm sheet on the parent's 17 mm wrap sphere has several equilibria). Which equilibrium: the band's
activation ramped from rest at the pose (`FootprintSheet.solve`); for the tendons in LEAST_ENERGY, whose sheet has more
than one equilibrium at some poses (`benchmarks/band_refine.py --branches`), the least-energy of that one and those
Newton reaches at the pose from the ramp's at the pose +- PROBE_FRACTION of the tasks' step along each coordinate, the
first LEAST_ENERGY[t] of those six starts (`least_energy`): the pose's alone; for those in FALLBACK, the ramp's, and
where it finds none the least-energy of the six starts'. A grid pose without an equilibrium (e.g.
tma's corner, plane 80-90, elevation 140, rotation -45) takes the mean of its solved neighbours' correction, listed in
the table (`unsolved`, meta); at most MAX_UNSOLVED of the grid may be.

Caching and resuming: each table carries its input hash (model file bytes, footprint width and moved insertion,
resolution, material, solver settings, grid, CODE_VERSION); a build solves only missing or stale tables, writes each
atomically, holds the folder's lock, and takes from a stale table of the same inputs on another grid (a REFINE change)
the poses it holds (`reusable`). It saves the poses solved so far every SAVE_EVERY (`partial_path`, with the input hash)
and an interrupted build resumes from them (`resumed`). `jobs` processes, one pool per tendon, solve its poses (and the
verify's, `band_verify`) CHUNK at a time: each pose's equilibrium is its own, so the tables do not depend on it.
"""
from __future__ import annotations

import hashlib
import json
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import numpy as np
from tqdm import tqdm

from shoulder_bench import full_arm
from shoulder_bench.authoring.fem import neighbours_mean, rounded, worker_init
from shoulder_bench.authoring.fem.footprint import FLAT_DRAPE, FOOTPRINT_M, INSERTION_M, RESOLUTION, SETTINGS
from shoulder_bench.authoring.fem.footprint_compare import compare
from shoulder_bench.authoring.fem.full import locked_folder
from shoulder_bench.authoring.fem.material import Material
from shoulder_bench.band_lines import BAND_TENDONS, read_table, table_path
from shoulder_bench.muscle import replacing

CODE_VERSION = "fem-band-2"  # bump when a change alters solutions; part of every table's input hash
FOOTPRINT_TENDONS = BAND_TENDONS  # the tendons whose footprint sheet is resolved
# Where the band finds no equilibrium at a grid pose, the correction there is the mean of its solved neighbours'
# (listed in the table's meta, `unsolved` in its arrays); more than this fraction of the grid unsolved fails the build
MAX_UNSOLVED = 0.01
# Each tendon's grid step: the tasks' divided by this (1 if absent), in every coordinate or per coordinate (plane,
# elevation, rotation). Where the held-out check on the tasks' grid missed by interpolation (band_refine.py: ssp, pec1
# and pec3 within the bound at their worst pose on a grid twice as fine; tma's worst cell at a third of the step in
# plane and rotation, where its arms bend, then half in elevation; dpo half in plane and rotation, then in elevation;
# ssc half in plane and rotation, its misses then in one box; docs/fem.md "What each miss is", "tma", "The deltoids")
REFINE = {"ssp": 2, "pec1": 2, "tma": (3, 2, 3), "pec3": 2, "dpo": 2, "ssc": (2, 1, 2)}
# Tendons whose band is solved as the least-energy of several equilibria (`least_energy`), with how many of
# `probe_offsets`' six starts beside the ramp's: tmi (no contact surface; the ramp from rest lands on the higher of two)
# all six; tma, ssp (any one start found the lower equilibrium where there is one: band_branches.py), dan, ld1-3 and
# dpo (every start found it at their worst held-out poses: band_refine.py --branches) one (docs/fem.md "tma", "ssp: one
# start", "dan and ld1-3", "dpo: least energy")
LEAST_ENERGY = {"tmi": 6, "tma": 1, "ssp": 1, "dan": 1, "ld1": 1, "ld2": 1, "ld3": 1, "dpo": 1}
# Tendons solved by the ramp where it converges and from the six starts where it does not: pec2 (today's solver's ramp
# ends its Newton iterations short of an equilibrium the -plane start reaches; docs/fem.md "pec2: the starts' fallback")
FALLBACK = ("pec2",)
PROBE_FRACTION = 0.25  # the starts' offsets from the pose, in tasks' grid steps
# Each tendon's contact surface (`footprint.SURFACES`; "wrap", the MJCF's wrap object, if absent): the humeral head
# sphere (`footprint.HUMERAL_HEAD`) for isp (its band on the parent's cylinder follows the MJCF path's jump and misses
# the held-out bound: docs/fem.md "isp: the humeral head"), dpo and dmi (their MJCF wraps are MuJoCo's inside wrapping:
# "The deltoids"), dan (its acromial site enters its MJCF wrap sphere at high elevation: "dan and ld1-3") and ssc
# (inserting on the lesser tuberosity, footprint.INSERTION_M: "ssc on the lesser tuberosity")
SURFACE = {"isp": "head", "dmi": "head", "dpo": "head", "dan": "head", "ssc": "head"}
SURFACE_TEXT = {"wrap": "the MJCF's wrap object", "head": "the humeral head sphere"}  # in each table's meta


def surface(tendon: str) -> str:
    """`tendon`'s band's contact surface: its SURFACE, else "wrap" (the MJCF's wrap object)."""
    return SURFACE.get(tendon, "wrap")


def refinement(tendon: str | None = None) -> tuple[int, int, int]:
    """`tendon`'s REFINE as (plane, elevation, rotation) divisors of the tasks' step (1, 1, 1 if absent or None)."""
    k = REFINE.get(tendon, 1)
    return (k, k, k) if isinstance(k, int) else tuple(k)


def axes(tendon: str | None = None) -> list[np.ndarray]:
    """`tendon`'s table grid's values per coordinate (deg): the tasks' pose grid as `full_arm.pose_grid` lays it out
    (tendon None or not in REFINE), or that grid with its step divided by `refinement(tendon)`."""
    return [np.linspace(lo, hi, round((hi - lo) / full_arm.POSE_STEP_DEG[c]) * k + 1)
            for (c, (lo, hi)), k in zip(full_arm.POSE_RANGE_DEG.items(), refinement(tendon))]


def grid_poses(tendon: str | None = None) -> np.ndarray:
    """(P, 3) the grid's poses (deg), plane slowest, rotation fastest."""
    return mesh_poses(axes(tendon))


def held_out(tendon: str | None = None) -> np.ndarray:
    """(P, 3) the poses halfway between `tendon`'s table grid's in every coordinate (deg): its cells' centres."""
    from shoulder_bench.authoring.fem.verify_full import held_out_poses

    return held_out_poses(refinement(tendon))


def mesh_poses(values) -> np.ndarray:
    return np.stack(np.meshgrid(*values, indexing="ij"), axis=-1).reshape(-1, 3)


def input_hash(tendon: str, resolution: str, material: Material, grid_axes=None) -> str:
    """The hash of all a table's solutions depend on, its grid `grid_axes` (default `axes(tendon)`) included."""
    # LEAST_ENERGY's or FALLBACK's rule, its starts where fewer than six, FLAT_DRAPE's drape: only where chosen (older
    # hashes stay)
    rule = {"equilibrium": "least energy", "probe": PROBE_FRACTION} if tendon in LEAST_ENERGY else {}
    if rule and LEAST_ENERGY[tendon] < 6:
        rule["starts"] = LEAST_ENERGY[tendon]
    rule.update({"equilibrium": "ramp, else least energy", "probe": PROBE_FRACTION} if tendon in FALLBACK else {})
    rule.update({"drape": "flat"} if tendon in FLAT_DRAPE else {})
    rule.update({"insertion_m": list(INSERTION_M[tendon])} if tendon in INSERTION_M else {})
    blob = json.dumps(rounded({"model": hashlib.sha256(full_arm.MODEL_FILE.read_bytes()).hexdigest(),
                               "tendon": tendon, "width_m": FOOTPRINT_M[tendon], "resolution": resolution,
                               "surface": surface(tendon), "rest": "pose", "material": material.as_dict(),
                               "solver": SETTINGS.as_dict(),
                               "axes": [np.asarray(a).tolist() for a in (grid_axes or axes(tendon))],
                               "code_version": CODE_VERSION, **rule}), sort_keys=True)
    return hashlib.sha256(blob.encode()).hexdigest()


INTERPOLATIONS = ("linear", "cubic")  # trilinear (the scheme), or scipy's tricubic spline (a comparison)


class BandTable:
    """One tendon's table: the band's and the MJCF's moment arms (m) on the pose grid, (planes, elevations,
    rotations, 3); `correction(poses)` interpolates their difference (trilinear; `interpolation`="cubic": scipy's
    tricubic spline through the same points)."""

    def __init__(self, path: Path, interpolation: str = "linear"):
        if interpolation not in INTERPOLATIONS:
            raise ValueError(f"unknown interpolation {interpolation!r}; choose from {', '.join(INTERPOLATIONS)}")
        self.arrays, self.meta = read_table(path)  # the runtime's reader (band_lines), with its checks
        self.tendon = self.meta["tendon"]
        from scipy.interpolate import RegularGridInterpolator

        grid = tuple(self.arrays[k] for k in ("plane_deg", "elevation_deg", "rotation_deg"))
        self._interp = RegularGridInterpolator(grid, self.arrays["moment_arm_m"] - self.arrays["mjcf_moment_arm_m"],
                                               method=interpolation)

    def correction(self, poses_deg) -> np.ndarray:
        """(P, 3) m: the band's moment arms less the MJCF's at `poses_deg` (P, 3), interpolated between the grid's."""
        return self._interp(np.atleast_2d(poses_deg))


def solve_grid(tendon: str, resolution: str = "full", progress=None, pose: full_arm.Pose | None = None,
               jobs: int = 1, known: dict | None = None, save=None) -> dict:
    """The taut band of `tendon` at every grid pose: arrays on the grid's shape; RuntimeError naming the poses where
    no equilibrium was found. `known` (`reusable`, `resumed`): poses already solved by the same rule and inputs, taken
    as they are (each pose's equilibrium is its own); the rest are solved, SAVE_EVERY at a time, each block's poses
    handed to save(known so far, as `known`) if given (the build's checkpoint)."""
    shape, poses = tuple(len(a) for a in axes(tendon)), grid_poses(tendon)
    r = with_known(poses, known, lambda todo: _solve_saving(tendon, todo, resolution, progress, pose, jobs, save))
    arm, mjcf, unsolved = r["fem_m"], r["mjcf_m"], ~r["converged"]
    tension, contact = np.nan_to_num(r["tension_N"]), np.nan_to_num(r["contact_N"])  # 0 where unsolved
    if unsolved.sum() > MAX_UNSOLVED * len(poses):
        raise RuntimeError(f"{tendon}: no equilibrium of the taut band at {unsolved.sum()} grid pose(s), e.g. "
                           f"{[tuple(p) for p in poses[unsolved][:3].tolist()]} deg; the tables already written are "
                           "kept")
    arm, mjcf, unsolved = arm.reshape(*shape, 3), mjcf.reshape(*shape, 3), unsolved.reshape(shape)
    arm[unsolved] = mjcf[unsolved] + neighbours_mean(arm - mjcf, unsolved)[unsolved]
    return {"moment_arm_m": arm, "mjcf_moment_arm_m": mjcf, "tension_N": tension.reshape(shape),
            "contact_N": contact.reshape(shape), "unsolved": unsolved, "f0_N": r["f0_N"],
            "fibre_m": r["fibre_m"].reshape(*shape, -1), "reused": r.get("reused", 0)}


SOLVED = ("fem_m", "mjcf_m", "tension_N", "contact_N", "converged", "fibre_m")  # what `solve_poses` gives per pose
SAVE_EVERY = 200  # poses a build solves between checkpoints: at most this many are solved again after an interrupt
PARTIAL = ("poses", "f0_N") + SOLVED  # what a checkpoint holds (beside its input hash): a `known` dict


def _solve_saving(tendon: str, poses: np.ndarray, resolution: str, progress, pose, jobs: int, save) -> dict:
    """`solve_poses` of `poses`, save(the poses solved so far as a `known` dict) after each SAVE_EVERY if `save` is
    given; `jobs` > 1: one pool for them all (a pool per block idled a core while the block's last chunk ran)."""
    if save is None:
        return solve_poses(tendon, poses, resolution, progress, pose, jobs)
    if jobs > 1 and len(poses) > CHUNK:
        return _solve_parallel(tendon, poses, resolution, progress, jobs, (), save)
    parts = []
    for i in range(0, len(poses), SAVE_EVERY):
        parts.append(solve_poses(tendon, poses[i:i + SAVE_EVERY], resolution, progress, pose, jobs))
        save(dict(_joined(parts), poses=poses[:i + SAVE_EVERY]))
    return _joined(parts)


def _joined(parts: list[dict]) -> dict:
    """`solve_poses` results of consecutive blocks of poses as one (their per-pose arrays concatenated)."""
    n = len(parts[0]["converged"])
    per_pose = [k for k, v in parts[0].items() if isinstance(v, np.ndarray) and v.shape[:1] == (n,)]
    return dict(parts[0], **{k: np.concatenate([p[k] for p in parts]) for k in per_pose})


def partial_path(tendon: str, folder: Path) -> Path:
    """Where a build keeps the poses of `tendon`'s table solved so far (removed when the table is written)."""
    return folder / f"{tendon}_band.partial.npz"


def resumed(path: Path, digest: str, keys=PARTIAL) -> dict | None:
    """The poses an interrupted build saved at `path` (`partial_path`) as a `known` dict (its `keys`), if that build had
    the inputs whose hash is `digest`; else None (missing, unreadable or from other inputs: solved anew)."""
    try:
        with np.load(path) as z:
            return {k: z[k] for k in keys} if str(z["input_hash"]) == digest else None
    except (OSError, ValueError, KeyError):
        return None


def save_partial(path: Path, digest: str, known: dict, keys=PARTIAL) -> None:
    with replacing(path) as tmp:
        np.savez(tmp, input_hash=np.array(digest), **{k: known[k] for k in keys})


def merged(*knowns: dict | None) -> dict | None:
    """`known` dicts (`reusable`, `resumed`; None skipped) as one; None if all are None."""
    knowns = [k for k in knowns if k is not None]
    return dict(knowns[0], **{k: np.concatenate([x[k] for x in knowns]) for k in ("poses",) + SOLVED}) if knowns \
        else None


def reusable(path: Path, tendon: str, resolution: str, material: Material) -> dict | None:
    """The poses of the table at `path` as `solve_poses` gives them (SOLVED, "poses") if it was built from the inputs
    a table of `tendon` would be built from now on its own grid (the table's stored hash equals `input_hash` with
    that grid: the same model, sheet, material, solver, rule and code), else None: a refined grid solves only the
    poses its previous table lacks."""
    try:
        arrays, meta = read_table(path)
    except ValueError:
        return None
    grid = [arrays[k] for k in ("plane_deg", "elevation_deg", "rotation_deg")]
    if meta.get("tendon") != tendon or meta.get("input_hash") != input_hash(tendon, resolution, material, grid):
        return None
    solved = ~arrays["unsolved"].reshape(-1)
    arm = arrays["moment_arm_m"].reshape(-1, 3).copy()
    arm[~solved] = np.nan  # as `solve_poses` leaves an unsolved pose; the new grid fills it from its own neighbours
    return {"poses": mesh_poses(grid), "fem_m": arm, "mjcf_m": arrays["mjcf_moment_arm_m"].reshape(-1, 3),
            "tension_N": np.where(solved, arrays["tension_N"].reshape(-1), np.nan),
            "contact_N": np.where(solved, arrays["contact_N"].reshape(-1), np.nan), "converged": solved,
            "fibre_m": arrays["fibre_m"].reshape(len(solved), -1) if "fibre_m" in arrays else  # one kept none
            np.full((len(solved), RESOLUTION[resolution][1]), np.nan),
            "f0_N": meta["f0_N"]}


def with_known(poses: np.ndarray, known: dict | None, solve) -> dict:
    """`solve(poses)`'s arrays, taking the poses in `known` from it (matched to 1e-6 deg) and solving only the rest."""
    if known is None:
        return solve(poses)
    at = known_at(poses, known)
    todo = poses[at < 0]
    new = solve(todo) if len(todo) else {"f0_N": known["f0_N"]}
    out = {"f0_N": new["f0_N"], "reused": int((at >= 0).sum())}
    for k in SOLVED:
        column = np.empty((len(poses),) + known[k].shape[1:], known[k].dtype)
        column[at >= 0] = known[k][at[at >= 0]]
        if len(todo):
            column[at < 0] = new[k]
        out[k] = column
    return out


def known_at(poses: np.ndarray, known: dict | None) -> np.ndarray:
    """(P,) each of `poses`' index in `known["poses"]` (matched to 1e-6 deg), -1 where it has none."""
    if known is None:
        return np.full(len(poses), -1)
    index = {tuple(np.round(p, 6)): i for i, p in enumerate(known["poses"])}
    return np.array([index.get(tuple(np.round(p, 6)), -1) for p in poses], dtype=int)


def solve_poses(tendon: str, poses: np.ndarray, resolution: str, progress=None,
                pose: full_arm.Pose | None = None, jobs: int = 1, activations=()) -> dict:
    """The taut band of `tendon` at `poses` (P, 3) deg, as `footprint_compare.compare` returns it (rest="pose"): the
    ramp's equilibrium (for FALLBACK tendons, where it finds none, the starts'), or for LEAST_ENERGY tendons
    `least_energy`'s. `jobs` > 1: that many processes, each solving CHUNK poses at a time on a model it poses itself
    (`pose` unused; each pose's equilibrium is its own, so the result is the same); progress(n) after n poses.
    activations: also the band at these levels below 1, taken down from a = 1 (`footprint_compare.continued`;
    `compare`'s "fem_m_at")."""
    poses = np.atleast_2d(np.asarray(poses, float))
    if jobs > 1 and len(poses) > CHUNK:
        return _solve_parallel(tendon, poses, resolution, progress, jobs, activations)
    if tendon in LEAST_ENERGY:
        return least_energy(tendon, poses, resolution, progress, pose, activations=activations)
    return compare(tendon, poses, resolution, progress=progress, pose=pose, rest="pose", surface=surface(tendon),
                   activations=activations, offsets_deg=probe_offsets() if tendon in FALLBACK else None,
                   fallback=tendon in FALLBACK)


CHUNK = 20  # poses a worker process solves at a time (the sheet is set up anew for each chunk: ~0.02 s)


def _solve_parallel(tendon: str, poses: np.ndarray, resolution: str, progress, jobs: int, activations,
                    save=None) -> dict:
    """`solve_poses` in `jobs` processes, CHUNK poses a task; save(the chunks done as a `known` dict) if given."""
    chunks = [poses[i:i + CHUNK] for i in range(0, len(poses), CHUNK)]
    parts, unsaved = [None] * len(chunks), 0
    with ProcessPoolExecutor(max_workers=jobs, initializer=worker_init) as pool:
        futures = {pool.submit(solve_poses, tendon, c, resolution, activations=activations): k
                   for k, c in enumerate(chunks)}
        try:
            for done in as_completed(futures):
                parts[futures[done]] = done.result()
                if progress is not None:
                    progress(len(chunks[futures[done]]))
                unsaved += len(chunks[futures[done]])
                if save is not None and unsaved >= SAVE_EVERY:
                    done_k = [k for k, part in enumerate(parts) if part is not None]
                    save(dict(_joined([parts[k] for k in done_k]), poses=np.concatenate([chunks[k] for k in done_k])))
                    unsaved = 0
        except BaseException:  # an interrupt or a failed chunk: drop the chunks not started rather than wait for them
            pool.shutdown(cancel_futures=True)
            raise
    return _joined(parts)


def probe_offsets() -> np.ndarray:
    """(6, 3) deg: the least-energy rule's starts beside the pose, +- PROBE_FRACTION of the tasks' step along each
    coordinate (+plane, +elevation, +rotation, then the same less); a tendon's rule takes the first LEAST_ENERGY[t]."""
    probe = np.diag([full_arm.POSE_STEP_DEG[c] * PROBE_FRACTION for c in full_arm.COORDINATES])
    return np.vstack([probe, -probe])


def least_energy(tendon: str, poses: np.ndarray, resolution: str, progress=None,
                 pose: full_arm.Pose | None = None, starts: int | None = None, activations=()) -> dict:
    """`compare`'s arrays (rest="pose") with, at each pose p, the least-energy equilibrium among the ramp's at p and
    those Newton reaches at p from the ramp's at p + each of the first `starts` of `probe_offsets` (default: the
    tendon's LEAST_ENERGY, else all six; `FootprintSheet.solve_least_energy`). Unconverged where none converges."""
    starts = LEAST_ENERGY.get(tendon, 6) if starts is None else starts
    return compare(tendon, poses, resolution, progress=progress, pose=pose, rest="pose",
                   surface=surface(tendon), offsets_deg=probe_offsets()[:starts], activations=activations)


def build(tendons=FOOTPRINT_TENDONS, coarse: bool = False, out: Path | None = None, jobs: int = 1,
          quiet: bool = False) -> dict[str, dict]:
    """Build (or reuse) each tendon's band table in `out` (default models/muscles_full), one tendon after another,
    `jobs` processes solving its poses. Returns {tendon: meta + cached}. --coarse needs --out."""
    unknown = [t for t in tendons if t not in FOOTPRINT_TENDONS]
    if unknown:
        raise ValueError(f"no band table for {', '.join(unknown)}; tendons with one: {', '.join(FOOTPRINT_TENDONS)}")
    with locked_folder(out, coarse, jobs, "band tables") as folder:
        return _build(folder, tuple(tendons), "coarse" if coarse else "full", int(jobs), quiet)


def _build(folder: Path, tendons: tuple, resolution: str, jobs: int, quiet: bool) -> dict[str, dict]:
    material, result, todo = Material(), {}, []
    for t in tendons:
        digest = input_hash(t, resolution, material)
        try:
            meta = BandTable(table_path(t, folder)).meta
        except ValueError:  # missing or unreadable: solve it
            meta = {}
        if meta.get("input_hash") == digest:
            result[t] = dict(meta, cached=True)
        else:
            done = resumed(partial_path(t, folder), digest)
            todo.append((t, digest, done, merged(reusable(table_path(t, folder), t, resolution, material), done)))
    total = sum(int((known_at(grid_poses(t), known) < 0).sum()) for t, _, _, known in todo)
    with tqdm(total=total, desc="fem bands", unit="pose", disable=quiet or not todo) as bar:
        for t, digest, done, known in todo:
            t0, partial = time.perf_counter(), partial_path(t, folder)
            grid = solve_grid(t, resolution, bar.update, jobs=jobs, known=known,
                              save=lambda new, p=partial, d=digest, done=done: save_partial(p, d, merged(done, new)))
            resumed_poses = 0 if done is None else len(done["poses"])
            meta = _meta(t, resolution, digest, dict(grid, reused=grid["reused"] - resumed_poses),
                         time.perf_counter() - t0, resumed_poses)
            _write(table_path(t, folder), grid, meta)
            partial.unlink(missing_ok=True)
            result[t] = dict(meta, cached=False)
    return {t: result[t] for t in tendons}


def _meta(tendon, resolution, digest, grid, seconds, resumed_poses=0) -> dict:
    c = grid["moment_arm_m"] - grid["mjcf_moment_arm_m"]
    return {"tendon": tendon, "source": "fem footprint sheet, taut band (rest='pose')", "resolution": resolution,
            "footprint_width_m": FOOTPRINT_M[tendon],
            "contact_surface": SURFACE_TEXT[surface(tendon)],
            "model_file": "models/shoulder_full_task.xml", "f0_N": grid["f0_N"],
            "scheme": "F(L_MT(q), a) * (r_MJCF(q) + trilinear(moment_arm_m - mjcf_moment_arm_m))",
            "largest_correction_mm": dict(zip(full_arm.COORDINATES, (np.abs(c).max(axis=(0, 1, 2)) * 1e3).tolist())),
            "tension_range_N": [float(grid["tension_N"][~grid["unsolved"]].min()),
                                float(grid["tension_N"][~grid["unsolved"]].max())],
            "unsolved_poses_deg": grid_poses(tendon)[grid["unsolved"].reshape(-1)].tolist(),
            "grid_refine": REFINE.get(tendon, 1),
            "equilibrium": (f"least energy: the ramp's and Newton's from {LEAST_ENERGY[tendon]} of probe_offsets"
                            if tendon in LEAST_ENERGY else
                            "the ramp from rest, else the least energy from the six probe_offsets"
                            if tendon in FALLBACK else "the ramp from rest"),
            "unsolved_rule": "the correction: the mean of the solved neighbouring grid poses' (one step along each "
                             "coordinate)",
            "code_version": CODE_VERSION, "input_hash": digest, "build_seconds": round(seconds, 2),
            "reused_poses": grid["reused"], "resumed_poses": resumed_poses}


def _write(path: Path, grid: dict, meta: dict) -> None:
    plane, elevation, rotation = axes(meta["tendon"])
    arrays = {"plane_deg": plane, "elevation_deg": elevation, "rotation_deg": rotation,
              **{k: grid[k] for k in ("moment_arm_m", "mjcf_moment_arm_m", "tension_N", "contact_N", "unsolved",
                                      "fibre_m")},
              "meta": np.array(json.dumps(meta, sort_keys=True))}
    with replacing(path) as tmp:
        np.savez(tmp, **arrays)
