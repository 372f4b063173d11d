"""The Hill-type alternative to the FEM tables (`muscle_model="hill"`).

A classic rigid-tendon Hill model (Thelen 2003 curves) on the MJCF tendon paths: the fibre length is the path
length minus a tendon slack length chosen so that the fibres are at optimal length at OPTIMAL_ANGLE_DEG, the active
force-length curve is exp(-(l-1)^2 / 0.45), the passive curve (exp(4 (l-1) / 0.6) - 1) / (exp(4) - 1) for l > 1.
F0 from MoBL-ARMS (anatomy.F0). The force-velocity factor is applied at run time by `muscle.ForceLaw`.

`python -m shoulder_bench.authoring.hill` rewrites models/muscles/*_hill.npz.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from shoulder_bench.authoring import anatomy
from shoulder_bench.model import MODEL_PATH, tendon_geometry

ANGLE_GRID_DEG = np.arange(-10.0, 160.0 + 1e-9, 5.0)
ACTIVATION_GRID = np.array([0.0, 0.5, 1.0])  # the law is linear in activation, so interpolation is exact
OPTIMAL_ANGLE_DEG = {"ssp": 30.0, "isp": 45.0, "dmi": 60.0, "ld": 60.0}  # our assumption: mid working range
CODE_VERSION = "hill-1"


def active_force_length(l_norm: np.ndarray) -> np.ndarray:
    return np.exp(-((l_norm - 1.0) ** 2) / 0.45)


def passive_force_length(l_norm: np.ndarray) -> np.ndarray:
    return np.where(l_norm > 1.0, (np.exp(4.0 * (l_norm - 1.0) / 0.6) - 1.0) / (np.exp(4.0) - 1.0), 0.0)


def build_tables(folder: Path | None = None, path: Path | str = MODEL_PATH) -> list[Path]:
    from shoulder_bench.muscle import replacing, table_path

    lengths, arms = tendon_geometry(ANGLE_GRID_DEG, path)
    written = []
    for muscle in anatomy.MUSCLES:
        l_opt = anatomy.OPTIMAL_FIBRE_LENGTH[muscle]
        at_optimum = np.interp(OPTIMAL_ANGLE_DEG[muscle], ANGLE_GRID_DEG, lengths[muscle])  # optimal angles on grid
        l_norm = 1.0 + (lengths[muscle] - at_optimum) / l_opt
        f = anatomy.F0[muscle] * (ACTIVATION_GRID[None, :] * active_force_length(l_norm)[:, None]
                                  + passive_force_length(l_norm)[:, None])
        meta = {"model": "hill", "muscle": muscle, "law": "Thelen 2003 rigid-tendon Hill curves",
                "F0_N": anatomy.F0[muscle], "optimal_fibre_length_m": l_opt,
                "optimal_angle_deg": OPTIMAL_ANGLE_DEG[muscle],
                "grid": {"angle_deg": [ANGLE_GRID_DEG[0], ANGLE_GRID_DEG[-1], 5.0],
                         "activation": ACTIVATION_GRID.tolist()},
                "code_version": CODE_VERSION}
        out = table_path(muscle, "hill", folder)
        with replacing(out) as tmp:
            np.savez(tmp, angle_deg=ANGLE_GRID_DEG, activation=ACTIVATION_GRID, force_N=f,
                     torque_Nm=f * arms[muscle][:, None], moment_arm_m=arms[muscle], meta=np.array(json.dumps(meta)))
        written.append(out)
    return written


if __name__ == "__main__":
    for p in build_tables():
        print(p)
