"""Offline thin-shell (membrane) FEM of the four muscles, reduced to the force tables the MuJoCo callback reads.

material (Blemker fibres, co-rotational background) -> membrane (CST element) -> solver (Newton, contact) ->
shells (meshes from anatomy) -> build (tables) -> verify (held-out points, MuJoCo vs FEM torque, literature bands,
figure); cli wires `shoulder-bench fem build|verify`. See docs/fem.md.

Hashes of inputs (mesh_sha256, input_hash) are taken over values rounded to a stated precision, so that the last-bit
differences floating point gives on another CPU (~1e-16 relative) do not change them:
  arrays (mesh nodes and thicknesses in m, unit fibre vectors, theta_ref in degrees) to HASH_QUANTUM = 1e-10 of their
  unit (0.1 nm on a sheet ~0.1 m long); scalars (material, solver settings, grid) to HASH_DIGITS = 9 significant
  digits. A change of 1e-6 relative changes the hash; one of 1e-15 does not (unless a value sits within 1e-15 of a
  rounding boundary: about one chance in 10^5 per value).
"""
from __future__ import annotations

import os
import signal
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

CODE_VERSION = "1"  # bump when a change alters solutions; it is part of every table's input hash
HASH_QUANTUM = 1e-10
HASH_DIGITS = 9


def quantised(a) -> np.ndarray:
    """`a` as little-endian int64 for hashing: integers as they are, floats in units of HASH_QUANTUM."""
    a = np.asarray(a)
    if np.issubdtype(a.dtype, np.integer):
        return a.astype("<i8")
    return np.rint(a.astype(float) / HASH_QUANTUM).astype("<i8")


def rounded(obj):
    """A JSON-able structure with every float rounded to HASH_DIGITS significant digits (-0.0 becomes 0.0)."""
    if isinstance(obj, dict):
        return {k: rounded(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [rounded(v) for v in obj]
    if isinstance(obj, float):
        return float(f"{obj:.{HASH_DIGITS}g}") + 0.0
    return obj


def output_folder(path: Path | str, option: str) -> Path:
    """Check, before any work, that `path` can be the output folder: an existing writable folder, or a path whose
    nearest existing parent is a writable folder (the folder is created when the first file is written)."""
    path = Path(path)
    parent = path
    while not parent.exists() and parent != parent.parent:
        parent = parent.parent
    if parent.exists() and not parent.is_dir():
        what = "is an existing file" if parent == path else f"lies under {parent}, which is a file"
        raise ValueError(f"{option} {path} {what}, not a folder; give a folder (created if missing)")
    if not os.access(parent, os.W_OK):
        raise ValueError(f"{option} {path}: {parent} is not writable; give a folder you can write to")
    return path


def worker_init() -> None:
    """The initializer of a parallel build's worker processes (`fem build|verify --jobs N`). One BLAS thread: N
    processes on N cores, each with OpenBLAS's own threads behind LAPACK's banded LU (`assembly`), spin against each
    other (`fem build --full --jobs 2` ran slower banded than with SuperLU before this). And SIGTERM ends the worker:
    the CLI's handler, inherited through fork, turns it into KeyboardInterrupt, which a pool's worker returns as its
    task's error and then takes the next task, so a terminated build's workers went on solving."""
    threadpool_limits(1, user_api="blas")
    signal.signal(signal.SIGTERM, signal.SIG_DFL)


def neighbours_mean(field: np.ndarray, unsolved: np.ndarray) -> np.ndarray:
    """`field` (grid shape + (3,)) where each unsolved grid pose takes the mean of its solved neighbours' values (one
    step along each coordinate); a cluster of unsolved poses (tma's corner) in rounds, from its edge inward."""
    out, todo = field.copy(), unsolved.copy()
    while todo.any():
        filled = {}
        for idx in zip(*np.nonzero(todo)):
            near = [out[j] for j in (tuple(np.add(idx, step * np.eye(todo.ndim, dtype=int)[axis]))
                                     for axis in range(todo.ndim) for step in (-1, 1))
                    if all(0 <= k < n for k, n in zip(j, todo.shape)) and not todo[j]]
            filled.update({idx: np.mean(near, axis=0)} if near else {})
        if not filled:
            raise RuntimeError("no solved grid pose to take the unsolved poses' correction from")
        for idx, value in filled.items():
            out[idx], todo[idx] = value, False
    return out
