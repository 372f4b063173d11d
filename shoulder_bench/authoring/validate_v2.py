"""`shoulder-bench model validate` (default `--model models/shoulder_v2.xml`): the v2 model's geometry against the
reference moment arms and the model-v2 issue's targets (docs/validation.md). `models/shoulder_v2.xml` is the 3-DOF
model; the tasks run its locked 1-DOF variant (`models/shoulder_v2_task.xml`, coronal plane, rotation 0, the same
generator and paths: shoulder_bench.arm), which validate does not take itself (it lacks the rotation and plane DOFs).

Moment arms come from `shoulder_bench.authoring.kinematics.moment_arms` (the reference tables' own method: GH
coordinates set,
slaved girdle coordinates from the model's equality polynomials, central differences h = 0.25 deg, one-sided across a
path jump) in all three DOFs (shoulder_elv, shoulder_rot, elv_angle), in the coronal (0 deg) and scapular (30 deg)
planes, rotation 0, girdle coupled and fixed. ld is the F0-weighted mean of the tendons ld1-3 with the parent's F0
(`ReferenceTables.v2_weights`), the rule `shoulder_bench.authoring.references` applies to the references' LAT1-3.

The v2 geometry of isp, dmi and ld1-3 is MyoArm's, reconstructed exactly (docs/model_v2.md; only the clavicle sits at
MoBL's SC location, which changes ld1-3 coupled about shoulder_elv), and ssp is the MoBL parent's own SUPSP path: their
comparisons with MyoArm (isp, dmi, ld) and with the parent (ssp) are close to tautologies, and so are the envelope and
RMSE targets wherever that reference is among their references. The other references' comparisons are the informative
ones; the report adds the envelope without MyoArm (`envelope_without_myoarm`, shown, no target) for that reason.

The tasks' plane of elevation for v2 is `validate.TASK_PLANE_V2` (None: not chosen). Every target in the tasks'
plane is evaluated in both candidate planes and shown per plane; it passes only in the chosen plane, so with None it
fails with "tasks' plane not chosen yet". The force targets (rest angle, passive torque, peak isometric torques) and
the capacity ratio and ssp's reach are judged on `shoulder_bench.authoring.statics_v2`, a static rigid-tendon Hill
estimate with
the parent's parameters and the Blemker curves (statics_v2.LABEL), per candidate plane, combined like the moment-arm
targets. The same quantities of the tasks' own tables (`arm.arm().load_law(muscle_model)`: models/muscles_v2, FEM by
default, built for the tasks' plane only, against the tasks' arm's gravity) are shown beside each force target under
`tables` (no target): the tables exist for one plane and carry the FEM's square-sheet placeholder footprint
(docs/fem.md, "v2 sheets"), so the targets keep judging the two-plane estimate (docs/validation.md).
"""
from __future__ import annotations

import numpy as np

from shoulder_bench.authoring import anatomy, references
from shoulder_bench.authoring import validate as V
from shoulder_bench.authoring.kinematics import moment_arms
from shoulder_bench.model import compile_model

TAUTOLOGY = ("v2's isp, dmi and ld1-3 are MyoArm's paths, reconstructed exactly (docs/model_v2.md; ld differs "
             "coupled about shoulder_elv by the clavicle move, elsewhere by <= 1 mm RMSE through the parent's F0 "
             "split), and ssp is the MoBL parent's own SUPSP path (within 0.07 mm of its table): their MyoArm (isp, "
             "dmi, ld) and parent (ssp) comparisons are close to tautologies, and so are the envelope and RMSE "
             "targets wherever that reference is among theirs; the informative comparisons are the other "
             "references' (their RMSE; the envelope w/o MyoArm)")
PLANES = tuple(references.PLANES.values())
TABLE_LABELS = {"fem": "FEM tables (the tasks' muscles)", "hill": "Hill tables (the tasks' alternative muscles)"}
FORCE_NOTE = ("judged on the static rigid-tendon Hill estimate (parent's parameters, Blemker curves; both planes); the "
              "tasks' tables are shown beside it, no target")
PARENT_PASSIVE_IDS = ("rest_angle", "passive_torque")  # shown with the parent's own passive curve too (no target)
FORCE_IDS = ("rest_angle", "passive_torque", *(f"peak_torque/{m}" for m in anatomy.MUSCLES))
FORCE_QUANTITIES = ("relaxed_rest_deg", "passive_angle_deg", "passive_torque_Nm", "peak_isometric_torque",
                    "capacity_ratio_ssp_dmi", "ssp_static_reach_deg")


def curves(model, refs, elevations, muscles=anatomy.MUSCLES, planes=PLANES) -> tuple[dict, dict]:
    """Moment arms (mm) of `muscles` (default v2's four; the full shoulder's, `validate_full`) over `elevations` at
    rotation 0 in `planes` (default both) and both girdle modes, about every coordinate:
    ({(muscle, coordinate, plane, girdle): array}, {(tendon, coordinate, plane, girdle): array})."""
    tendons, n = [t for m in muscles for t in references.FULL_TENDONS[m]], len(elevations)
    poses = [(p, float(e), 0.0) for p in planes for e in elevations]
    ours, bundles = {}, {}
    for g in references.GIRDLES:
        arms = moment_arms(model, tendons, poses, g)
        for c in references.COORDINATES:
            for i, p in enumerate(planes):
                block = arms[c][i * n:(i + 1) * n]
                for j, t in enumerate(tendons):
                    bundles[(t, c, p, g)] = block[:, j]
                for m in muscles:
                    ours[(m, c, p, g)] = sum(w * block[:, tendons.index(t)] for t, w in refs.v2_weights(m).items())
    return ours, bundles


def _key(k) -> str:
    return "/".join(str(x) for x in k)


def _envelope(mine, used: dict) -> dict:
    """The envelope excursion of `mine` (V.envelope_excursion) with the references used and the worst angle."""
    env = V.envelope_excursion(mine, used)
    return {"references": list(used), "margin_mm": V.ENVELOPE_MARGIN_MM, "inside": env["outside_mm"] <= V.TOL,
            "outside_mm": env["outside_mm"], "at_deg": float(V.ELEVATIONS[env["index"]]), "model_mm": env["model_mm"],
            "lo_mm": env["lo_mm"], "hi_mm": env["hi_mm"]}


def moment_arm_section(refs, grid: dict, fine: dict, bundles: dict, muscles=anatomy.MUSCLES, planes=PLANES) -> dict:
    """Curves, per-reference RMSE and the envelope excursion for every muscle, DOF, plane and girdle."""
    rows, ref_curves = [], {}
    for m in muscles:
        excluded = references.ENVELOPE_EXCLUDED.get(m, {})
        for coord in references.COORDINATES:
            for plane in planes:
                for girdle in references.GIRDLES:
                    ref = {r: refs.curve(r, m, coord, plane, girdle, V.ELEVATIONS) for r in references.REFERENCES}
                    ref_curves[f"{m}/{coord}/{plane}/{girdle}"] = {r: np.round(v, 3).tolist() for r, v in ref.items()}
                    mine = grid[(m, coord, plane, girdle)]
                    used = {r: v for r, v in ref.items() if r not in excluded}
                    closest, err = V.best_rmse(mine, used)
                    rows.append({"muscle": m, "coordinate": coord, "plane_deg": plane, "girdle": girdle,
                                 "rmse_mm": {r: V.rmse(mine, v) for r, v in ref.items()},
                                 "envelope": _envelope(mine, used),
                                 "envelope_without_myoarm": _envelope(mine, {r: v for r, v in used.items()
                                                                            if r != "myoarm"}),
                                 "closest": {"reference": closest, "rmse_mm": err}, "note": ""})
    return {"elevation_deg": V.ELEVATIONS.tolist(), "fine_elevation_deg": V.FINE.tolist(),
            "model_mm": {_key(k): np.round(v, 3).tolist() for k, v in grid.items()},
            "model_fine_mm": {_key(k): np.round(v, 3).tolist() for k, v in fine.items()},
            "model_tendons_mm": {_key(k): np.round(v, 3).tolist() for k, v in bundles.items()},
            "references_mm": ref_curves, "rmse": rows}


def _plane_targets(refs, grid: dict, fine: dict, plane: int, cond: str, plane_text: str
                   ) -> tuple[list[dict], list[dict]]:
    """(moment-arm targets, sign targets) as if `plane` were the tasks' plane: v1's target logic on v2's curves (the
    start-of-abduction targets on the 1-deg curves, girdle fixed, the coupled values beside them)."""
    view = V.ModelView(("shoulder_elv",), (plane,), "coupled", plane, "", version="2")
    arms = {m: grid[(m, "shoulder_elv", plane, "coupled")] for m in anatomy.MUSCLES}
    signs = V.sign_targets(view, refs, lambda m, c: (grid[(m, c, plane, "coupled")], ""))
    early = V.early_targets(lambda m, g: (fine[(m, "shoulder_elv", plane, g)], ""), "", plane_text)
    return V.moment_arm_targets(view, refs, arms, cond) + early, signs


def combine(per_plane: dict[int, list[dict]], task_plane: int | None) -> list[dict]:
    """One target per id from its per-plane results: passed and measured from the tasks' plane, or failed with
    NO_TASK_PLANE when none is chosen; every plane's result kept under `planes`."""
    out = []
    for rows in zip(*per_plane.values()):
        first = rows[0]
        assert all(t["id"] == first["id"] and t["target"] == first["target"] for t in rows)
        planes = {str(p): {"passed": t["passed"], "measured": t["measured"], "bound": t["bound"],
                           **({"coupled": t["coupled"]} if "coupled" in t else {})} for p, t in zip(per_plane, rows)}
        extra = {k: first[k] for k in ("girdle",) if k in first}  # the judged girdle (the start-of-abduction targets)
        if "coupled" in first:  # shown beside them, no target: the tasks' plane's, or none while it is not chosen
            extra["coupled"] = None if task_plane is None else planes[str(task_plane)]["coupled"]
        bound = first["bound"] if len({t["bound"] for t in rows}) == 1 else "per plane"
        if task_plane is None:
            passed, measured = False, V.NO_TASK_PLANE
        else:
            passed, measured = planes[str(task_plane)]["passed"], planes[str(task_plane)]["measured"]
        out.append({**V.target(first["id"], first["target"], passed, measured, bound, first["note"]), **extra,
                    "task_plane_deg": task_plane, "planes": planes})
    return out


def _force_targets(summary: dict, cond: str) -> list[dict]:
    """v1's force targets on one plane's static estimate (`statics_v2.summary`), each noted with its method."""
    return V.force_targets(summary["relaxed_rest_deg"], summary["passive_angle_deg"], summary["passive_torque_Nm"],
                           summary["peak_isometric_torque"], cond, note=FORCE_NOTE)


def tables_section(muscle_model: str, refs, task_plane: int | None, cond: str) -> dict | None:
    """The force quantities of the tasks' own tables (`arm.arm().load_law(muscle_model)`, the locked variant
    models/shoulder_v2_task.xml, gravity `statics.gravity_torque`), as `statics_v2.summary` gives them for the
    estimate, and the force targets evaluated on them (shown, no target). None when the tasks' plane is not the tables'
    plane (or not chosen)."""
    from shoulder_bench import arm as A
    from shoulder_bench import statics
    from shoulder_bench.authoring import statics_v2

    if task_plane is None or task_plane != A.TASK_PLANE_DEG:
        return None
    law = A.arm().load_law(muscle_model)
    q = V.law_quantities(law, refs, task_plane, gravity=statics.gravity_torque, range_deg=statics_v2.RANGE_DEG)
    reach = V.static_reach(A.arm().load_law(muscle_model, ("ssp",)), gravity=statics.gravity_torque,
                           top_deg=statics_v2.RANGE_DEG[1])
    label = TABLE_LABELS.get(muscle_model, f"{muscle_model} tables (the tasks' muscles)")
    rows = V.force_targets(q["relaxed_rest_deg"], q["passive_angle_deg"], q["passive_torque_Nm"],
                           q["peak_isometric_torque"], cond)
    return {"label": label, "muscle_model": muscle_model, "model": f"models/{A.MODEL_FILE.name}",
            "folder": f"models/{A.TABLE_FOLDER.name}", "plane_deg": task_plane, **q, "ssp_static_reach_deg": reach,
            "targets": {t["id"]: {"passed": t["passed"], "measured": t["measured"]} for t in rows}}


def evaluate(view: V.ModelView, shown: str, path, muscle_model: str = "fem") -> dict:
    """The v2 report (the same keys as v1's; the force quantities are the tasks' plane's, None while it is not
    chosen; every plane's under `statics`; the tasks' `muscle_model` tables' under `tables`, and beside each force
    target)."""
    from shoulder_bench.authoring import statics_v2

    model = compile_model(path)
    refs = references.load()
    grid, bundles = curves(model, refs, V.ELEVATIONS)
    fine, _ = curves(model, refs, V.FINE)
    tp = view.task_plane
    plane_text = "tasks'" if tp is None else V.PLANE_NAMES[tp]
    cond = f"{plane_text} plane, rotation 0, girdle coupled, 0-120 deg"
    results = {p: _plane_targets(refs, grid, fine, p, cond, plane_text) for p in PLANES}
    statics = {p: statics_v2.summary(statics_v2.analyse(p, path), refs) for p in PLANES}
    forces = {p: _force_targets(statics[p], cond) for p in PLANES}
    arm_targets = combine({p: r[0] for p, r in results.items()}, tp)
    sign_targets = combine({p: r[1] for p, r in results.items()}, tp)
    tables = tables_section(muscle_model, refs, tp, cond)
    force_targets = combine(forces, tp)
    for t in force_targets:  # the tasks' tables' value beside each force target (no target)
        assert t["id"] in FORCE_IDS, t["id"]
        if tables is not None:
            t["tables"] = {"label": tables["label"], **tables["targets"][t["id"]]}
        if tp is not None and t["id"] in PARENT_PASSIVE_IDS:  # the same estimate with the parent's passive curve
            pc = statics[tp]["parent_passive_curve"]
            t["parent_passive_curve"] = (f"{pc['relaxed_rest_deg']:.1f} deg" if t["id"] == "rest_angle" else
                                         f"{pc['passive_max_Nm']:+.2f} N m at {pc['passive_max_at_deg']:g} deg")
    targets = arm_targets + force_targets + sign_targets
    per_plane = {str(p): {"passed": sum(t["passed"] for t in r[0] + r[1]), "of": len(r[0] + r[1]),
                          "force_passed": sum(t["passed"] for t in forces[p]), "force_of": len(forces[p])}
                 for p, r in results.items()}
    return {
        "model": {"path": shown, "version": "2", "kinematic_only": True, "muscle_model": muscle_model,
                  "tasks_model": "models/shoulder_v2_task.xml",
                  "description": view.describe(), "girdle": view.girdle, "task_plane_deg": tp,
                  "coordinates": list(view.coordinates), "planes_deg": list(view.planes),
                  "tendons": {m: refs.v2_weights(m) for m in anatomy.MUSCLES}, "note": TAUTOLOGY},
        "follows": {m: {"reference": r, "reason": why} for m, (r, why) in references.FOLLOWS.items()},
        "envelope_excluded": references.ENVELOPE_EXCLUDED,
        "moment_arms": moment_arm_section(refs, grid, fine, bundles),
        **{k: None if tp is None else statics[tp][k] for k in FORCE_QUANTITIES},
        "statics": {"method": statics_v2.LABEL, "planes": {str(p): v for p, v in statics.items()}},
        "tables": tables,
        "humerus_mass_kg": float(model.body("humerus").mass[0]),
        "per_plane_passed": per_plane,
        "targets": targets,
        "passed": all(t["passed"] for t in targets),
    }
