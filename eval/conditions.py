"""`shoulder-bench condition report`: what each condition (`shoulder_bench.conditions`) does to the tasks' shoulder.

Per condition (the intact shoulder first, each condition at its default fraction), on the tasks' arm and four
muscles:
  max_torque_Nm      maximum isometric elevation torque over 0-120 deg: at each angle every muscle fully on where
                     that elevates and off (passive only) where it does not (ld and isp oppose elevation over most of
                     the range, so "all on" would not be the maximum), the largest over the range;
  static_reach_deg   the highest elevation up to which the muscles hold the arm at rest against gravity
                     (`statics.reach_on_grid` with `statics.gravity_torque`, 0.1 deg grid);
  ssp_share          (intact only) the supraspinatus share of the maximum elevation torque, mean over 0-30 deg: the
                     drop when its activation goes to 0 (as a nerve block removes it), over the maximum; compared with
                     Phillips, Kosek & Karduna 2018 (J Biomech 68:65): about 40 %, 95 % CI 32-48 %;
  max_er_torque_Nm   maximum isometric external-rotation torque over 0-120 deg elevation (coronal, rotation 0,
                     girdle coupled): the tabled tendon forces times each tendon's axial-rotation moment arm in the
                     condition's 3-DOF model (`rotation_arms`), each muscle on or off whichever rotates externally;
  reference_mae_deg  the reference controller's test-set MAE on abduction_4m under the condition (it plans with the
                     conditioned law), with its crashes;
  rerouted           (a condition with a geometry: ld_transfer) the rerouted ld's moment arms beside the intact ones:
                     elevation at ARM_ANGLES_DEG, axial rotation (+ external) at 0 deg, per bundle and F0-weighted,
                     and the external-rotation anchor (6.5-10.6 mm at 0 deg abduction, issue 13).
Report level: the Muench et al. 2022 pattern (posterosuperior tear -24.1 deg of maximum active abduction, the
transfer +8.9 deg) against the model's static reach (the quantity the model has for "maximum active abduction").
"""
from __future__ import annotations

import functools

import mujoco
import numpy as np

from shoulder_bench import statics
from shoulder_bench.arm import GEOMETRIES, JOINT, MUSCLES, RANGE_DEG, arm, arm_for, model_file, polycoef_value
from shoulder_bench.conditions import CONDITIONS, geometry
from shoulder_bench.geometry import tendon_jacobian
from shoulder_bench.model import DEFAULT_MUSCLE_MODEL

TORQUE_RANGE_DEG = (0.0, 120.0)
SHARE_RANGE_DEG = (0.0, 30.0)
PHILLIPS_2018 = {"share": 0.40, "ci95": (0.32, 0.48), "source": "Phillips, Kosek & Karduna 2018, J Biomech 68:65"}
LD_ER_ARM_MM = {"range_mm": (6.5, 10.6), "source": "issue 13 (the transferred latissimus external-rotation moment "
                "arm at 0 deg abduction, depending on the insertion)"}
MUENCH_2022 = {"tear_deg": -24.1, "transfer_deg": 8.9, "source": "Muench et al. 2022 (maximum active abduction in a "
               "dynamic cadaver simulator: irreparable posterosuperior tear, then latissimus dorsi transfer)"}
ARM_ANGLES_DEG = (0.0, 30.0, 60.0, 90.0, 120.0)
EXTRA = ("posterosuperior_tear+ld_transfer",)  # composed rows: the transfer's clinical indication
ROT_JOINT = "shoulder_rot"


@functools.cache
def _model_3dof(geo: str | None) -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_path(str(model_file(geo, dofs=3)))


def rotation_arms(geo: str | None, angle_deg, tendons) -> np.ndarray:
    """(K, n) external-rotation moment arms (m, + external = -(+internal) = dL/d shoulder_rot) of `tendons` in the
    3-DOF model of geometry `geo` at elevations `angle_deg`: coronal plane, rotation 0, girdle coupled (every slaved
    joint from its polycoef)."""
    m = _model_3dof(geo)
    d = mujoco.MjData(m)
    tid = [m.tendon(t).id for t in tendons]
    rot = int(m.joint(ROT_JOINT).dofadr[0])
    out = np.zeros((len(np.atleast_1d(angle_deg)), len(tid)))
    for k, q in enumerate(np.radians(np.atleast_1d(angle_deg))):
        d.qpos[:] = m.qpos0
        d.qpos[m.joint(JOINT).qposadr[0]] = q
        for e in range(m.neq):  # drivers (shoulder_elv, elv_angle) are set; dependents follow
            dep, drv = m.joint(int(m.eq_obj1id[e])), m.joint(int(m.eq_obj2id[e]))
            x = d.qpos[drv.qposadr[0]] - m.qpos0[drv.qposadr[0]]
            d.qpos[dep.qposadr[0]] = m.qpos0[dep.qposadr[0]] + polycoef_value(m.eq_data[e, :5], x)
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        mujoco.mj_tendon(m, d)
        out[k] = tendon_jacobian(m, d)[tid, rot]
    return out


def er_capacity(law, geo: str | None, angle_deg) -> np.ndarray:
    """(K,) the largest external-rotation torque at rest (N m): per muscle, on or off whichever rotates externally."""
    q = np.radians(angle_deg)
    v = np.zeros_like(q)
    er = rotation_arms(geo, angle_deg, law.actuators)
    tau = [law.force(q, v, np.full((len(q), len(law.muscles)), a)) * er for a in (0.0, 1.0)]
    per_muscle = [np.stack([t[:, [law.actuators.index(x) for x in law.groups[mu]]].sum(axis=1)
                            for mu in law.muscles], axis=1) for t in tau]
    return np.maximum(*per_muscle).sum(axis=1)


def rerouted_arms(condition: str, muscle_model: str = DEFAULT_MUSCLE_MODEL) -> dict:
    """The rerouted tendons' moment arms (mm) beside the intact ones, per bundle and F0-weighted (`ld`)."""
    geo = geometry(condition)
    names = GEOMETRIES[geo]["tendons"]
    out = {"tendons": list(names), "angles_deg": list(ARM_ANGLES_DEG)}
    for key, g in (("intact", None), ("rerouted", geo)):
        a = arm(g)
        law = a.load_law(muscle_model, ("ld",), None if g is None else condition)
        w = np.array([t.meta["F0_N"] for t in law.tables])
        w = w / w.sum()
        elev = a.tendon_geometry(ARM_ANGLES_DEG, names)[1] * 1000
        er0 = rotation_arms(g, [0.0], names)[0] * 1000
        out[key] = {"elevation_mm": {t: elev[:, k].tolist() for k, t in enumerate(names)},
                    "elevation_ld_mm": (elev @ w).tolist(), "er_at_0_mm": dict(zip(names, er0.tolist())),
                    "er_at_0_ld_mm": float(er0 @ w), "weights": dict(zip(names, w.tolist()))}
    lo, hi = LD_ER_ARM_MM["range_mm"]
    x = out["rerouted"]["er_at_0_ld_mm"]
    out["er_anchor"] = dict(LD_ER_ARM_MM, model_mm=x, difference_mm=0.0 if lo <= x <= hi else
                            (x - hi if x > hi else x - lo), within=bool(lo <= x <= hi),
                            bundles_mm=[min(out["rerouted"]["er_at_0_mm"].values()),
                                        max(out["rerouted"]["er_at_0_mm"].values())])
    return out


def measure(condition: str | None, muscle_model: str = DEFAULT_MUSCLE_MODEL, reference: bool = True) -> dict:
    """The report's row for one condition (None: intact)."""
    the_arm = arm_for(condition)
    law = the_arm.load_law(muscle_model, MUSCLES, condition)
    deg = np.arange(TORQUE_RANGE_DEG[0], TORQUE_RANGE_DEG[1] + 1e-9, 1.0)
    cap = statics.static_capacity(law, np.radians(deg))
    er = er_capacity(law, the_arm.geometry, deg)
    fine = np.arange(0.0, RANGE_DEG[1], 0.1)
    q = np.radians(fine)
    reach = statics.reach_on_grid(fine, statics.static_capacity(law, q), statics.gravity_torque(q), RANGE_DEG[1])
    row = {"condition": condition or "none", "max_torque_Nm": float(cap.max()),
           "max_torque_at_deg": float(deg[int(np.argmax(cap))]), "max_er_torque_Nm": float(er.max()),
           "max_er_torque_at_deg": float(deg[int(np.argmax(er))]), "static_reach_deg": reach}
    if the_arm.geometry is not None:
        row["rerouted"] = rerouted_arms(condition, muscle_model)
    if condition is None:
        s = np.radians(np.arange(SHARE_RANGE_DEG[0], SHARE_RANGE_DEG[1] + 1e-9, 1.0))
        full = statics.static_capacity(law, s)
        row["ssp_share"] = float(np.mean((full - statics.static_capacity(law, s, off=("ssp",))) / full))
    if reference:
        from shoulder_bench.eval.evaluate import evaluate
        from shoulder_bench.eval.reference import ReferenceController
        from shoulder_bench.trajectory import load_test_set

        opts = {} if condition is None else {"condition": condition}
        m = evaluate(ReferenceController("abduction_4m", muscle_model, **opts), "abduction_4m", load_test_set(),
                     muscle_model=muscle_model, options=opts)
        row["reference_mae_deg"], row["reference_crashes"] = m["mae_deg"], m["crashes"]
    return row


def report(muscle_model: str = DEFAULT_MUSCLE_MODEL, reference: bool = True) -> dict:
    """Every condition side by side with the intact shoulder and the anchor."""
    rows = [measure(c, muscle_model, reference) for c in (None, *CONDITIONS, *EXTRA)]
    share = rows[0]["ssp_share"]
    lo, hi = PHILLIPS_2018["ci95"]
    anchor = dict(PHILLIPS_2018, model=share, difference_points=100 * (share - PHILLIPS_2018["share"]),
                  within_ci=bool(lo <= share <= hi))
    # None: the muscles cannot hold the arm above 0 deg at all; counted as a reach of 0 deg for the change
    reach = {r["condition"]: r["static_reach_deg"] or 0.0 for r in rows}
    tear, both = reach["posterosuperior_tear"] - reach["none"], reach[EXTRA[0]] - reach["posterosuperior_tear"]
    muench = dict(MUENCH_2022, model_tear_deg=tear, model_transfer_deg=both,
                  tear_difference_deg=tear - MUENCH_2022["tear_deg"],
                  transfer_difference_deg=both - MUENCH_2022["transfer_deg"])
    return {"muscle_model": muscle_model, "conditions": rows, "ssp_share_anchor": anchor, "muench_anchor": muench,
            "descriptions": {name: {"description": c.description, "source": c.source}
                             for name, c in CONDITIONS.items()}}


def print_report(r: dict) -> None:
    print(f"conditions of the tasks' shoulder ({r['muscle_model']} tables; each condition at its default fraction)")
    has_ref = "reference_mae_deg" in r["conditions"][0]
    head = f"{'condition':<34} {'max elev. torque (0-120)':>25} {'max ext. rot. torque':>25} {'static reach':>13}"
    print(head + (f" {'reference MAE (abduction_4m)':>29}" if has_ref else ""))
    for row in r["conditions"]:
        reach = "none" if row["static_reach_deg"] is None else f"{row['static_reach_deg']:.1f} deg"
        line = (f"{row['condition']:<34} {row['max_torque_Nm']:>11.2f} N m at {row['max_torque_at_deg']:>5.0f} deg "
                f"{row['max_er_torque_Nm']:>11.2f} N m at {row['max_er_torque_at_deg']:>5.0f} deg {reach:>13}")
        if has_ref:
            line += f" {row['reference_mae_deg']:>16.2f} deg, {row['reference_crashes']:>3} crashes"
        print(line)
    for row in r["conditions"]:
        if "rerouted" in row:
            _print_rerouted(row["condition"], row["rerouted"])
            break
    mu = r["muench_anchor"]
    print(f"static reach change (the model's maximum active abduction): posterosuperior tear "
          f"{mu['model_tear_deg']:+.1f} deg, + ld_transfer {mu['model_transfer_deg']:+.1f} deg; {mu['source']}: "
          f"{mu['tear_deg']:+.1f} / {mu['transfer_deg']:+.1f} deg; the model differs by "
          f"{mu['tear_difference_deg']:+.1f} / {mu['transfer_difference_deg']:+.1f} deg")
    a = r["ssp_share_anchor"]
    lo, hi = a["ci95"]
    print(f"supraspinatus share of the intact elevation torque, 0-30 deg: model {100 * a['model']:.0f} %, "
          f"{a['source']}: {100 * a['share']:.0f} % (95 % CI {100 * lo:.0f}-{100 * hi:.0f} %); the model differs by "
          f"{a['difference_points']:+.0f} points ({'within' if a['within_ci'] else 'outside'} the CI)")


def _print_rerouted(name: str, ra: dict) -> None:
    angles = "/".join(f"{x:g}" for x in ra["angles_deg"])
    print(f"{name}: ld moment arms (mm; F0-weighted ld1-3, coronal, rotation 0, girdle coupled)")
    for key in ("intact", "rerouted"):
        v = ra[key]
        elev = " / ".join(f"{x:+.1f}" for x in v["elevation_ld_mm"])
        er = ", ".join(f"{t} {x:+.1f}" for t, x in v["er_at_0_mm"].items())
        print(f"  {key:<9} elevation at {angles} deg: {elev}; external rotation at 0 deg: {v['er_at_0_ld_mm']:+.1f} "
              f"({er})")
    a = ra["er_anchor"]
    lo, hi = a["range_mm"]
    print(f"  external-rotation arm at 0 deg: model {a['model_mm']:.1f} mm (bundles {a['bundles_mm'][0]:.1f}-"
          f"{a['bundles_mm'][1]:.1f}), {a['source']}: {lo:g}-{hi:g} mm; "
          + ("within the range" if a["within"] else f"the model differs by {a['difference_mm']:+.1f} mm"))
