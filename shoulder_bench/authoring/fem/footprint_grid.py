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

`refine` K > 1 asks the same of a grid K times finer in every coordinate: each drawn cell is replaced by one of its
K^3 sub-cells (drawn with the same seed), so the refined check looks at the same places in the pose space and its
errors can be set beside the tasks' grid's cell by cell (how the error falls with the step, and where it stays).
Every cell's record (centre, the scheme's error, the sheet's tension and contact force at the centre at a = 1) is
written, to say where the largest errors lie: at slack, at contact onset, or neither.

A second score, `arm_a05`, asks how much of the error is the force's and how much the line of action's: the same
interpolated torque rescaled to the sheet's own tension at the centre (T_centre tau_table / T_table, T_table the
tension interpolated as the torque is). It is what a table of the line of action beside an exact force law would
give, the scheme of the length-keyed tables with the FEM's line of action in place of the MJCF path's. The solves
are written beside the JSON (npz); `python -m shoulder_bench.authoring.fem.footprint_grid FILE.npz ...` scores them
again.

With rest="pose" (`check_taut`, `--rest pose`) the sheet is the taut band (`footprint.RESTS`): what is tabled is its
line of action alone, the moment arms (torque / tension) at a = 1, for a force law that gives the force; corners and
centres are solved at a = 1, each on its own. Three scores, in % of the band's peak |moment arm| over the corners:
arm_a1, the band's arms tabled trilinearly; mjcf_a1, the MJCF tendon's own arms (-ten_J S) tabled the same way (how
fast the model's geometry turns, whatever the muscle); correction_a1, the band's arms as the MJCF arm (exact at
every pose, as MuJoCo's tendon applies it) plus a table of the difference band - MJCF. `within_tol` is the last's.
"""
from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np

from shoulder_bench import full_arm
from shoulder_bench.authoring.fem.footprint_activation import solve_levels
from shoulder_bench.authoring.fem.footprint_compare import compare
from shoulder_bench.authoring.fem.footprint_report import each_tendon, output_stem, write_json
from shoulder_bench.authoring.fem.verify_full import HELD_OUT_TOL, held_out_poses
from shoulder_bench.muscle import replacing

CELLS = 24  # held-out poses (cells) per tendon
SEED = 0


def cells(n: int = CELLS, seed: int = SEED, refine=1) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(centres (n, 3), the grid poses at their corners (m, 3), corner index (n, 8) into them): n held-out poses of
    the tasks' grid, or with `refine` K (or one per coordinate) one sub-cell of each of them on the grid K times
    finer."""
    rng = np.random.default_rng(seed)
    held = held_out_poses()
    centres = held[np.sort(rng.choice(len(held), n, replace=False))]
    half = np.array([full_arm.POSE_STEP_DEG[c] / 2 for c in full_arm.COORDINATES])
    k = np.broadcast_to(np.asarray(refine), (3,))
    if (k > 1).any():  # sub-cell i (0..K-1 per coordinate) of a cell: centre at -h + (2i + 1) h / K from the cell's
        sub = rng.integers(0, k, size=(n, 3))
        centres = centres - half + (2 * sub + 1) * half / k
        half = half / k
    signs = np.array(list(itertools.product((-1.0, 1.0), repeat=3)))
    corners = centres[:, None, :] + signs[None] * half
    unique, index = np.unique(corners.reshape(-1, 3).round(9), axis=0, return_inverse=True)
    return centres, unique, index.reshape(n, 8)


def check(tendon: str, n: int = CELLS, resolution: str = "full", surface: str = "wrap", pose=None,
          progress=None, refine: int = 1) -> dict:
    """The errors of the module docstring for `tendon` over `n` held-out cells (NaN where a solve failed)."""
    pose = pose or full_arm.Pose()
    centres, corners, index = cells(n, refine=refine)
    corner_solves = solve_levels(tendon, corners, resolution, surface, pose, progress, levels=(0.0, 1.0))
    mid = solve_levels(tendon, centres, resolution, surface, pose, progress, levels=(0.0, 0.5, 1.0))
    solves = {"corners_deg": corners, "corner_index": index, "centres_deg": centres,
              **{f"corner_{k}": corner_solves[k] for k in ("torque_Nm", "tension_N", "contact_N")},
              **{f"centre_{k}": mid[k] for k in ("torque_Nm", "tension_N", "contact_N")}, "f0_N": mid["f0_N"]}
    pct, peak = scores(solves)
    ok = solved(pct)
    out = {"tendon": tendon, "cells": n, "refine": refine, "checked": int(ok.sum()),
           "peak_torque_Nm": dict(zip(full_arm.COORDINATES, peak.tolist()))}
    for key, v in pct.items():
        out[key] = dict(zip(full_arm.COORDINATES, v[ok].max(axis=0).tolist())) if ok.any() else None
    worst = out["scheme_a05"]
    out["within_tol"] = bool(worst is not None and max(worst.values()) <= HELD_OUT_TOL * 100)
    tension, contact = mid["tension_N"][:, 2] / mid["f0_N"] * 100, mid["contact_N"][:, 2]
    out["cell_records"] = [{"centre_deg": centres[i].tolist(),
                            **{f"{k}_pct": pct[k][i].tolist() if ok[i] else None for k in ("scheme_a05", "arm_a05")},
                            "tension_a1_pct_f0": _finite(tension[i]), "contact_a1_N": _finite(contact[i])}
                           for i in range(n)]
    out["solves"] = solves  # not in the JSON: `run` writes them to the npz
    return out


def check_taut(tendon: str, n: int = CELLS, resolution: str = "full", surface: str = "wrap", pose=None,
               progress=None, refine: int = 1) -> dict:
    """The taut band's check (rest="pose"): its moment arms (torque / tension at a = 1) tabled on the grid, trilinear
    in the pose, against the band re-solved at the held-out centres; errors in % of the tendon's peak |moment arm|
    over the solved corners, per coordinate (score "arm_a1"). Every pose is solved on its own (no walk)."""
    pose = pose or full_arm.Pose()
    centres, corners, index = cells(n, refine=refine)
    solves = {"corners_deg": corners, "corner_index": index, "centres_deg": centres}
    for name, poses in (("corner", corners), ("centre", centres)):
        r = compare(tendon, poses, resolution, progress=progress, surface=surface, pose=pose, rest="pose")
        solves.update({f"{name}_arm_m": r["fem_m"], f"{name}_mjcf_m": r["mjcf_m"],
                       f"{name}_tension_N": r["tension_N"], f"{name}_contact_N": r["contact_N"]})
    solves["f0_N"] = np.array(r["f0_N"])
    pct, peak = scores(solves)
    ok = solved(pct)
    worst = {k: dict(zip(full_arm.COORDINATES, v[ok].max(axis=0).tolist())) if ok.any() else None
             for k, v in pct.items()}
    return {"tendon": tendon, "cells": n, "refine": refine, "checked": int(ok.sum()), "rest": "pose",
            "peak_moment_arm_mm": dict(zip(full_arm.COORDINATES, (peak * 1e3).tolist())), **worst,
            "within_tol": bool(worst["correction_a1"] is not None
                               and max(worst["correction_a1"].values()) <= HELD_OUT_TOL * 100),
            "cell_records": [{"centre_deg": centres[i].tolist(),
                              **{f"{k}_pct": v[i].tolist() if ok[i] else None for k, v in pct.items()},
                              "tension_a1_pct_f0": _finite(solves["centre_tension_N"][i] / solves["f0_N"] * 100),
                              "contact_a1_N": _finite(solves["centre_contact_N"][i])} for i in range(n)],
            "solves": solves}


def scores(s: dict) -> tuple[dict, np.ndarray]:
    """({score: (n, 3) % of the peak}, peak (3,)) from a cell check's solves (`check`'s or `check_taut`'s "solves",
    or the npz): the module docstring's pose_a1, pose_a0, scheme_a05 and arm_a05 (peak in N m), or the taut band's
    arm_a1 (peak |moment arm| in m)."""
    if "corner_arm_m" in s:  # the taut band's: its arms tabled; the MJCF arms alone; the band's correction tabled
        i, peak = s["corner_index"], np.nanmax(np.abs(s["corner_arm_m"]), axis=0)
        band, mjcf = s["corner_arm_m"], s["corner_mjcf_m"]
        pct = {"arm_a1": np.abs(band[i].mean(axis=1) - s["centre_arm_m"]),
               "mjcf_a1": np.abs(mjcf[i].mean(axis=1) - s["centre_mjcf_m"]),
               "correction_a1": np.abs((band - mjcf)[i].mean(axis=1) - (s["centre_arm_m"] - s["centre_mjcf_m"]))}
        return {k: v / peak * 100 for k, v in pct.items()}, peak
    grid, tension = s["corner_torque_Nm"][s["corner_index"]], s["corner_tension_N"][s["corner_index"]]
    tau, t_centre = s["centre_torque_Nm"], s["centre_tension_N"]
    peak = np.nanmax(np.abs(s["corner_torque_Nm"]), axis=(0, 1))
    corner_mean, tension_mean = grid.mean(axis=1), tension.mean(axis=1)  # (n, 2, 3), (n, 2): a = 0 and 1
    table, t_table = corner_mean.mean(axis=1), tension_mean.mean(axis=1)  # at a = 0.5
    with np.errstate(invalid="ignore", divide="ignore"):
        arm = np.where(t_table[:, None] > 0, t_centre[:, 1, None] * table / t_table[:, None], 0.0)
    pct = {"pose_a1": np.abs(corner_mean[:, 1] - tau[:, 2]), "pose_a0": np.abs(corner_mean[:, 0] - tau[:, 0]),
           "scheme_a05": np.abs(table - tau[:, 1]), "arm_a05": np.abs(arm - tau[:, 1])}
    return {k: v / peak * 100 for k, v in pct.items()}, peak


def solved(pct: dict) -> np.ndarray:
    """(n,) the cells every score could be computed for (every solve they need found an equilibrium)."""
    return np.isfinite(sum(v.sum(axis=1) for v in pct.values()))


def _finite(x) -> float | None:
    return float(x) if np.isfinite(x) else None


def rescore(*paths) -> None:
    """Print the largest of every score per tendon from --grid runs' npz files; given several (the same cells at
    refinements K1, K2, ...: `refine`), also each tendon's per-cell error (N m, the largest over the coordinates)
    from one file to the next: the median ratio, over the cells solved in both, says how the error falls with the
    step (1/4 when it falls as the step squared, as trilinear interpolation of a smooth field does)."""
    worst, pose = {}, None
    for path in paths:
        data = np.load(path)
        print(path)
        for tendon in dict.fromkeys(k.split("/")[0] for k in data.files):
            s = {k.split("/")[1]: data[k] for k in data.files if k.startswith(tendon + "/")}
            if "corner_arm_m" in s and "corner_mjcf_m" not in s:  # a taut run saved before they were
                pose = pose or full_arm.Pose()
                for name in ("corner", "centre"):
                    s[f"{name}_mjcf_m"] = pose.tendon_geometry(s[f"{name}s_deg"], (tendon,))[1][:, 0]
            pct, peak = scores(s)
            ok = solved(pct)
            print(f"{tendon:<6} {ok.sum():>2}/{len(ok)}  " + "   ".join(
                f"{k} " + " ".join(f"{x:6.2f}" for x in v[ok].max(axis=0)) for k, v in pct.items()))
            worst.setdefault(tendon, []).append({k: (v * peak / 100).max(axis=1) for k, v in pct.items()})  # N m
    for tendon, runs in worst.items():
        for a, b in zip(runs, runs[1:]):
            print(f"{tendon:<6} per cell, this file's error / the previous file's (median over the cells solved in "
                  f"both): " + ", ".join(f"{k} {np.nanmedian(b[k] / a[k]):.2f}" for k in a))


def run(tendons, resolution: str = "full", out: Path | None = None, surface: str = "wrap", n: int = CELLS,
        refine: int = 1, rest: str = "reference"):
    """`check` (or with rest="pose" `check_taut`) for every tendon; prints a table; with `out`, writes
    footprint_grid[_taut][_head][_refineK].json there."""
    pose = full_arm.Pose()
    step = {c: full_arm.POSE_STEP_DEG[c] / refine for c in full_arm.COORDINATES}
    one = check if rest == "reference" else check_taut
    rows = each_tendon(tendons, len(cells(n, refine=refine)[1]) + n, "footprint sheets, grid check",
                       lambda t, progress: one(t, n, resolution, surface, pose, progress, refine))
    labels = [full_arm.COORDINATE_LABELS[c] for c in full_arm.COORDINATES]
    what = "|torque|" if rest == "reference" else "|moment arm| (the taut band's, a = 1; bound on the correction)"
    print(f"largest error over the held-out cells, % of the tendon's peak {what} (bound {HELD_OUT_TOL * 100:g} %); "
          f"{resolution} sheets, contact: {surface}; grid step {step} deg; columns: " + ", ".join(labels))
    keys = (("pose_a1", "pose_a0", "scheme_a05", "arm_a05") if rest == "reference"
            else ("arm_a1", "mjcf_a1", "correction_a1"))
    print("tendon  cells   pose interpolation, a = 1   pose interpolation, a = 0   scheme at a = 0.5 (pose + a)   "
          "line of action only, a = 0.5" if rest == "reference" else
          "tendon  cells   the band's arms tabled      the MJCF arms tabled        MJCF + the band's correction tabled")
    for r in rows:
        cols = ["   ".join("   -  " if r[k] is None else f"{r[k][c]:6.2f}" for c in full_arm.COORDINATES)
                for k in keys]
        print(f"{r['tendon']:<6} {r['checked']:>2}/{r['cells']}   " + "     ".join(cols)
              + ("" if r["within_tol"] else "   over the bound"))
    if out is not None:
        stem = output_stem(out, "footprint_grid", surface, rest)
        path = (stem.with_name(f"{stem.name}_refine{refine}") if refine > 1 else stem).with_suffix(".json")
        solves = {r["tendon"]: r.pop("solves") for r in rows}
        write_json(path, {"resolution": resolution, "surface": surface, "rest": rest, "seed": SEED, "refine": refine,
                          "step_deg": step, "tendons": rows})
        with replacing(path.with_suffix(".npz")) as tmp:  # levels: corners a = 0, 1, centres 0, 0.5, 1 (taut: a = 1)
            with open(tmp, "wb") as f:
                np.savez_compressed(f, **{f"{t}/{k}": v for t, d in solves.items() for k, v in d.items()})
        print(f"wrote {path} and {path.with_suffix('.npz').name}")
    return rows


if __name__ == "__main__":  # python -m shoulder_bench.authoring.fem.footprint_grid FILE.npz ...
    import sys

    rescore(*sys.argv[1:])
