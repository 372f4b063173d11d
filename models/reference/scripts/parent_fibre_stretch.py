"""The MoBL-ARMS parent's own musculotendon lengths and rigid-tendon fibre stretch, for docs/tendons.md.

Cross-check for `python -m shoulder_bench.authoring.tendons` (which uses the v2 model's paths, MyoArm's): the same
poses and
the same formula on the parent's own paths (its wrap objects and moving path points), computed by OpenSim.

    python -m venv /tmp/osimvenv && /tmp/osimvenv/bin/pip install opensim==4.6 numpy   # not a project dependency
    # the parent file also ships in osim-rl's PyPI sdist (md5 d6b9866c4f721f481e7d9e0bdae51093, as the reference's):
    pip download osim-rl==3.0.11 --no-deps -d /tmp && tar xzf /tmp/osim-rl-3.0.11.tar.gz -C /tmp \
        && cp /tmp/osim-rl-3.0.11/osim/models/MoBL_ARMS_J.osim /tmp/
    # --full (after the two paths): the full shoulder's fifteen tendons instead of v2's six
    /tmp/osimvenv/bin/python models/reference/scripts/parent_fibre_stretch.py /tmp/MoBL_ARMS_J.osim \
        models/reference/mobl_arms_parent_muscles.csv

Posing as ../shared/reference/moment_arms/README.md section 4: every coordinate 0, then elv_angle, shoulder_elv,
shoulder_rot set directly and each coupled coordinate from its CoordinateCouplerConstraint function (girdle `fixed`:
only shoulder1_r2 = f(elv_angle); `coupled`: all), no assembly; realizePosition; Muscle.getLength.
Fibre length with a rigid tendon at slack length and constant-width pennation (Schutte1993Muscle_Deprecated):
l_f = sqrt((L_MT - l_ts)^2 + (l_opt sin a0)^2), lam = l_f / l_opt (lam = sin a0 where L_MT <= l_ts).
"""
from __future__ import annotations

import csv
import math
import sys

import numpy as np
import opensim as osim

MUSCLES = {"ssp": "SUPSP", "isp": "INFSP", "dmi": "DELT2", "ld1": "LAT1", "ld2": "LAT2", "ld3": "LAT3"}
# `--full`: the full shoulder's fifteen tendons (shoulder_bench.authoring.mobl_data.FULL_MUSCLES), docs/model_full.md
FULL = {**MUSCLES, "dan": "DELT1", "dpo": "DELT3", "ssc": "SUBSC", "tmi": "TMIN", "tma": "TMAJ", "pec1": "PECM1",
        "pec2": "PECM2", "pec3": "PECM3", "cor": "CORB"}
PLANES = {"coronal": 0.0, "scapular": 30.0}
ELEV = np.arange(-10.0, 160.5, 1.0)
TASK = (ELEV >= 0) & (ELEV <= 120)
BAND = (0.85, 1.15)


def main(osim_path: str, params_csv: str) -> int:
    with open(params_csv, newline="") as f:
        par = {r["muscle"]: r for r in csv.DictReader(f)}
    model = osim.Model(osim_path)
    state = model.initSystem()
    coords = model.getCoordinateSet()
    couplers = []
    cons = model.getConstraintSet()
    for i in range(cons.getSize()):
        c = osim.CoordinateCouplerConstraint.safeDownCast(cons.get(i))
        if c is not None:
            names = c.getIndependentCoordinateNames()
            couplers.append((c.getDependentCoordinateName(), [names.get(j) for j in range(names.getSize())],
                             c.getFunction()))
    muscles = model.getMuscles()

    def lengths(plane, elev, girdle):
        for i in range(coords.getSize()):
            coords.get(i).setValue(state, 0.0, False)
        for name, v in (("elv_angle", plane), ("shoulder_elv", elev), ("shoulder_rot", 0.0)):
            coords.get(name).setValue(state, math.radians(v), False)
        for dep, ind, fun in couplers:
            if girdle == "fixed" and "shoulder_elv" in ind:
                continue
            if not set(ind) <= {"elv_angle", "shoulder_elv"}:
                continue  # the wrist couplers: those coordinates stay 0
            x = osim.Vector(len(ind), 0.0)
            for j, n in enumerate(ind):
                x.set(j, coords.get(n).getValue(state))
            coords.get(dep).setValue(state, fun.calcValue(x), False)
        model.realizePosition(state)
        return [muscles.get(m).getLength(state) for m in MUSCLES.values()]

    print("| tendon (MoBL) | plane | girdle | L_MT at 0° (mm) | L_MT 0–120° (mm) | λ̂ 0–120° | in 0.85–1.15 | "
          "λ̂ −10–160° |")
    print("|---|---|---|---:|---|---|---|---|")
    for pname, plane in PLANES.items():
        for girdle in ("fixed", "coupled"):
            L = np.array([lengths(plane, e, girdle) for e in ELEV])
            for k, (t, m) in enumerate(MUSCLES.items()):
                lo, lt, a0 = (float(par[m][c]) for c in ("optimal_fiber_length_m", "tendon_slack_length_m",
                                                          "pennation_angle_rad"))
                w, x = lo * math.sin(a0), L[:, k] - lt
                lam = np.where(x > 0, np.sqrt(x * x + w * w), w) / lo
                ok = lam[TASK].min() >= BAND[0] and lam[TASK].max() <= BAND[1]
                print(f"| {t} ({m}) | {pname} | {girdle} | {L[ELEV == 0, k][0] * 1000:.1f} | "
                      f"{L[TASK, k].min() * 1000:.1f}–{L[TASK, k].max() * 1000:.1f} | "
                      f"{lam[TASK].min():.3f}–{lam[TASK].max():.3f} | {'yes' if ok else 'NO'} | "
                      f"{lam.min():.3f}–{lam.max():.3f} |")
    return 0


if __name__ == "__main__":
    args = [a for a in sys.argv[1:] if a != "--full"]
    if len(args) != 2:
        raise SystemExit(__doc__)
    if "--full" in sys.argv:
        MUSCLES = FULL
    raise SystemExit(main(*args))
