"""Fibre stretch of the v2 muscles with the MoBL-ARMS parent's fibre and tendon lengths (rigid tendon).

For each tendon of `models/shoulder_v2.xml` (MyoArm's paths: ssp, isp, dmi, ld1-3) the musculotendon length L_MT(q)
is MuJoCo's `ten_length` at poses set by `shoulder_bench.authoring.kinematics.ShoulderPoser`. The parent's muscles are
OpenSim
`Schutte1993Muscle_Deprecated`, whose pennation model is constant width (OpenSim `calcPennation`:
sin a = l_opt sin a0 / l_f, so the fibres' perpendicular distance w = l_opt sin a0 stays fixed). With the tendon rigid
at its slack length l_ts the fibres take the rest, l_f cos a = L_MT - l_ts, hence

    l_f(q) = sqrt((L_MT(q) - l_ts)^2 + (l_opt sin a0)^2),      lam(q) = l_f(q) / l_opt.

Where L_MT <= l_ts the tendon is slack and the fibres sit at their width: lam = sin a0 (as OpenSim does).

MyoArm's derived values (MuJoCo muscle: rigid tendon LT, no pennation, `muscle_parameters.csv`, model `myoarm`):
lam_myo(q) = (L_MT - LT) / L0 (its own rigid-tendon stretch), and the tendon strain a series tendon of slack length LT
would need to keep those fibres inside the band, eps(q) = (L_MT - L0 clip(lam_myo, 0.85, 1.15)) / LT - 1: 0 where
lam_myo is in the band, < 0 where the tendon would have to be shorter than its slack length (impossible: it goes
slack and the fibres stay below the band). Meaningless where MyoArm's LT is negative (LAT2). The parent's own tendon
curve reaches F0 at about 3.3 % strain.

For comparison the parent's own excursion over 0-120 deg (coupled: total derivative) is -integral of its shoulder_elv
moment arm (moment_arms_mobl_arms_parent.csv, 10 deg grid, trapezoid): the parent's L_MT is not in the data, its
excursion is. `python -m shoulder_bench.authoring.tendons` prints the table (docs/tendons.md).
"""
from __future__ import annotations

import argparse
import csv
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from shoulder_bench.authoring.kinematics import ShoulderPoser
from shoulder_bench.authoring.mobl_data import MUSCLES, REFERENCE_DIR
from shoulder_bench.model import MODELS_DIR
from shoulder_bench.tendon_compliance import parent_curve  # the parent's SimmSpline curves (extract script)

PARENT_FILE = REFERENCE_DIR / "mobl_arms_parent_muscles.csv"
PARAMETERS_FILE = REFERENCE_DIR / "muscle_parameters.csv"
MODEL_V2 = MODELS_DIR / "shoulder_v2.xml"
BAND = (0.85, 1.15)  # the model-v2 issue's physiological range of fibre stretch
TASK_RANGE = (0.0, 120.0)  # degrees of elevation over which the band is checked
WIDE_RANGE = (-10.0, 160.0)
PLANES = {"coronal": 0.0, "scapular": 30.0}
GIRDLES = ("fixed", "coupled")


@dataclass(frozen=True)
class FibreParams:
    f0: float  # N
    l_opt: float  # m
    l_ts: float  # m
    alpha0: float  # rad, at optimal fibre length
    cls: str = ""


def load_parent(path: Path | str = PARENT_FILE) -> dict[str, FibreParams]:
    """The parent's parameters by MoBL muscle name (SUPSP, ...)."""
    with open(path, newline="") as f:
        return {r["muscle"]: FibreParams(float(r["max_isometric_force_N"]), float(r["optimal_fiber_length_m"]),
                                         float(r["tendon_slack_length_m"]), float(r["pennation_angle_rad"]),
                                         r["class"]) for r in csv.DictReader(f)}


def parent_passive(lam, muscle: str) -> np.ndarray:
    """The parent's normalised passive fibre force at normalised stretch `lam`: linear interpolation of its
    passive_force_length_curve knots (zero up to 1.15, 0.035 at 1.25; OpenSim interpolates the same knots by a cubic
    spline, which gives less force between them: 0.0037 against 0.0105 at 1.18)."""
    x, y = parent_curve(muscle)
    return np.interp(np.asarray(lam, dtype=float), x, y)


def load_myoarm(path: Path | str = PARAMETERS_FILE) -> dict[str, FibreParams]:
    """MyoArm's derived L0 (optimal_fiber_length) and LT (tendon_slack_length); no pennation."""
    vals: dict[str, dict] = {}
    with open(path, newline="") as f:
        for r in csv.DictReader(f):
            if r["model"] == "myoarm" and r["record"] in ("max_isometric_force", "optimal_fiber_length",
                                                          "tendon_slack_length"):
                vals.setdefault(r["muscle"], {})[r["record"]] = float(r["value"])
    return {m: FibreParams(v["max_isometric_force"], v["optimal_fiber_length"], v["tendon_slack_length"], 0.0,
                           "MuJoCo muscle") for m, v in vals.items()}


def fibre_length(L_mt, p: FibreParams) -> np.ndarray:
    """Rigid-tendon fibre length (m), constant-width pennation; fibres at their width where the tendon is slack."""
    w = p.l_opt * np.sin(p.alpha0)
    x = np.asarray(L_mt, dtype=float) - p.l_ts
    return np.where(x > 0, np.sqrt(x * x + w * w), w)


def stretch(L_mt, p: FibreParams) -> np.ndarray:
    """Normalised fibre length lam = l_f / l_opt."""
    return fibre_length(L_mt, p) / p.l_opt


def load_model(path: Path | str = MODEL_V2) -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_path(str(path))


def tendon_lengths(model: mujoco.MjModel, tendons, plane_deg: float, elevations_deg, girdle: str,
                   rotation_deg: float = 0.0) -> np.ndarray:
    """`ten_length` (m), shape (len(elevations), len(tendons))."""
    poser = ShoulderPoser(model)
    tid = [model.tendon(t).id for t in tendons]
    return np.array([poser.lengths(tid, np.radians([plane_deg, e, rotation_deg]), girdle)
                     for e in np.asarray(elevations_deg, dtype=float)])


def parent_excursion_mm(tables, muscle: str, plane: int, girdle: str, elevations=range(0, 121, 10)) -> np.ndarray:
    """L(q) - L(0) of the parent (mm) from its shoulder_elv moment arms (r = -dL/dq), trapezoid on the grid;
    `tables`: a `shoulder_bench.authoring.references.ReferenceTables`."""
    r = tables.raw_curve("mobl_arms", muscle, "shoulder_elv", plane, girdle, list(elevations))
    dq = np.radians(np.diff(np.asarray(list(elevations), dtype=float)))
    return np.concatenate([[0.0], -np.cumsum(0.5 * (r[1:] + r[:-1]) * dq)])


def analyse(model: mujoco.MjModel | None = None, step_deg: float = 1.0, with_parent_excursion: bool = True) -> list:
    """One dict per (tendon, plane, girdle), lengths in m, stretches dimensionless."""
    model = model or load_model()
    parent, myo = load_parent(), load_myoarm()
    if with_parent_excursion:
        from shoulder_bench.authoring.references import ReferenceTables
        tables = ReferenceTables.load()
    tendons = list(MUSCLES)
    elev = np.unique(np.round(np.concatenate([np.arange(0, WIDE_RANGE[1] + 1e-9, step_deg), -np.arange(
        0, -WIDE_RANGE[0] + 1e-9, step_deg), [WIDE_RANGE[0], TASK_RANGE[1], WIDE_RANGE[1]]]), 9))  # has 0, 120
    task = (elev >= TASK_RANGE[0] - 1e-9) & (elev <= TASK_RANGE[1] + 1e-9)
    rows = []
    for plane_name, plane in PLANES.items():
        for girdle in GIRDLES:
            L = tendon_lengths(model, tendons, plane, elev, girdle)
            for k, t in enumerate(tendons):
                m = MUSCLES[t]
                lam, lam_m = stretch(L[:, k], parent[m]), (L[:, k] - myo[m].l_ts) / myo[m].l_opt
                eps = ((L[:, k] - myo[m].l_opt * np.clip(lam_m, *BAND)) / myo[m].l_ts - 1 if myo[m].l_ts > 0
                       else np.full_like(lam, np.nan))
                exc_p = np.ptp(parent_excursion_mm(tables, m, int(plane), girdle)) if with_parent_excursion else np.nan
                rows.append(dict(
                    tendon=t, muscle=m, plane=plane_name, girdle=girdle,
                    L_rest=float(L[elev == 0, k][0]), lam_rest=float(lam[elev == 0][0]),
                    lam_task=(float(lam[task].min()), float(lam[task].max())),
                    lam_wide=(float(lam.min()), float(lam.max())),
                    in_band=bool(lam[task].min() >= BAND[0] and lam[task].max() <= BAND[1]),
                    excursion_mm=float(np.ptp(L[task, k]) * 1000), parent_excursion_mm=float(exc_p),
                    lam_myo_task=(float(lam_m[task].min()), float(lam_m[task].max())),
                    eps_myo_task=(float(np.nanmin(eps[task])), float(np.nanmax(eps[task])))
                    if myo[m].l_ts > 0 else (np.nan, np.nan)))
    return rows


def _r(a: tuple, f: str = ".3f") -> str:
    return "n/a" if np.isnan(a[0]) else f"{a[0]:{f}}–{a[1]:{f}}"


def table(rows: list) -> str:
    """Markdown table of `analyse`'s rows."""
    head = ("| tendon (MoBL) | plane | girdle | λ̂ 0–120° | in 0.85–1.15 | λ̂ −10–160° | λ̂ at 0° | excursion 0–120° "
            "v2 / parent (mm) | MyoArm λ̂ 0–120° | MyoArm: tendon strain to stay in band |\n"
            "|---|---|---|---|---|---|---:|---|---|---|")
    lines = [head]
    for r in rows:
        eps = r["eps_myo_task"]
        eps_s = "n/a (LT < 0)" if np.isnan(eps[0]) else f"{eps[0] * 100:+.1f} … {eps[1] * 100:+.1f} %"
        lines.append(f"| {r['tendon']} ({r['muscle']}) | {r['plane']} | {r['girdle']} | {_r(r['lam_task'])} | "
                     f"{'yes' if r['in_band'] else 'NO'} | {_r(r['lam_wide'])} | {r['lam_rest']:.3f} | "
                     f"{r['excursion_mm']:.1f} / {r['parent_excursion_mm']:.1f} | {_r(r['lam_myo_task'])} | {eps_s} |")
    return "\n".join(lines)


def parameter_table() -> str:
    parent, myo = load_parent(), load_myoarm()
    lines = ["| tendon | MoBL | F0 (N) | l_opt (mm) | l_ts (mm) | α0 (°) | MyoArm L0 / LT (mm) |",
             "|---|---|---:|---:|---:|---:|---|"]
    for t, m in MUSCLES.items():
        p, q = parent[m], myo[m]
        lines.append(f"| {t} | {m} | {p.f0:g} | {p.l_opt * 1000:.1f} | {p.l_ts * 1000:.1f} | "
                     f"{np.degrees(p.alpha0):.1f} | {q.l_opt * 1000:.1f} / {q.l_ts * 1000:.1f} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description="Fibre stretch of the v2 muscles with the parent's l_opt and l_ts")
    ap.add_argument("--step", type=float, default=1.0, help="elevation step, degrees (default 1)")
    args = ap.parse_args(argv)
    print(parameter_table())
    print()
    print(f"rigid tendon, constant-width pennation; rotation 0; band {BAND[0]}–{BAND[1]} checked over "
          f"{TASK_RANGE[0]:g}–{TASK_RANGE[1]:g}° elevation (step {args.step:g}°)")
    print()
    print(table(analyse(step_deg=args.step)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
