"""`shoulder-bench fem footprint --grid`: would a table of the footprint sheets' torque vector on the tasks' pose grid
meet issue 12 §2's 2 % bound? (docs/fem.md "Footprint sheets: the pose grid")

The scheme under test (docs/fem.md "Activation"): the torque vector tabled on `full_arm.pose_grid` (plane every 15°,
elevation 10°, rotation 15°) at a = 0 and a = 1, trilinear in the pose and linear in the activation. The check, as
`fem verify --full`'s: held-out poses halfway between the grid's in every coordinate (`verify_full.held_out_poses`;
N of them drawn with a fixed seed), re-solved at a = 0.5 (between the levels), against the scheme's value there.
Only what the check needs is solved: at a cell's centre trilinear interpolation is the mean of its 8 corners, so the
corners of the drawn cells at a = 0 and 1 and the centres at a = 0, 0.5 and 1. Errors per coordinate in % of the
tendon's peak |torque| over the solved grid corners and both levels (a peak over fewer poses than the whole grid's
can only be smaller, so the percentages can only be larger than against the full table's). Split into the pose
interpolation's part (corners' mean against the centre, at a = 1 and a = 0) and the whole scheme's (a = 0.5).
"""
from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np

from shoulder_bench import full_arm
from shoulder_bench.authoring.fem.footprint_activation import solve_levels
from shoulder_bench.authoring.fem.footprint_report import each_tendon, output_stem, write_json
from shoulder_bench.authoring.fem.verify_full import HELD_OUT_TOL, held_out_poses

CELLS = 24  # held-out poses (cells) per tendon
SEED = 0


def cells(n: int = CELLS, seed: int = SEED) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(centres (n, 3), the grid poses at their corners (m, 3), corner index (n, 8) into them): n held-out poses."""
    held = held_out_poses()
    centres = held[np.sort(np.random.default_rng(seed).choice(len(held), n, replace=False))]
    half = np.array([full_arm.POSE_STEP_DEG[c] / 2 for c in full_arm.COORDINATES])
    signs = np.array(list(itertools.product((-1.0, 1.0), repeat=3)))
    corners = centres[:, None, :] + signs[None] * half
    unique, index = np.unique(corners.reshape(-1, 3), axis=0, return_inverse=True)
    return centres, unique, index.reshape(n, 8)


def check(tendon: str, n: int = CELLS, resolution: str = "full", surface: str = "wrap", pose=None,
          progress=None) -> dict:
    """The errors of the module docstring for `tendon` over `n` held-out cells (NaN where a solve failed)."""
    pose = pose or full_arm.Pose()
    centres, corners, index = cells(n)
    grid = solve_levels(tendon, corners, resolution, surface, pose, progress, levels=(0.0, 1.0))["torque_Nm"]
    mid = solve_levels(tendon, centres, resolution, surface, pose, progress, levels=(0.0, 0.5, 1.0))["torque_Nm"]
    peak = np.nanmax(np.abs(grid), axis=(0, 1))
    corner_mean = grid[index].mean(axis=1)  # (n, 2, 3): trilinear at the centres, a = 0 and 1
    pct = {"pose_a1": np.abs(corner_mean[:, 1] - mid[:, 2]) / peak * 100,
           "pose_a0": np.abs(corner_mean[:, 0] - mid[:, 0]) / peak * 100,
           "scheme_a05": np.abs(corner_mean.mean(axis=1) - mid[:, 1]) / peak * 100}
    ok = np.isfinite(sum(v.sum(axis=1) for v in pct.values()))
    out = {"tendon": tendon, "cells": n, "checked": int(ok.sum()), "peak_torque_Nm": dict(zip(full_arm.COORDINATES,
                                                                                             peak.tolist()))}
    for key, v in pct.items():
        out[key] = dict(zip(full_arm.COORDINATES, v[ok].max(axis=0).tolist())) if ok.any() else None
    worst = out["scheme_a05"]
    out["within_tol"] = bool(worst is not None and max(worst.values()) <= HELD_OUT_TOL * 100)
    return out


def run(tendons, resolution: str = "full", out: Path | None = None, surface: str = "wrap", n: int = CELLS):
    """`check` for every tendon; prints a table; with `out`, writes footprint_grid[_head].json there."""
    pose = full_arm.Pose()
    rows = each_tendon(tendons, len(cells(n)[1]) + n, "footprint sheets, grid check",
                       lambda t, progress: check(t, n, resolution, surface, pose, progress))
    labels = [full_arm.COORDINATE_LABELS[c] for c in full_arm.COORDINATES]
    print(f"largest error over the held-out cells, % of the tendon's peak |torque| (bound {HELD_OUT_TOL * 100:g} %); "
          f"{resolution} sheets, contact: {surface}; columns: " + ", ".join(labels))
    print("tendon  cells   pose interpolation, a = 1   pose interpolation, a = 0   scheme at a = 0.5 (pose + a)")
    for r in rows:
        cols = ["   ".join("   -  " if r[k] is None else f"{r[k][c]:6.2f}" for c in full_arm.COORDINATES)
                for k in ("pose_a1", "pose_a0", "scheme_a05")]
        print(f"{r['tendon']:<6} {r['checked']:>2}/{r['cells']}   " + "     ".join(cols)
              + ("" if r["within_tol"] else "   over the bound"))
    if out is not None:
        path = output_stem(out, "footprint_grid", surface).with_suffix(".json")
        write_json(path, {"resolution": resolution, "surface": surface, "seed": SEED,
                          "step_deg": full_arm.POSE_STEP_DEG, "tendons": rows})
        print(f"wrote {path}")
    return rows
