"""Solve each muscle sheet over the (angle, activation) grid and write the tables the MuJoCo callback reads.

Table `models/muscles/<m>_fem.npz` (format: shoulder_bench.muscle): torque_Nm (K, J) is the FEM joint torque about +x
(positive = abduction) from the insertion reaction; force_N = torque_Nm / moment_arm_m is the tendon force MuJoCo must
apply along the MJCF tendon so that its torque equals the FEM torque at grid points. Extra arrays: insertion_force_N
(K, J, 3), the resultant the muscle exerts on the humerus, and newton_iterations (K, J).

Caching: a table whose meta.input_hash equals the hash of (shell mesh, material, solver settings, grid, code version)
is not re-solved; only its moment arms and force_N are refreshed from the current MJCF (and when those are unchanged
too, nothing is written). The hash is taken after
rounding (mesh arrays to 1e-10 of their unit, scalars to 9 significant digits: shoulder_bench.authoring.fem), so it is
the same
on every CPU.

Every file is written atomically (temporary file, then os.replace): a build that fails leaves the files it had not
finished as they were.
"""
from __future__ import annotations

import hashlib
import json
import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

from shoulder_bench.authoring import anatomy
from shoulder_bench.authoring.fem import CODE_VERSION, output_folder, rounded
from shoulder_bench.authoring.fem.material import Material
from shoulder_bench.authoring.fem.shells import GRID_DEG, build_shell, load_shell, mesh_sha256, save_shell, shell_path
from shoulder_bench.authoring.fem.solver import MuscleProblem, SolverSettings
from shoulder_bench.muscle import replacing

ACTIVATIONS = np.array([0.0, 0.1, 0.25, 0.5, 0.75, 1.0])
SMALL_MOMENT_ARM = 0.003  # m; below this |r|, force = torque / r is ill-conditioned: interpolated instead
NOISE_FORCE_N = 1.0  # |negative tendon force| up to this is solver noise on a slack sheet, clamped to zero


def input_hash(shell: dict, material: Material, settings: SolverSettings, grid: dict) -> str:
    """SHA-256 of (mesh hash, material, solver settings, grid, CODE_VERSION), floats rounded to 9 significant digits."""
    blob = json.dumps(rounded({"mesh": mesh_sha256(shell), "material": material.as_dict(),
                               "solver": settings.as_dict(), "grid": grid, "code_version": CODE_VERSION}),
                      sort_keys=True)
    return hashlib.sha256(blob.encode()).hexdigest()


def grid_dict() -> dict:
    return {"angle_deg": [float(GRID_DEG[0]), float(GRID_DEG[-1]), float(GRID_DEG[1] - GRID_DEG[0])],
            "activation": ACTIVATIONS.tolist()}


def _cached(path: Path, digest: str) -> dict | None:
    if not path.exists():
        return None
    try:
        with np.load(path, allow_pickle=False) as z:
            meta = json.loads(str(z["meta"]))
            if meta.get("input_hash") != digest:
                return None
            return {k: z[k] for k in z.files}
    except Exception:  # unreadable: rebuild
        return None


def store_shell(shell: dict, folder: Path) -> None:
    """Store the (full-resolution) shell beside its table: written if missing or stale."""
    path = shell_path(str(shell["muscle"]), folder)
    if not path.exists() or mesh_sha256(load_shell(path)) != mesh_sha256(shell):
        save_shell(shell, path)


def solve_table(shell: dict, material: Material, settings: SolverSettings, progress: tqdm | None = None) -> dict:
    problem = MuscleProblem(shell, material, settings)
    k, j = len(GRID_DEG), len(ACTIVATIONS)
    torque, force, iters = np.zeros((k, j)), np.zeros((k, j, 3)), np.zeros((k, j), int)
    cb = None if progress is None else (lambda: progress.update(1))
    neighbour = None
    for c in range(j - 1, -1, -1):  # from a = 1 down: a slack low-activation sweep can restart from the one above
        a = float(ACTIVATIONS[c])
        force[:, c], torque[:, c], iters[:, c], xs = problem.sweep(GRID_DEG, a, callback=cb, neighbour=neighbour)
        neighbour = (a, xs)
    return {"torque_Nm": torque, "insertion_force_N": force, "newton_iterations": iters,
            "stalled_solves": np.array(problem.stalled)}


def tendon_force(torque: np.ndarray, moment_arm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Tendon force for MuJoCo: torque / moment arm where that is well conditioned, so MuJoCo's torque equals the FEM
    torque there; where |moment arm| < SMALL_MOMENT_ARM or the ratio would be negative (the MJCF line and the FEM sheet
    cross zero moment arm at slightly different angles: muscles only pull), the force is interpolated in angle from
    the well-conditioned angles of the same activation. Returns (force, mask of interpolated entries)."""
    ratio = torque / np.where(np.abs(moment_arm) >= SMALL_MOMENT_ARM, moment_arm, np.inf)[:, None]
    # passive forces of a slack sheet are zero up to solver noise (a fraction of a newton, either sign): not a conflict
    good = (np.abs(moment_arm) >= SMALL_MOMENT_ARM)[:, None] & (ratio >= -NOISE_FORCE_N)
    force = np.empty_like(torque)
    for j in range(torque.shape[1]):
        force[:, j] = np.interp(GRID_DEG, GRID_DEG[good[:, j]], ratio[good[:, j], j])
    return np.maximum(force, 0.0), ~good


def write_table(path: Path, muscle: str, fem: dict, meta: dict, moment_arm: np.ndarray) -> dict:
    torque = fem["torque_Nm"]
    force, interpolated = tendon_force(torque, moment_arm)
    mismatch = np.abs(force * moment_arm[:, None] - torque)
    meta = dict(meta, force_interpolated_deg=GRID_DEG[interpolated.any(axis=1)].tolist(),
                max_torque_mismatch_Nm=float(mismatch.max()), max_abs_force_N=float(np.max(np.abs(force))))
    arrays = {"angle_deg": GRID_DEG.astype(float), "activation": ACTIVATIONS.astype(float), "torque_Nm": torque,
              "moment_arm_m": moment_arm.astype(float), "force_N": force,
              "insertion_force_N": fem["insertion_force_N"], "newton_iterations": fem["newton_iterations"],
              "stalled_solves": fem["stalled_solves"],
              "meta": np.array(json.dumps(meta, sort_keys=True))}
    with replacing(path) as tmp:
        np.savez(tmp, **arrays)
    return meta


def build(muscles=anatomy.MUSCLES, coarse: bool = False, out: Path | None = None, material: Material | None = None,
          settings: SolverSettings | None = None, quiet: bool = False) -> dict[str, dict]:
    """Build (or reuse) the FEM table of each muscle into `out` (default models/muscles). Returns {muscle: meta
    plus `cached` (inputs unchanged, not re-solved) and `written` (its table file was written)}.

    The output folder is checked before any work (ValueError when it is a file or not writable, or when coarse
    tables would replace the shipped full ones)."""
    from shoulder_bench.model import MODELS_DIR, moment_arms

    if coarse and out is None:
        raise ValueError(f"--coarse without --out would replace the full tables in {MODELS_DIR / 'muscles'} with "
                         "coarse ones; give --out DIR for the coarse tables")
    folder = output_folder(out if out is not None else MODELS_DIR / "muscles", "--out")
    material = material or Material()
    settings = settings or SolverSettings()
    arms = moment_arms(GRID_DEG)
    grid = grid_dict()
    result = {}
    for m in muscles:
        shell = build_shell(m, "coarse" if coarse else "full")
        digest = input_hash(shell, material, settings, grid)
        path = folder / f"{m}_fem.npz"
        fem = _cached(path, digest)
        t0 = time.perf_counter()
        cached = fem is not None
        if cached and np.allclose(fem["moment_arm_m"], arms[m], rtol=0.0, atol=1e-12):  # up to date: write nothing
            result[m] = dict(json.loads(str(fem["meta"])), cached=True, written=False)
            continue
        if fem is None:
            with tqdm(total=len(GRID_DEG) * len(ACTIVATIONS), desc=f"fem {m}", disable=quiet, leave=True) as bar:
                fem = solve_table(shell, material, settings, bar)
            seconds = time.perf_counter() - t0
        else:
            seconds = float(json.loads(str(fem["meta"]))["build_seconds"])
        meta = {"model": "fem", "muscle": m, "mesh_sha256": mesh_sha256(shell), "material": material.as_dict(),
                "solver": settings.as_dict(), "grid": grid, "tolerance": f"max nodal residual < {settings.tol} F0 "
                f"({settings.stall_factor * settings.tol} F0 for {int(fem['stalled_solves'])} stalled solves)",
                "code_version": CODE_VERSION, "input_hash": digest, "resolution": [int(r) for r in shell["resolution"]],
                "theta_ref_deg": float(shell["theta_ref_deg"]), "build_seconds": round(seconds, 2)}
        result[m] = dict(write_table(path, m, fem, meta, arms[m]), cached=cached, written=True)
        if not coarse:
            store_shell(shell, folder)
    return result
