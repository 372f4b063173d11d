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
  reference_mae_deg  the reference controller's test-set MAE on abduction_4m under the condition (it plans with the
                     conditioned law), with its crashes.
"""
from __future__ import annotations

import numpy as np

from shoulder_bench import statics
from shoulder_bench.arm import MUSCLES, RANGE_DEG, arm
from shoulder_bench.conditions import CONDITIONS
from shoulder_bench.model import DEFAULT_MUSCLE_MODEL

TORQUE_RANGE_DEG = (0.0, 120.0)
SHARE_RANGE_DEG = (0.0, 30.0)
PHILLIPS_2018 = {"share": 0.40, "ci95": (0.32, 0.48), "source": "Phillips, Kosek & Karduna 2018, J Biomech 68:65"}


def measure(condition: str | None, muscle_model: str = DEFAULT_MUSCLE_MODEL, reference: bool = True) -> dict:
    """The report's row for one condition (None: intact)."""
    law = arm().load_law(muscle_model, MUSCLES, condition)
    deg = np.arange(TORQUE_RANGE_DEG[0], TORQUE_RANGE_DEG[1] + 1e-9, 1.0)
    cap = statics.static_capacity(law, np.radians(deg))
    fine = np.arange(0.0, RANGE_DEG[1], 0.1)
    q = np.radians(fine)
    reach = statics.reach_on_grid(fine, statics.static_capacity(law, q), statics.gravity_torque(q), RANGE_DEG[1])
    row = {"condition": condition or "none", "max_torque_Nm": float(cap.max()),
           "max_torque_at_deg": float(deg[int(np.argmax(cap))]), "static_reach_deg": reach}
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
    rows = [measure(c, muscle_model, reference) for c in (None, *CONDITIONS)]
    share = rows[0]["ssp_share"]
    lo, hi = PHILLIPS_2018["ci95"]
    anchor = dict(PHILLIPS_2018, model=share, difference_points=100 * (share - PHILLIPS_2018["share"]),
                  within_ci=bool(lo <= share <= hi))
    return {"muscle_model": muscle_model, "conditions": rows, "ssp_share_anchor": anchor,
            "descriptions": {name: {"description": c.description, "source": c.source}
                             for name, c in CONDITIONS.items()}}


def print_report(r: dict) -> None:
    print(f"conditions of the tasks' shoulder ({r['muscle_model']} tables; each condition at its default fraction)")
    has_ref = "reference_mae_deg" in r["conditions"][0]
    head = f"{'condition':<22} {'max elev. torque (0-120)':>25} {'static reach':>13}"
    print(head + (f" {'reference MAE (abduction_4m)':>29}" if has_ref else ""))
    for row in r["conditions"]:
        reach = "none" if row["static_reach_deg"] is None else f"{row['static_reach_deg']:.1f} deg"
        line = (f"{row['condition']:<22} {row['max_torque_Nm']:>11.2f} N m at {row['max_torque_at_deg']:>5.0f} deg "
                f"{reach:>13}")
        if has_ref:
            line += f" {row['reference_mae_deg']:>16.2f} deg, {row['reference_crashes']:>3} crashes"
        print(line)
    a = r["ssp_share_anchor"]
    lo, hi = a["ci95"]
    print(f"supraspinatus share of the intact elevation torque, 0-30 deg: model {100 * a['model']:.0f} %, "
          f"{a['source']}: {100 * a['share']:.0f} % (95 % CI {100 * lo:.0f}-{100 * hi:.0f} %); the model differs by "
          f"{a['difference_points']:+.0f} points ({'within' if a['within_ci'] else 'outside'} the CI)")
