"""`shoulder-bench fem footprint --activation`: how the footprint sheets' solved torque depends on the activation
(docs/fem.md "Footprint sheets: activation"), the question a table over pose x activation (issue 12 §2) turns on.

Each sheet (`footprint.FootprintSheet`) is solved at every report pose (`footprint_report.report_poses`) at the
activations LEVELS. Per tendon and coordinate it reports
- the line of action: the moment arm (torque / tension) at a = 0.25 and 0.5 against a = 1, largest |difference| in mm,
  over the poses where the sheet is taut at both (tension >= TAUT of F0). If it does not move, a table may store the
  moment arms over the poses alone and the force over (length, activation): the scheme the length-keyed tables use;
- linearity in activation: |tau(a) - ((1 - a) tau(0) + a tau(1))| at a = 0.25 and 0.5, largest over the poses, in %
  of the tendon's peak |tau| in that coordinate (over the poses and levels). If it is small, two levels suffice.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from shoulder_bench.authoring.fem.footprint import FootprintSheet
from shoulder_bench.authoring.fem.solver import NoConvergence
from shoulder_bench.full_arm import COORDINATE_LABELS, COORDINATES, Pose

LEVELS = (0.0, 0.25, 0.5, 1.0)
TAUT = 0.01  # of F0: below it the moment arm (torque / tension) is not compared


def solve_levels(tendon: str, poses: np.ndarray, resolution: str, surface: str, pose: Pose, progress=None,
                 levels=LEVELS) -> dict:
    """Torque (P, L, 3) N m, tension and contact force (P, L) N of `tendon`'s sheet at `poses` x `levels` (NaN: no
    equilibrium).

    At each pose the sheet is solved at a = 1 (`FootprintSheet.solve`: from the reference pose) and then continued
    down the levels at that pose (the solver's activation continuation, steps <= 0.25), which is several times
    cheaper than walking every level from the reference; where that fails the level is solved from the reference."""
    sheet = FootprintSheet(tendon, resolution, pose=pose, surface=surface)
    torque = np.full((len(poses), len(levels), 3), np.nan)
    tension = np.full((len(poses), len(levels)), np.nan)
    contact = np.full((len(poses), len(levels)), np.nan)
    for k, p in enumerate(poses):
        above = None  # (nodes, activation) of the last level solved at this pose
        for j in sorted(range(len(levels)), key=lambda i: -levels[i]):
            a = levels[j]
            try:
                if above is None:
                    s = sheet.solve(p, a)
                else:
                    try:
                        x, _ = sheet.problem.step(above[0], (0.0, above[1]), (0.0, a))
                        s = sheet.reduce(x, a)
                    except NoConvergence:
                        s = sheet.solve(p, a)
            except NoConvergence:
                above = None
                continue
            above = (s["nodes"], a)
            torque[k, j], tension[k, j], contact[k, j] = s["torque_Nm"], s["tension_N"], s["contact_N"]
        if progress is not None:
            progress()
    return {"tendon": tendon, "poses_deg": poses, "levels": tuple(levels), "torque_Nm": torque, "tension_N": tension,
            "contact_N": contact, "f0_N": sheet.f0}


def measures(res: dict) -> dict:
    """The line-of-action and linearity measures of the module docstring from `solve_levels`' result."""
    tau, ten, f0, levels = res["torque_Nm"], res["tension_N"], res["f0_N"], res["levels"]
    one, zero = levels.index(1.0), levels.index(0.0)
    ok = np.isfinite(tau).all(axis=(1, 2))  # poses solved at every level
    peak = np.nanmax(np.abs(tau[ok]), axis=(0, 1))
    out = {"tendon": res["tendon"], "poses": int(len(ok)), "solved": int(ok.sum()),
           "peak_torque_Nm": dict(zip(COORDINATES, peak.tolist())), "arm_mm": {}, "linearity_pct": {}}
    for a in (0.25, 0.5):
        j = levels.index(a)
        taut = ok & (ten[:, j] >= TAUT * f0) & (ten[:, one] >= TAUT * f0)
        d_arm = np.abs(tau[taut, j] / ten[taut, j, None] - tau[taut, one] / ten[taut, one, None]) * 1e3
        line = (1 - a) * tau[ok, zero] + a * tau[ok, one]
        d_lin = np.abs(tau[ok, j] - line).max(axis=0) / peak * 100
        out["arm_mm"][str(a)] = {"taut_poses": int(taut.sum()),
                                 **dict(zip(COORDINATES, (d_arm.max(axis=0) if taut.any() else [np.nan] * 3)))}
        out["linearity_pct"][str(a)] = dict(zip(COORDINATES, d_lin.tolist()))
    out["arm_mm"] = {a: {k: v if k == "taut_poses" else float(v) for k, v in d.items()}
                     for a, d in out["arm_mm"].items()}
    return out


def run(tendons, resolution: str = "coarse", out: Path | None = None, surface: str = "wrap") -> list[dict]:
    """Solve every tendon at the report poses x LEVELS, print the measures; with `out`, write
    footprint_activation[_head].json there."""
    from shoulder_bench.authoring.fem.footprint_report import each_tendon, output_stem, report_poses, write_json

    poses, pose = report_poses(), Pose()
    rows = each_tendon(tendons, len(poses), "footprint sheets x activations",
                       lambda t, progress: measures(solve_levels(t, poses, resolution, surface, pose, progress)))
    labels = [COORDINATE_LABELS[c] for c in COORDINATES]
    print(f"line of action: largest |moment arm at a - at a = 1| (mm), taut poses; linearity: largest |tau(a) - "
          f"linear between a = 0 and 1| (% of peak); {resolution} sheets, contact: {surface}")
    print("tendon  solved   a     taut   arm " + " ".join(f"{x:>9}" for x in labels) + "   linearity "
          + " ".join(f"{x:>9}" for x in labels))
    for r in rows:
        for a in ("0.25", "0.5"):
            arm, lin = r["arm_mm"][a], r["linearity_pct"][a]
            print(f"{r['tendon']:<6} {r['solved']:>3}/{r['poses']}  {a:>4}  {arm['taut_poses']:>4}      "
                  + " ".join(f"{arm[c]:9.2f}" for c in COORDINATES) + "             "
                  + " ".join(f"{lin[c]:8.2f}%" for c in COORDINATES))
    if out is not None:
        path = output_stem(out, "footprint_activation", surface).with_suffix(".json")
        write_json(path, {"resolution": resolution, "surface": surface, "levels": LEVELS, "taut_fraction_f0": TAUT,
                          "tendons": rows})
        print(f"wrote {path}")
    return rows
