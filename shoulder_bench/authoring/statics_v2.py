"""The v2 force targets by a static analysis: a rigid-tendon Hill-type muscle on the v2 geometry with the MoBL-ARMS
parent's parameters and the Blemker curves the FEM uses (no simulation, no FEM; docs/validation.md).

Per tendon (ssp, isp, dmi, ld1-3) with the parent's F0, l_opt, l_ts and a0 (`models/reference/mobl_arms_parent_
muscles.csv`, `shoulder_bench.authoring.tendons.load_parent`), at elevation q in a plane of elevation, rotation 0,
girdle coupled:

* L_MT(q): MuJoCo `ten_length` of the v2 model posed by `kinematics.ShoulderPoser`;
* fibres as `shoulder_bench.authoring.tendons` (rigid tendon at l_ts, constant-width pennation): l_f cos a = L_MT -
l_ts,
  l_f sin a = l_opt sin a0, lam = l_f / l_opt;
* tendon force F(q, a) = F0 (a f_active(lam) + f_passive(lam)) cos a, cos a = (L_MT - l_ts) / l_f (0 where the tendon
  is slack): the fibre force F0 f (Blemker's nominal stress sigma_max f times the PCSA, `fem.material`) projected on
  the tendon line;
* torque tau = F r with r(q) = -dL_MT/dq the TOTAL elevation moment arm with the girdle coupled
  (`kinematics.moment_arms`, the validation's own moment arms); ld = ld1 + ld2 + ld3, each with its own parameters.

Gravity: the humerus only (1.998 kg; the 0.1 g placeholder girdle bodies excluded) on the locked 1-DOF variant
(`mobl.model_xml(locked_plane_deg=plane)`, the tasks' model), tau_g = -dPE/dq = -m g dz_COM/dq along the coupled path
(the GH centre moves with the rhythm), from the COM Jacobian and the coupling chain rule.

Quantities, as `shoulder_bench.authoring.validate` defines them for v1: the relaxed rest angle (activations 0: from 0
deg the
first zero of passive + gravity torque in the direction it pushes, i.e. a crossing with negative slope, linear
interpolation on the STEP_DEG grid; or the end of -10..160), the net passive torque over 0-20 deg (0.5 deg), each
muscle's peak isometric torque (a = 1 minus a = 0, signed value of largest magnitude over 0-120 deg every 1 deg) and
its ratio to F0 x the peak moment arm of the reference it follows (`references.FOLLOWS`, `anatomy.F0`), the ssp/dmi
capacity ratio at 0, 5 and 10 deg, and ssp's static reach (`validate.static_reach`: ssp alone, on or off whichever
helps, every angle from 0 held against gravity). `python -m shoulder_bench.authoring.statics_v2` prints the table.
"""
from __future__ import annotations

import argparse
import functools
from dataclasses import dataclass

import mujoco
import numpy as np

from shoulder_bench import arm, statics
from shoulder_bench.authoring import anatomy, mobl, references, tendons
from shoulder_bench.authoring.fem.material import f_active, f_passive
from shoulder_bench.authoring.kinematics import ShoulderPoser, moment_arms

LABEL = ("static rigid-tendon Hill estimate (parent's parameters, Blemker curves); the FEM tables replace it later")
RANGE_DEG = (-10.0, 160.0)
STEP_DEG = 0.1
PASSIVE_DEG, PASSIVE_STEP = 20.0, 0.5  # validate.PASSIVE_MAX_DEG, its 0.5 deg grid
PEAK_DEG = 120.0  # peak isometric torque over 0-120 deg every 1 deg (validate.FINE)
CAPACITY_DEG = (0.0, 5.0, 10.0)
GIRDLE = "coupled"
BUNDLES = {m: tuple(references.V2_TENDONS[m]) for m in anatomy.MUSCLES}  # ld: ld1, ld2, ld3
TENDONS = tuple(t for m in anatomy.MUSCLES for t in BUNDLES[m])
PARENT_MUSCLE = {t: references.V2_TENDONS[m][t] for m in anatomy.MUSCLES for t in BUNDLES[m]}  # ld1 -> LAT1


class LockedPath(arm.LockedPath):
    """`arm.LockedPath`; given `plane_deg`, of the kinematic locked variant in that plane, generated
    (`mobl.model_xml(locked_plane_deg=...)`)."""

    def __init__(self, plane_deg: float | None = None, model: mujoco.MjModel | None = None):
        if model is None and plane_deg is not None:
            model = mujoco.MjModel.from_xml_string(mobl.model_xml(locked_plane_deg=plane_deg))
        super().__init__(model)


def fibres(L_mt, p: tendons.FibreParams) -> tuple[np.ndarray, np.ndarray]:
    """(lam, cos a) of a rigid tendon at l_ts, constant-width pennation (`tendons.stretch`); cos a = 0 when slack."""
    l_f = tendons.fibre_length(L_mt, p)
    return l_f / p.l_opt, np.maximum(np.asarray(L_mt, dtype=float) - p.l_ts, 0.0) / l_f


def tendon_force(L_mt, p: tendons.FibreParams, activation) -> np.ndarray:
    """Tendon force (N): F0 (a f_active(lam) + f_passive(lam)) cos a."""
    lam, cos_a = fibres(L_mt, p)
    return p.f0 * (activation * f_active(lam) + f_passive(lam)) * cos_a


@dataclass
class Statics:
    """One plane: geometry on `elevation_deg` (tendons in TENDONS order) and the muscle torques from it."""
    plane_deg: int
    elevation_deg: np.ndarray
    lengths: np.ndarray  # (n, tendons) m
    arms: np.ndarray  # (n, tendons) m, total elevation moment arm, girdle coupled
    gravity: np.ndarray  # (n,) N m
    params: tuple  # FibreParams per tendon

    def tendon_torque(self, activation: float) -> np.ndarray:
        """(n, tendons) N m: F r with every activation `activation`."""
        return np.stack([tendon_force(self.lengths[:, k], p, activation) for k, p in enumerate(self.params)],
                        axis=1) * self.arms

    def muscle_torque(self, activation: float) -> dict[str, np.ndarray]:
        t = self.tendon_torque(activation)
        return {m: sum(t[:, TENDONS.index(b)] for b in BUNDLES[m]) for m in anatomy.MUSCLES}

    def passive(self) -> np.ndarray:
        return sum(self.muscle_torque(0.0).values())

    def passive_parent_curve(self) -> np.ndarray:
        """(n,) N m: the net passive torque with the parent's own passive force-length curve instead of Blemker's
        (`tendons.parent_passive`; information, not what the targets judge)."""
        out = np.zeros(len(self.elevation_deg))
        for k, t in enumerate(TENDONS):
            p = self.params[k]
            lam, cos_a = fibres(self.lengths[:, k], p)
            out += p.f0 * tendons.parent_passive(lam, PARENT_MUSCLE[t]) * cos_a * self.arms[:, k]
        return out

    def isometric(self) -> dict[str, np.ndarray]:
        on, off = self.muscle_torque(1.0), self.muscle_torque(0.0)
        return {m: on[m] - off[m] for m in anatomy.MUSCLES}

    def at(self, deg) -> np.ndarray:
        """Indices of the grid angles `deg`."""
        idx = np.rint((np.asarray(deg, dtype=float) - self.elevation_deg[0]) / STEP_DEG).astype(int)
        assert np.allclose(self.elevation_deg[idx], deg, atol=1e-6), deg
        return idx


def grid(step_deg: float = STEP_DEG) -> np.ndarray:
    n = int(round((RANGE_DEG[1] - RANGE_DEG[0]) / step_deg))
    return np.round(RANGE_DEG[0] + step_deg * np.arange(n + 1), 9)


def analyse(plane_deg: int, path: str | None = None) -> Statics:
    """The plane's geometry on the STEP_DEG grid over RANGE_DEG (the v2 model at `path`, default the shipped one)."""
    return _analyse(int(plane_deg), None if path is None else str(path))


@functools.lru_cache(maxsize=8)
def _analyse(plane_deg: int, path: str | None) -> Statics:
    model, elev = tendons.load_model(*([path] if path else [])), grid()
    poser, tid = ShoulderPoser(model), [model.tendon(t).id for t in TENDONS]
    L = np.array([poser.lengths(tid, np.radians([plane_deg, e, 0.0]), GIRDLE) for e in elev])
    r = moment_arms(model, TENDONS, [(plane_deg, e, 0.0) for e in elev], GIRDLE)["shoulder_elv"] / 1000.0
    locked = LockedPath(plane_deg)
    g = np.array([locked.gravity_torque(q) for q in np.radians(elev)])
    parent = tendons.load_parent()
    params = tuple(parent[references.V2_TENDONS[m][t]] for m in anatomy.MUSCLES for t in BUNDLES[m])
    return Statics(plane_deg, elev, L, r, g, params)


def summary(st: Statics, refs: references.ReferenceTables) -> dict:
    """The quantities of one plane (JSON-ready)."""
    deg, passive, iso = st.elevation_deg, st.passive(), st.isometric()
    active_force = np.stack([tendon_force(st.lengths[:, k], q, 1.0) - tendon_force(st.lengths[:, k], q, 0.0)
                             for k, q in enumerate(st.params)], axis=1)
    pdeg = np.arange(0.0, PASSIVE_DEG + 1e-9, PASSIVE_STEP)
    p = passive[st.at(pdeg)]
    k = int(np.argmax(np.abs(p)))
    fine = np.arange(0.0, PEAK_DEG + 1e-9, 1.0)
    peaks = {}
    for m in anatomy.MUSCLES:
        y = iso[m][st.at(fine)]
        j = int(np.argmax(np.abs(y)))
        i = st.at([fine[j]])[0]
        force = float(sum(active_force[i, TENDONS.index(b)] for b in BUNDLES[m]))
        lam = [float(fibres(st.lengths[i, TENDONS.index(b)], st.params[TENDONS.index(b)])[0]) for b in BUNDLES[m]]
        ref = references.FOLLOWS[m][0]
        r_peak, at = refs.peak(ref, m, "shoulder_elv", st.plane_deg, "coupled", np.arange(0.0, PEAK_DEG + 1, 10.0))
        expected = anatomy.F0[m] * r_peak / 1000.0
        peaks[m] = {"peak_Nm": float(y[j]), "at_deg": float(fine[j]), "active_force_N": force,
                    "arm_mm": float(y[j] / force * 1000.0) if force else None, "lam": lam,
                    "follows": ref, "ref_peak_mm": r_peak,
                    "ref_peak_deg": at, "F0_N": anatomy.F0[m], "expected_Nm": expected,
                    "ratio": float(y[j] / expected) if expected else None}
    cap = st.at(CAPACITY_DEG)
    ssp_on, ssp_off = st.muscle_torque(1.0)["ssp"], st.muscle_torque(0.0)["ssp"]
    i0 = st.at([0.0])[0]
    pp = st.passive_parent_curve()
    pp_win = pp[st.at(pdeg)]
    kp = int(np.argmax(np.abs(pp_win)))
    lam0 = {t: float(fibres(st.lengths[i0, k], q)[0]) for k, (t, q) in enumerate(zip(TENDONS, st.params))}
    return {"plane_deg": st.plane_deg, "method": LABEL, "elevation_range_deg": list(RANGE_DEG), "step_deg": STEP_DEG,
            "relaxed_rest_deg": statics.rest_on_grid(deg, passive + st.gravity),
            "passive_angle_deg": pdeg.tolist(), "passive_torque_Nm": np.round(p, 4).tolist(),
            "passive_max_Nm": float(p[k]), "passive_max_at_deg": float(pdeg[k]),
            "gravity_at_0_Nm": float(st.gravity[i0]), "lam_at_0": lam0,
            "parent_passive_curve": {"relaxed_rest_deg": statics.rest_on_grid(deg, pp + st.gravity),
                                     "passive_max_Nm": float(pp_win[kp]), "passive_max_at_deg": float(pdeg[kp]),
                                     "note": "the parent's passive force-length curve (zero up to 1.15) instead of "
                                             "Blemker's; information, no target"},
            "peak_isometric_torque": peaks,
            "capacity_ratio_ssp_dmi": {f"{a:g}": float(iso["ssp"][i] / iso["dmi"][i])
                                       for a, i in zip(CAPACITY_DEG, cap)},
            "ssp_static_reach_deg": statics.reach_on_grid(deg, np.maximum(ssp_on, ssp_off), st.gravity,
                                                                RANGE_DEG[1])}


def _peak(p: dict) -> str:
    return (f"{p['peak_Nm']:+.2f} N m at {p['at_deg']:g} (F {p['active_force_N']:.0f} N x {p['arm_mm']:+.1f} mm) / "
            f"{p['expected_Nm']:+.2f} = {p['ratio']:.2f}")


def table(summaries: dict[str, dict]) -> str:
    """The per-plane table (text) of `summary` results keyed by plane name."""
    fmt = {"relaxed rest angle (a = 0)": lambda s: f"{s['relaxed_rest_deg']:.1f} deg",
           "passive torque at 0 deg": lambda s: f"{s['passive_torque_Nm'][0]:+.2f} N m",
           "passive, largest 0-20 deg": lambda s: f"{s['passive_max_Nm']:+.2f} N m at {s['passive_max_at_deg']:g}",
           "gravity torque at 0 deg": lambda s: f"{s['gravity_at_0_Nm']:+.2f} N m",
           "rest, parent's passive curve": lambda s: f"{s['parent_passive_curve']['relaxed_rest_deg']:.1f} deg",
           "passive 0-20, parent's curve": lambda s: (f"{s['parent_passive_curve']['passive_max_Nm']:+.2f} N m at "
                                                      f"{s['parent_passive_curve']['passive_max_at_deg']:g}"),
           **{f"{m} peak isometric / expected": lambda s, m=m: _peak(s["peak_isometric_torque"][m])
              for m in anatomy.MUSCLES},
           **{f"ssp/dmi capacity at {a:g} deg": lambda s, a=a: f"{s['capacity_ratio_ssp_dmi'][f'{a:g}']:.2f}"
              for a in CAPACITY_DEG},
           "ssp static reach": lambda s: "none" if s["ssp_static_reach_deg"] is None
           else f"{s['ssp_static_reach_deg']:.1f} deg",
           "fibre stretch at 0 deg": lambda s: " ".join(f"{t} {v:.3f}" for t, v in s["lam_at_0"].items())}
    rows = [("", [f"{n} ({s['plane_deg']} deg)" for n, s in summaries.items()])]
    rows += [(label, [f(s) for s in summaries.values()]) for label, f in fmt.items()]
    width = max(len(v) for _, vals in rows for v in vals) + 3
    return "\n".join((f"{label:32s}" + "".join(f"{v:{width}s}" for v in vals)).rstrip() for label, vals in rows)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description="v2 force targets, static rigid-tendon Hill estimate")
    ap.add_argument("--model", default=None, help="the v2 MJCF (default models/shoulder_v2.xml)")
    args = ap.parse_args(argv)
    refs = references.load()
    print(f"{LABEL}\nrotation 0, girdle coupled, elevation {RANGE_DEG[0]:g}..{RANGE_DEG[1]:g} deg every "
          f"{STEP_DEG:g} deg; torque = F0 (a f_active + f_passive) cos(pennation) x total elevation moment arm; "
          "gravity: the 2 kg humerus on the locked variant; peak: a = 1 minus a = 0, expected F0 x the followed "
          "reference's peak moment arm")
    print(table({n: summary(analyse(p, args.model), refs) for n, p in references.PLANES.items()}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
