"""FEM tables of the v2 muscles: `python -m shoulder_bench.authoring.fem.v2 [--coarse] [--out DIR] [--plane P]
[--variant ld_transfer]` (a variant: its tendons on its model with its fibre parameters, into its folder;
`transfer.VARIANTS`, docs/surgery.md).

One table per v2 tendon (ssp, isp, dmi, ld1, ld2, ld3) of the locked 1-DOF variant, `models/muscles_v2/<t>_fem.npz`,
in hill_v2's format (angle_deg = hill.ANGLE_GRID_DEG, activation, force_N, torque_Nm, moment_arm_m, meta) so that
`ForceLaw.load("fem", muscles=hill_v2.TENDONS, folder=..., arms=...)` reads it (`load_law`):

* geometry: `hill_v2.geometry(plane)`: L_MT(q) = MuJoCo ten_length of the locked variant on its coupling and the
  total moment arm r = -ten_J S;
* force_N: the tendon force of the pennated FEM sheet (`v2_sheet`) whose axial extent is L_MT(q) - l_ts (rigid
  tendon at the parent's slack length), solved at every grid angle x ACTIVATIONS with continuation; solver noise of
  a slack sheet (|F| < NOISE_FORCE_N, either sign) is clamped to 0, anything more negative is an error;
* torque_Nm = force_N x moment_arm_m. The force acts along the MuJoCo tendon whose ten_J is the exact derivative of
  the length the sheet's extent comes from, so the torque MuJoCo applies equals torque_Nm (`applied_vs_table`).

Caching: meta.input_hash = SHA-256 of (sheet mesh hash, quantised sheet extents, sheet spec, material, solver
settings, grid, CODE_VERSION), rounded as shoulder_bench.authoring.fem says; a table whose hash matches is not
re-solved (its
moment arms and torque are refreshed if the model's arms changed; otherwise nothing is written). docs/fem.md, "v2
sheets".
"""
from __future__ import annotations

import argparse
import hashlib
import json
import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

from shoulder_bench import arm
from shoulder_bench.authoring import hill_v2, transfer
from shoulder_bench.authoring.fem import output_folder, quantised, rounded
from shoulder_bench.authoring.fem.build import NOISE_FORCE_N
from shoulder_bench.authoring.fem.material import Material
from shoulder_bench.authoring.fem.shells import mesh_sha256
from shoulder_bench.authoring.fem.solver import SolverSettings
from shoulder_bench.authoring.fem.v2_sheet import RESOLUTION, SheetProblem, SheetSpec, build_sheet
from shoulder_bench.authoring.hill import ANGLE_GRID_DEG
from shoulder_bench.muscle import replacing, table_path

CODE_VERSION = "fem-v2-1"  # bump when a change alters solutions; part of every table's input hash
FOLDER = hill_v2.FOLDER
TENDONS = hill_v2.TENDONS
ACTIVATIONS = np.array([0.0, 0.1, 0.25, 0.5, 0.75, 1.0])
SETTINGS = SolverSettings(max_step_deg=5.0)  # here: continuation steps of <= 5 % axial strain (v2_sheet)


def specs(variant: str | None = None) -> dict[str, SheetSpec]:
    params = transfer.variant(variant).parameters()
    return {t: SheetSpec.from_parent(t, p) for t, p in params.items()}


def grid_dict() -> dict:
    return {"angle_deg": [float(ANGLE_GRID_DEG[0]), float(ANGLE_GRID_DEG[-1]), 5.0],
            "activation": ACTIVATIONS.tolist()}


def input_hash(spec: SheetSpec, resolution, extents: np.ndarray, material: Material, settings: SolverSettings) -> str:
    sheet = build_sheet(spec, resolution, material.fibre)
    blob = json.dumps(rounded({"mesh": mesh_sha256(sheet), "spec": spec.as_dict(), "material": material.as_dict(),
                               "extents": hashlib.sha256(quantised(extents).tobytes()).hexdigest(),
                               "solver": settings.as_dict(), "grid": grid_dict(), "code_version": CODE_VERSION}),
                      sort_keys=True)
    return hashlib.sha256(blob.encode()).hexdigest()


def input_hashes(plane_deg: float, coarse: bool = False, material: Material | None = None,
                 settings: SolverSettings | None = None, variant: str | None = None) -> dict[str, str]:
    """What each table's input_hash would be (no solving): the shipped tables must carry these."""
    L, _ = hill_v2.geometry(plane_deg, variant=variant)
    res = "coarse" if coarse else "full"
    return {t: input_hash(s, res, L[:, k] - s.l_ts, material or Material(), settings or SETTINGS)
            for k, (t, s) in enumerate(specs(variant).items())}


def solve(spec: SheetSpec, extents: np.ndarray, resolution, material: Material, settings: SolverSettings,
          progress=None) -> dict:
    """The sheet over extents x ACTIVATIONS, from a = 1 down (a failing sweep restarts from the level above)."""
    problem = SheetProblem(spec, resolution, material, settings)
    k, j = len(extents), len(ACTIVATIONS)
    out = {"force": np.zeros((k, j)), "lateral_force_N": np.zeros((k, j)),
           "newton_iterations": np.zeros((k, j), int), "fibre_stretch": np.zeros((k, j, 3))}
    cb = None if progress is None else (lambda: progress.update(1))
    neighbour = None
    for c in range(j - 1, -1, -1):
        a = float(ACTIVATIONS[c])
        r = problem.sweep_extents(extents, a, callback=cb, neighbour=neighbour)
        out["force"][:, c], out["lateral_force_N"][:, c] = r["force_N"], r["lateral_N"]
        out["newton_iterations"][:, c], out["fibre_stretch"][:, c] = r["newton_iterations"], r["stretch"]
        neighbour = (a, r["x"])
    out["stalled_solves"] = np.array(problem.stalled)
    return out


def _cached(path: Path, digest: str) -> dict | None:
    try:
        with np.load(path, allow_pickle=False) as z:
            if json.loads(str(z["meta"])).get("input_hash") == digest:
                return {k: z[k] for k in z.files}
    except Exception:  # missing or unreadable: rebuild
        return None
    return None


def build(plane_deg: float | None = None, coarse: bool = False, out: Path | None = None, quiet: bool = False,
          material: Material | None = None, settings: SolverSettings | None = None,
          variant: str | None = None) -> dict[str, dict]:
    """Build (or reuse) each tendon's table in `out` (default models/muscles_v2, or the variant's folder). Returns
    {tendon: meta + cached, written}. --coarse needs --out (coarse tables never replace the shipped ones)."""
    v = transfer.variant(variant)
    if coarse and out is None:
        raise ValueError(f"--coarse without --out would replace the full tables in {v.folder}; give --out DIR")
    folder = output_folder(out if out is not None else v.folder, "--out")
    plane = hill_v2.default_plane() if plane_deg is None else float(plane_deg)
    material, settings = material or Material(), settings or SETTINGS
    res = "coarse" if coarse else "full"
    L, r = hill_v2.geometry(plane, variant=variant)
    todo, result = [], {}
    for k, (t, spec) in enumerate(specs(variant).items()):
        digest = input_hash(spec, res, L[:, k] - spec.l_ts, material, settings)
        path = table_path(t, "fem", folder)
        old = _cached(path, digest)
        if old is not None and np.allclose(old["moment_arm_m"], r[:, k], rtol=0.0, atol=1e-12):
            result[t] = dict(json.loads(str(old["meta"])), cached=True, written=False)
        else:
            todo.append((k, t, spec, digest, path, old))
    n_solve = sum(old is None for *_, old in todo) * len(ANGLE_GRID_DEG) * len(ACTIVATIONS)
    with tqdm(total=n_solve, desc="fem v2", disable=quiet or n_solve == 0) as bar:
        for k, t, spec, digest, path, old in todo:
            t0 = time.perf_counter()
            if old is None:
                fem = solve(spec, L[:, k] - spec.l_ts, res, material, settings, bar)
                meta = _meta(t, spec, plane, res, digest, material, settings, fem, time.perf_counter() - t0)
                if v.name is not None:
                    meta.update(variant=v.name, tendon_slack_rule=transfer.SLACK_RULE,
                                model_file=meta["model_file"].replace("mobl.", "transfer."))
            else:  # inputs unchanged, only the model's moment arms moved: refresh the arms and torque
                fem = {key: old[key] for key in ("lateral_force_N", "newton_iterations", "fibre_stretch",
                                                 "stalled_solves")}
                fem["force"] = old["force_N"]
                meta = json.loads(str(old["meta"]))
            _write(path, fem, L[:, k], L[:, k] - spec.l_ts, r[:, k], meta)
            result[t] = dict(meta, cached=old is not None, written=True)
    return result


def solve_meta(t: str, spec: SheetSpec, res: str, material: Material, settings: SolverSettings, fem: dict) -> dict:
    """The meta fields of a sheet's table that the v2 and full-shoulder builds share: parameters, sheet, material,
    solver, convergence; ValueError if the sheet pushes on its tendon beyond solver noise."""
    f = fem["force"]
    if np.any(f < -NOISE_FORCE_N):
        raise ValueError(f"{t}: sheet pushes on its tendon ({f.min():.3g} N): not solver noise")
    its = fem["newton_iterations"]
    return {"F0_N": spec.f0, "optimal_fibre_length_m": spec.l_opt, "tendon_slack_length_m": spec.l_ts,
            "pennation_angle_rad": spec.alpha0,
            "sheet": {"rest_extent_m": spec.rest_extent, "width_m": spec.width,
                      "thickness_m": spec.thickness(material.fibre.sigma_max),
                      "width_over_length": spec.width_over_length, "resolution": list(RESOLUTION[res])},
            "material": material.as_dict(), "solver": settings.as_dict(),
            "tolerance": f"max nodal residual < {settings.tol} F0 ({settings.stall_factor * settings.tol} F0 for "
                         f"{int(fem['stalled_solves'])} stalled solves)",
            "newton_iterations": {"total": int(its.sum()), "max_per_point": int(its.max())},
            "clamped_noise_N": float(max(0.0, -f.min())),
            "fibre_stretch_range": [float(fem["fibre_stretch"][..., 0].min()),
                                    float(fem["fibre_stretch"][..., 2].max())]}


def _meta(t, spec, plane, res, digest, material, settings, fem, seconds) -> dict:
    return {"model": "fem", "source": "fem", "muscle": t, "parent_muscle": hill_v2.PARENT_MUSCLE[t],
            "model_file": f"mobl.model_xml(locked_plane_deg={plane:g}, dynamics=True, actuators=True)",
            "plane_deg": float(plane), "joint": arm.JOINT, "girdle": "coupled",
            "law": "v2_sheet: pennated fibre membrane (Blemker fibres, co-rotational background) of axial extent "
                   "L_MT - l_ts in series with a rigid tendon; force = the axial reaction at the insertion edge",
            "moment_arm": "-ten_J S (tendon Jacobian along the coupling slopes), the total coupled arm",
            "parameters": hill_v2.PROVENANCE, **solve_meta(t, spec, res, material, settings, fem), "grid": grid_dict(),
            "code_version": CODE_VERSION, "input_hash": digest, "build_seconds": round(seconds, 2)}


def _write(path, fem, L_mt, extent, arm, meta) -> None:
    force = np.maximum(fem["force"], 0.0)  # |F| < NOISE_FORCE_N below zero is a slack sheet's noise (_meta)
    arrays = {"angle_deg": ANGLE_GRID_DEG.astype(float), "activation": ACTIVATIONS.astype(float), "force_N": force,
              "torque_Nm": force * arm[:, None], "moment_arm_m": arm.astype(float),
              "musculotendon_length_m": L_mt, "sheet_extent_m": extent,
              "lateral_force_N": fem["lateral_force_N"], "newton_iterations": fem["newton_iterations"],
              "fibre_stretch": fem["fibre_stretch"], "stalled_solves": fem["stalled_solves"],
              "meta": np.array(json.dumps(meta, sort_keys=True))}
    with replacing(path) as tmp:
        np.savez(tmp, **arrays)


def main(argv=None) -> int:
    from shoulder_bench.authoring.fem import v2_check

    ap = argparse.ArgumentParser(prog="python -m shoulder_bench.authoring.fem.v2",
                                 description="FEM tables of the v2 muscles (models/muscles_v2/<tendon>_fem.npz)")
    ap.add_argument("--coarse", action="store_true", help=f"coarse sheets {RESOLUTION['coarse']} (tests); needs --out")
    ap.add_argument("--out", type=Path, default=None, help=f"output folder, created if missing (default {FOLDER})")
    ap.add_argument("--plane", type=float, default=None, help="plane of elevation, deg (default TASK_PLANE_V2)")
    ap.add_argument("--quiet", action="store_true", help="no progress bar")
    ap.add_argument("--variant", choices=[k for k in transfer.VARIANTS if k], default=None,
                    help="a rerouted geometry's tables (ld_transfer: ld1-3 into models/muscles_v2_ld_transfer)")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    try:
        metas = build(args.plane, coarse=args.coarse, out=args.out, quiet=args.quiet, variant=args.variant)
    except ValueError as exc:
        ap.error(str(exc))
    for t, m in metas.items():
        how = ("solved" if not m["cached"] else "inputs unchanged, moment arms refreshed" if m["written"]
               else "up to date, nothing to do")
        n = m["newton_iterations"]
        lam = m["fibre_stretch_range"]
        print(f"{t}: {m['sheet']['resolution']} sheet, {how} ({m['build_seconds']:.1f} s to solve; Newton "
              f"{n['total']} iterations, <= {n['max_per_point']} per grid point, {m['tolerance']}; fibre stretch "
              f"{lam[0]:.3f}-{lam[1]:.3f}; clamped {m['clamped_noise_N']:.2g} N)")
    print(f"total {time.perf_counter() - t0:.1f} s")
    if all(m["cached"] and not m["written"] for m in metas.values()):
        return 0
    folder = args.out if args.out is not None else transfer.variant(args.variant).folder
    print("applied (S^T qfrc_actuator) vs table torque, every grid pose and activation level:")
    for t, r in v2_check.applied_vs_table("fem", args.plane, folder, args.variant).items():
        print(f"  {t:4s} max |err| {r['max_err_Nm']:.3e} N m = {r['max_err_pct_of_peak']:.2e} % of peak "
              f"{r['peak_Nm']:.3f} N m (bound {hill_v2.BOUND_PCT:g} %)")
    print("FEM vs Hill (models/muscles_v2/<t>_hill.npz), max over the grid, % of the FEM table's peak:")
    for t, c in v2_check.compare_with_hill(folder, variant=args.variant).items():
        print(f"  {t:4s} |dF| {c['force_pct']:5.1f} %  |dtau| {c['torque_pct']:5.1f} %  (largest dF {c['dF_N']:+.1f} N "
              f"at {c['at'][0]:g} deg, a = {c['at'][1]:g}); peak F {c['peak_F_fem_N']:.1f} vs {c['peak_F_hill_N']:.1f} "
              f"N; passive max {c['passive_max_fem_N']:.1f} vs {c['passive_max_hill_N']:.1f} N; stretch FEM "
              f"{c['stretch_fem'][0]:.3f}-{c['stretch_fem'][1]:.3f} (mean {c['stretch_fem_mean'][0]:.3f}-"
              f"{c['stretch_fem_mean'][1]:.3f}), Hill {c['stretch_hill'][0]:.3f}-{c['stretch_hill'][1]:.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
