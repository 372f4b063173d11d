"""FEM tables of the full shoulder's fifteen tendons over its 3-DOF pose space (issue 12 §2, docs/fem.md "Full
shoulder"): `shoulder-bench fem build --full [--coarse --out DIR] [--jobs N]`.

The reduced-order scheme. Each tendon's sheet is v2's (`v2_sheet`: a pennated fibre membrane of axial extent
L_MT - l_ts in series with a rigid tendon at the MoBL parent's slack length; the parent's F0, l_opt, alpha0). Its
force depends on the pose only through the musculotendon length L_MT(q), so the table over (plane x elevation x
rotation) x activation factors exactly into

    force_N(L, a) on a uniform length grid   x   the MuJoCo tendon's Jacobian at the pose,

and MuJoCo applies the generalised force F(L_MT(q), a) (-ten_J(q)) through the tendon transmission, whose ten_J is
the exact derivative of that same length. What is exploited: that one-dimensionality (a 3-D pose grid of
P poses x J levels becomes K lengths x J levels, K = LENGTH_POINTS) and smoothness in length (linear interpolation
between K knots; `verify_full` re-solves held-out poses). Not exploited: linearity in activation (the FEM is not
linear in a; six levels). The length grid spans each tendon's L_MT over the pose space (`full_arm.pose_grid`, the
coordinates' ranges) with LENGTH_MARGIN on both sides; outside it the law takes the edge values.

What this is not: the issue's sheets over the real attachment footprints, with contact on the humeral head and a
torque vector that is an output of the solve. Here the line of action is the MJCF tendon's (docs/fem.md); the
footprint sheets of `footprint` solve it for six tendons, behind no table yet.

Caching and resuming: each tendon's table is written (atomically) as soon as it is solved, with its input hash
(sheet mesh hash, spec, material, solver, length grid, CODE_VERSION); a rerun solves only the tendons whose table is
missing or whose hash differs, so an interrupted build resumes where it stopped.
"""
from __future__ import annotations

import contextlib
import hashlib
import json
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
from tqdm import tqdm

from shoulder_bench import full_arm
from shoulder_bench.authoring import mobl_data, tendons
from shoulder_bench.authoring.fem import output_folder, quantised, rounded, worker_init
from shoulder_bench.authoring.fem.material import Material
from shoulder_bench.authoring.fem.shells import mesh_sha256
from shoulder_bench.authoring.fem.solver import NoConvergence
from shoulder_bench.authoring.fem.v2 import ACTIVATIONS, SETTINGS, solve, solve_meta
from shoulder_bench.authoring.fem.v2_sheet import SheetSpec, build_sheet
from shoulder_bench.locks import FolderLock
from shoulder_bench.muscle import replacing
from shoulder_bench.tendon_law import table_path

CODE_VERSION = "fem-full-1"  # bump when a change alters solutions; part of every table's input hash
LENGTH_POINTS = 33
LENGTH_MARGIN = 0.02  # fraction of the tendon's length range added below and above it
PROVENANCE = ("MoBL-ARMS parent (models/reference/mobl_arms_parent_muscles.csv, from stanfordnmbl/osim-rl@610b95c "
              "osim/models/MoBL_ARMS_J.osim; models/reference/README.md)")


def specs(geometry: str | None = None) -> dict[str, SheetSpec]:
    """Each tendon's sheet from the parent's fibre parameters; a geometry's rerouted tendons (`ld_transfer`) with
    their re-tensioned slack lengths (`transfer.slack_lengths`, docs/surgery.md)."""
    import dataclasses

    from shoulder_bench.authoring import transfer

    parent = tendons.load_parent()
    params = {t: parent[mobl_data.FULL_MUSCLES[t]] for t in full_arm.TENDONS}
    if geometry is not None:
        slack = transfer.slack_lengths()
        params |= {t: dataclasses.replace(params[t], l_ts=slack[t]) for t in full_arm.GEOMETRIES[geometry]["tendons"]}
    return {t: SheetSpec.from_parent(t, p) for t, p in params.items()}


def length_grids(pose_deg: np.ndarray | None = None, geometry: str | None = None) -> dict[str, np.ndarray]:
    """Each tendon's uniform length grid (m, LENGTH_POINTS knots) over its L_MT on the pose space (of the model of
    `geometry`, default intact)."""
    poses = full_arm.pose_grid() if pose_deg is None else pose_deg
    L, _ = full_arm.Pose(full_arm.compile_full(geometry)).tendon_geometry(poses)
    out = {}
    for k, t in enumerate(full_arm.TENDONS):
        lo, hi = float(L[:, k].min()), float(L[:, k].max())
        pad = LENGTH_MARGIN * (hi - lo)
        out[t] = np.linspace(lo - pad, hi + pad, LENGTH_POINTS)
    return out


def input_hash(spec: SheetSpec, resolution: str, lengths: np.ndarray, material: Material, settings) -> str:
    sheet = build_sheet(spec, resolution, material.fibre)
    blob = json.dumps(rounded({"mesh": mesh_sha256(sheet), "spec": spec.as_dict(), "material": material.as_dict(),
                               "lengths": hashlib.sha256(quantised(lengths).tobytes()).hexdigest(),
                               "solver": settings.as_dict(), "activation": ACTIVATIONS.tolist(),
                               "code_version": CODE_VERSION}), sort_keys=True)
    return hashlib.sha256(blob.encode()).hexdigest()


def _cached(path: Path, digest: str) -> dict | None:
    """The meta of the table at `path` if its input hash is `digest`, else None (also when missing or unreadable)."""
    try:
        with np.load(path, allow_pickle=False) as z:
            meta = json.loads(str(z["meta"]))
    except Exception:  # missing or unreadable: rebuild
        return None
    return meta if meta.get("input_hash") == digest else None


def _solve_one(job) -> tuple[str, dict, float]:
    t, spec, lengths, res, material, settings = job
    t0 = time.perf_counter()
    try:
        fem = solve(spec, lengths - spec.l_ts, res, material, settings)
    except NoConvergence as exc:
        raise RuntimeError(f"{t}: the sheet did not converge over {lengths[0]:.4f}-{lengths[-1]:.4f} m ({exc}); "
                           "the tables already written are kept, a rerun resumes") from exc
    return t, fem, time.perf_counter() - t0


def build(coarse: bool = False, out: Path | None = None, quiet: bool = False, jobs: int = 1,
          tendons_: tuple[str, ...] | None = None, material: Material | None = None,
          geometry: str | None = None) -> dict[str, dict]:
    """Build (or reuse) each tendon's table in `out` (default models/muscles_full); `jobs` processes solve tendons
    in parallel. Returns {tendon: meta + cached}. --coarse needs --out (coarse tables never replace the shipped
    ones). `geometry` (`full_arm.GEOMETRIES`: ld_transfer): its rerouted tendons on its model, with their
    re-tensioned slack lengths, into its folder (default models/muscles_full_ld_transfer)."""
    valid = full_arm.TENDONS if geometry is None else full_arm.GEOMETRIES[geometry]["tendons"]
    names = valid if tendons_ is None else tuple(tendons_)
    unknown = [t for t in names if t not in valid]
    if unknown:
        raise ValueError(f"unknown tendon(s) {unknown}; choose from {', '.join(valid)}"
                         + (f" (the tendons {geometry} reroutes)" if geometry else ""))
    default = full_arm.TABLE_FOLDER if geometry is None else full_arm.GEOMETRIES[geometry]["tables"]
    with locked_folder(out, coarse, jobs, "full tables", default) as folder:
        return _build(folder, coarse, quiet, jobs, names, material, geometry)


@contextlib.contextmanager
def locked_folder(out: Path | None, coarse: bool, jobs: int, what: str, default: Path = full_arm.TABLE_FOLDER):
    """The folder a full-shoulder table build writes (`out`, default `default`), checked before any work (--coarse
    needs --out: coarse tables never replace the shipped `what`; --jobs >= 1), created, and locked while the build
    runs: two builds never write one folder."""
    if coarse and out is None:
        raise ValueError(f"--coarse without --out would replace the {what} in {default}; give --out DIR")
    if int(jobs) < 1:
        raise ValueError(f"--jobs must be >= 1, got {jobs}")
    folder = output_folder(out if out is not None else default, "--out")
    folder.mkdir(parents=True, exist_ok=True)
    lock = FolderLock(folder, "table folder", "give another --out")
    try:
        yield folder
    finally:
        lock.release(remove=True)


def _build(folder: Path, coarse: bool, quiet: bool, jobs: int, names: tuple, material, geometry=None) -> dict:
    material, settings, res = material or Material(), SETTINGS, ("coarse" if coarse else "full")
    grids, all_specs = length_grids(geometry=geometry), specs(geometry)
    result, todo = {}, []
    for t in names:
        digest = input_hash(all_specs[t], res, grids[t], material, settings)
        path = table_path(t, "fem", folder)
        meta = _cached(path, digest)
        if meta is not None:
            result[t] = dict(meta, cached=True)
        else:
            todo.append((t, digest, path))
    parallel = int(jobs) > 1 and len(todo) > 1
    pool = ProcessPoolExecutor(int(jobs), initializer=worker_init) if parallel else contextlib.nullcontext()
    with tqdm(total=len(todo), desc="fem full (tendons)", disable=quiet or not todo) as bar, pool:
        solved = (pool.map if parallel else map)(_solve_one, [(t, all_specs[t], grids[t], res, material, settings)
                                                                for t, _, _ in todo])
        for (t, digest, path), (_, fem, seconds) in zip(todo, solved):  # map keeps the order
            meta = _meta(t, all_specs[t], res, digest, material, settings, fem, seconds, geometry)
            _write(path, grids[t], fem, meta)
            result[t] = dict(meta, cached=False)
            bar.update(1)
    return {t: result[t] for t in names}


def _meta(t, spec, res, digest, material, settings, fem, seconds, geometry=None) -> dict:
    from shoulder_bench.authoring.transfer import SLACK_RULE

    extra = {} if geometry is None else {"geometry": geometry, "tendon_slack_rule": SLACK_RULE}
    return {"model": "fem", "source": "fem", "muscle": t, "parent_muscle": mobl_data.FULL_MUSCLES[t],
            "model_file": f"models/{full_arm.model_file(geometry).name}", "coordinate": "tendon length", **extra,
            "law": "v2_sheet: pennated fibre membrane (Blemker fibres, co-rotational background) of axial extent "
                   "L_MT - l_ts in series with a rigid tendon; force = the axial reaction at the insertion edge",
            "pose_space_deg": {c: list(r) for c, r in full_arm.POSE_RANGE_DEG.items()},
            "parameters": PROVENANCE, **solve_meta(t, spec, res, material, settings, fem),
            "code_version": CODE_VERSION, "input_hash": digest, "build_seconds": round(seconds, 2)}


def _write(path: Path, lengths: np.ndarray, fem: dict, meta: dict) -> None:
    arrays = {"length_m": lengths.astype(float), "activation": ACTIVATIONS.astype(float),
              "force_N": np.maximum(fem["force"], 0.0), "lateral_force_N": fem["lateral_force_N"],
              "newton_iterations": fem["newton_iterations"], "fibre_stretch": fem["fibre_stretch"],
              "stalled_solves": fem["stalled_solves"], "meta": np.array(json.dumps(meta, sort_keys=True))}
    with replacing(path) as tmp:
        np.savez(tmp, **arrays)
