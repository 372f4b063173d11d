"""`shoulder-bench fem footprint`: the footprint sheets' moment arms beside the MJCF tendons' over a grid of poses
(docs/fem.md "Footprint sheets"), as a table, a JSON file and a figure."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from tqdm import tqdm

from shoulder_bench.authoring.fem.footprint import TENDONS
from shoulder_bench.authoring.fem.footprint_compare import compare
from shoulder_bench.full_arm import COORDINATE_LABELS, COORDINATES, Pose
from shoulder_bench.muscle import replacing

# Planes x elevations x rotations: the tasks' pose space (full_arm.POSE_RANGE_DEG) at its ends and middle.
PLANES_DEG = (0.0, 45.0, 90.0)
ELEVATIONS_DEG = tuple(np.arange(0.0, 140.0 + 1e-9, 20.0))
ROTATIONS_DEG = (-45.0, 0.0, 45.0)
FIGURE_PLANE_DEG = 45.0


def report_poses() -> np.ndarray:
    """(72, 3) the report's poses (deg: plane, elevation, rotation)."""
    grid = np.meshgrid(PLANES_DEG, ELEVATIONS_DEG, ROTATIONS_DEG, indexing="ij")
    return np.stack(grid, axis=-1).reshape(-1, 3)


ACTIVE_STRETCH = (0.6, 1.4)  # Blemker's active force-length curve's middle piece (f_active >= 0.36 within it)


def summary(result: dict) -> dict:
    """Per coordinate: RMS and largest |FEM - MJCF| and the MJCF arm's RMS, mm, over the converged poses ("all")
    and over those of them whose central fibre stretch is inside ACTIVE_STRETCH ("active": the sheet taut by its
    active force, neither slack nor held by passive force alone)."""
    ok = result["converged"]
    lo, hi = ACTIVE_STRETCH
    active = ok & (result["stretch"] >= lo) & (result["stretch"] <= hi)
    out = {"tendon": result["tendon"], "converged": int(ok.sum()), "active_poses": int(active.sum()),
           "poses": int(len(ok)), "width_mm": result["width_m"] * 1e3,
           "contact_N_median": float(np.median(result["contact_N"][ok])),
           "stretch_range": [float(result["stretch"].min()), float(result["stretch"].max())]}
    for subset, sel in (("all", ok), ("active", active)):
        diff = (result["fem_m"] - result["mjcf_m"])[sel] * 1e3
        mjcf = result["mjcf_m"][sel] * 1e3
        out[subset] = {COORDINATE_LABELS[c]: {"rms_diff_mm": float(np.sqrt(np.mean(diff[:, k] ** 2))),
                                              "max_diff_mm": float(np.max(np.abs(diff[:, k]))),
                                              "mjcf_rms_mm": float(np.sqrt(np.mean(mjcf[:, k] ** 2)))}
                       for k, c in enumerate(COORDINATES)} if sel.any() else None
    return out


def figure(results: list[dict], path: Path, surface: str = "wrap") -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(results), 3, figsize=(11, 2.9 * len(results)), squeeze=False, sharex=True)
    colours = dict(zip(ROTATIONS_DEG, ("tab:blue", "tab:green", "tab:red")))
    for row, res in zip(axes, results):
        poses = res["poses_deg"]
        for rot, col in colours.items():
            sel = (poses[:, 0] == FIGURE_PLANE_DEG) & (poses[:, 2] == rot)
            for k, ax in enumerate(row):
                ax.plot(poses[sel, 1], res["mjcf_m"][sel, k] * 1e3, "--", color=col, lw=1)
                ax.plot(poses[sel, 1], res["fem_m"][sel, k] * 1e3, "-o", color=col, ms=3, lw=1.5,
                        label=f"rotation {rot:+.0f}°")
        for k, ax in enumerate(row):
            ax.set_title(f"{res['tendon']}: {COORDINATE_LABELS[COORDINATES[k]]}", fontsize=9)
            ax.axhline(0, color="0.7", lw=0.5)
            ax.grid(alpha=0.3)
        row[0].set_ylabel("moment arm (mm)")
    axes[0, 0].legend(fontsize=7, title="FEM (solid), MJCF (dashed)", title_fontsize=7)
    for ax in axes[-1]:
        ax.set_xlabel(f"elevation (°), plane {FIGURE_PLANE_DEG:.0f}°")
    on = "the MJCF wrap objects" if surface == "wrap" else "the humeral head sphere"
    what = "taut bands" if results and results[0].get("rest") == "pose" else "sheets"
    fig.suptitle(f"Footprint {what} (solved line of action, contact with {on}) vs the MJCF tendon paths", fontsize=10)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def each_tendon(tendons, poses_each: int, desc: str, solve) -> list:
    """solve(tendon, progress) for every tendon under one progress bar of `poses_each` poses a tendon; a tendon
    without a sheet (a ValueError, raised before any solve) is skipped, saying why; none left is a ValueError. The
    footprint commands' loop."""
    results, skipped = [], []
    with tqdm(total=len(tendons) * poses_each, desc=desc, unit="pose") as bar:
        for t in tendons:
            try:
                results.append(solve(t, bar.update))
            except ValueError as exc:
                bar.update(poses_each)
                tqdm.write(f"skipped: {exc}")
                skipped.append(str(exc))
    if not results:
        raise ValueError(f"no sheet to solve: {'; '.join(skipped) or 'no tendon given'}")
    return results


def output_stem(out: Path, name: str, surface: str, rest: str = "reference") -> Path:
    """`out`/name[_taut][_SURFACE] (_taut: the taut band, rest="pose"; _SURFACE unless the wrap contact), `out`
    created: where a footprint command writes."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    name = name if rest == "reference" else f"{name}_taut"
    return out / (name if surface == "wrap" else f"{name}_{surface}")


def write_json(path: Path, data: dict) -> None:
    with replacing(path) as tmp:  # written whole or not at all
        tmp.write_text(json.dumps(data, indent=1))


def run(tendons=TENDONS, resolution: str = "full", out: Path | None = None, surface: str = "wrap",
        rest: str = "reference") -> list[dict]:
    """Solve every tendon at every report pose with contact on `surface` (`footprint.SURFACES`; a tendon whose
    sheet cannot touch it is skipped, saying why) from the stress-free state `rest` (`footprint.RESTS`); print the
    table; with `out`, write footprint[_taut][_head].json and footprint[_taut][_head]_moment_arms.png there."""
    poses, pose = report_poses(), Pose()  # one compiled model for every tendon
    results = each_tendon(tendons, len(poses), "footprint sheets", lambda t, progress: compare(
        t, poses, resolution, progress=progress, surface=surface, pose=pose, rest=rest))
    rows = [summary(r) for r in results]
    print("|FEM - MJCF| moment arm, RMS / largest (the MJCF arm's RMS), mm")
    print("tendon  width  stretch    poses         plane               elevation           rotation         contact")
    for s in rows:
        for subset in ("all", "active"):
            if s[subset] is None:
                continue
            count = s["converged"] if subset == "all" else s["active_poses"]
            cells = "  ".join(f"{s[subset][c]['rms_diff_mm']:5.1f} / {s[subset][c]['max_diff_mm']:5.1f} "
                              f"({s[subset][c]['mjcf_rms_mm']:4.1f})" for c in ("plane", "elevation", "rotation"))
            head = (f"{s['tendon']:<6} {s['width_mm']:3.0f} mm  {s['stretch_range'][0]:.2f}-{s['stretch_range'][1]:.2f}"
                    if subset == "all" else " " * 26)
            tail = f"median {s['contact_N_median']:.0f} N" if subset == "all" else ""
            print(f"{head}  {subset:>6} {count:>2}/{s['poses']}  {cells}  {tail}")
    if out is not None:
        stem = output_stem(out, "footprint", surface, rest)
        data = {"resolution": resolution, "surface": surface, "rest": rest, "summary": rows,
                "poses": [{"tendon": r["tendon"], "pose_deg": p.tolist(), "converged": bool(ok),
                           "stretch": float(lam), "fem_mm": (f * 1e3).tolist() if ok else None,
                           "mjcf_mm": (j * 1e3).tolist(), "tension_N": float(ten) if ok else None}
                          for r in results for p, f, j, ok, lam, ten in zip(r["poses_deg"], r["fem_m"], r["mjcf_m"],
                                                                             r["converged"], r["stretch"],
                                                                             r["tension_N"])]}
        write_json(stem.with_name(stem.name + ".json"), data)
        with replacing(stem.with_name(stem.name + "_moment_arms.png")) as tmp:
            figure(results, tmp, surface)
        print(f"wrote {stem}.json and {stem}_moment_arms.png")
    return results


def mesh_difference(a: Path, b: Path) -> dict:
    """Per tendon, the largest |moment arm difference| (mm, per coordinate) between two reports (footprint.json of
    two runs, e.g. coarse and full sheets) over the poses both solved; prints it."""
    runs = [json.loads(Path(p).read_text()) for p in (a, b)]
    keyed = [{(r["tendon"], tuple(r["pose_deg"])): r["fem_mm"] for r in run["poses"]} for run in runs]
    out = {}
    for tendon in dict.fromkeys(t for t, _ in keyed[0]):
        both = [(keyed[0][k], keyed[1][k]) for k in keyed[0] if k[0] == tendon and keyed[0][k] and keyed[1].get(k)]
        if not both:
            print(f"{tendon}: no pose solved in both")
            continue
        diff = np.abs(np.array([x for x, _ in both]) - np.array([y for _, y in both]))
        out[tendon] = {"poses": len(both), "max_diff_mm": diff.max(0).tolist()}
        print(f"{tendon}: {len(both)} poses solved in both ({runs[0]['resolution']} vs {runs[1]['resolution']}); "
              f"largest difference plane {diff[:, 0].max():.2f}, elevation {diff[:, 1].max():.2f}, rotation "
              f"{diff[:, 2].max():.2f} mm")
    return out


if __name__ == "__main__":  # python -m shoulder_bench.authoring.fem.footprint_report A/footprint.json B/footprint.json
    import sys

    mesh_difference(*sys.argv[1:3])
