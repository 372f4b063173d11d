"""The full shoulder's force targets (issue 12 section 1: v2's targets in all three DOFs), for `model validate`.

v2's static analysis (`statics_v2`: a rigid-tendon Hill muscle with the MoBL-ARMS parent's F0, l_opt, l_ts, a0 and
the Blemker curves the FEM uses; no simulation) on the full model's fifteen tendons, and beside it, shown with no
target, the same quantities from the tasks' FEM tables (`tendon_law.TendonLaw`, isometric: lengthening rate 0).
Per plane of elevation (coronal 0, scapular 30 deg), rotation 0, girdle coupled, elevation RANGE_DEG every STEP_DEG:

* L_MT and the moment arms r about plane, elevation and rotation of each tendon (`kinematics.moment_arms`, the
  validation's own); the tendon torque F r, a muscle's the sum over its tendons (ld = ld1 + ld2 + ld3);
* gravity on the humerus (its mass; the 0.1 g placeholder girdle bodies left out, as v2): tau_k = -m g dz_COM/dq_k,
  central differences of the COM height along each coordinate with the girdle following (h = 0.25 deg);
* the relaxed rest angle along elevation (activations 0, plane and rotation held: `statics.rest_on_grid` of the
  elevation component of passive + gravity), the largest |net passive torque| over 0-20 deg in each DOF, and each
  muscle's peak isometric torque (a = 1 minus a = 0, largest magnitude over 0-120 deg every 1 deg) in each DOF
  against F0 (the parent's, summed over bundles) x the peak moment arm of the muscle's path source in that DOF
  (the parent for ssp, the OpenSim file for pec1, MyoArm otherwise; `mobl_data.PATH_SOURCE`).

Bounds are v1's and v2's (`validate.REST_MAX_DEG`, `PASSIVE_MAX_NM`, `PEAK_TORQUE_TOL`).
"""
from __future__ import annotations

import mujoco
import numpy as np

from shoulder_bench import statics
from shoulder_bench.authoring import mobl_data as D
from shoulder_bench.authoring import references, statics_v2, tendons
from shoulder_bench.authoring import validate as V
from shoulder_bench.authoring.fem.material import f_active, f_passive
from shoulder_bench.authoring.kinematics import GH_COORDINATES, ShoulderPoser, moment_arms

PLANES = tuple(references.PLANES.values())  # coronal 0, scapular 30
RANGE_DEG, STEP_DEG = (-10.0, 160.0), 0.5
GIRDLE = "coupled"
H_DEG = 0.25


def grid() -> np.ndarray:
    n = int(round((RANGE_DEG[1] - RANGE_DEG[0]) / STEP_DEG))
    return np.round(RANGE_DEG[0] + STEP_DEG * np.arange(n + 1), 9)


def geometry(model: mujoco.MjModel, tendon_names, plane: float) -> dict:
    """L (P, T) m, r (P, T, 3) m and gravity (P, 3) N m on `grid()` in `plane` (rotation 0, girdle coupled)."""
    elev = grid()
    poses = [(plane, e, 0.0) for e in elev]
    arms = moment_arms(model, list(tendon_names), poses, GIRDLE)
    r = np.stack([arms[c] for c in GH_COORDINATES], axis=-1) / 1000.0
    poser, tid = ShoulderPoser(model), [model.tendon(t).id for t in tendon_names]
    L = np.array([poser.lengths(tid, np.radians(p), GIRDLE) for p in poses])
    hum = model.body("humerus").id
    mg = model.body_mass[hum] * -model.opt.gravity[2]
    g = np.zeros((len(poses), 3))
    for k in range(len(GH_COORDINATES)):
        for sign in (1.0, -1.0):
            for i, p in enumerate(poses):
                q = np.radians(p)
                q[k] += sign * np.radians(H_DEG)
                g[i, k] -= sign * mg * poser.pose(*q, GIRDLE).xipos[hum, 2] / (2 * np.radians(H_DEG))
    return {"elevation_deg": elev, "L": L, "r": r, "gravity": g}


def hill_forces(tendon_names, parent_passive: bool = False):
    """force(L (P, T), a) -> (P, T) N of the static estimate, F0 (a f_active(lam) + f_passive(lam)) cos a with the
    parent's parameters of each tendon (`statics_v2.fibres`); `parent_passive`: the parent's own passive
    force-length curve (`tendons.parent_passive`, zero up to stretch 1.15) instead of Blemker's, shown beside the
    rest and passive targets as v2 shows it."""
    parent = tendons.load_parent()
    params = [(parent[D.FULL_MUSCLES[t]], D.FULL_MUSCLES[t]) for t in tendon_names]

    def force(L, a):
        out = []
        for k, (p, name) in enumerate(params):
            lam, cos_a = statics_v2.fibres(L[:, k], p)
            passive = tendons.parent_passive(lam, name) if parent_passive else f_passive(lam)
            out.append(p.f0 * (a * f_active(lam) + passive) * cos_a)
        return np.stack(out, axis=1)
    return force


def fem_forces(tendon_names, law):
    """force(L (P, T), a) -> (P, T) N of the tasks' FEM tables (`law` a TendonLaw), every muscle at activation a."""
    cols = [law.actuators.index(t) for t in tendon_names]

    def force(L, a):
        full = np.zeros((len(L), len(law.actuators)))
        full[:, cols] = L
        f = law.force(full, np.zeros_like(full), np.full((len(L), len(law.muscles)), float(a)))
        return f[:, cols]
    return force


def quantities(geo: dict, force, muscles: dict) -> dict:
    """The rest angle, passive torque and peak isometric torques of one plane; `muscles` {muscle: tendon indices}."""
    elev, L, r, g = geo["elevation_deg"], geo["L"], geo["r"], geo["gravity"]
    f0, f1 = force(L, 0.0), force(L, 1.0)
    passive_by_tendon = f0[..., None] * r  # (P, T, 3)
    passive = passive_by_tendon.sum(axis=1)
    active = (f1 - f0)[..., None] * r
    win = (elev >= 0.0) & (elev <= V.PASSIVE_MAX_DEG + 1e-9)
    k = np.abs(passive[win]).argmax(axis=0)
    fine = (elev >= 0.0) & (elev <= 120.0 + 1e-9) & (np.abs(elev - np.round(elev)) < 1e-9)
    peaks = {}
    for m, idx in muscles.items():
        tau = active[:, idx].sum(axis=1)[fine]
        j = np.abs(tau).argmax(axis=0)
        peaks[m] = {c: {"peak_Nm": float(tau[j[n], n]), "at_deg": float(elev[fine][j[n]])}
                    for n, c in enumerate(GH_COORDINATES)}
    by_tendon = np.abs(passive_by_tendon[win]).max(axis=(0, 2))  # (T,) largest over 0-20 deg and DOFs
    return {"relaxed_rest_deg": statics.rest_on_grid(elev, passive[:, 1] + g[:, 1]),
            "net_relaxed_elevation_Nm": (passive[:, 1] + g[:, 1]).round(4).tolist(),  # the rest's curve (figure)
            "passive_by_tendon_max_Nm": by_tendon.round(4).tolist(),
            "passive_max_Nm": {c: float(passive[win][k[n], n]) for n, c in enumerate(GH_COORDINATES)},
            "passive_max_at_deg": {c: float(elev[win][k[n]]) for n, c in enumerate(GH_COORDINATES)},
            "gravity_at_0_Nm": g[int(np.argmin(np.abs(elev)))].round(4).tolist(), "peak_isometric": peaks}


def section(model: mujoco.MjModel, muscles: dict, refs, law=None) -> dict:
    """{plane: {"hill": quantities, "fem": quantities or None, "expected": {muscle: {DOF: ...}}}}; `muscles`
    {muscle: tendon names}; `law` the FEM tables (None: not shown)."""
    names = [t for ts in muscles.values() for t in ts]
    idx = {m: [names.index(t) for t in ts] for m, ts in muscles.items()}
    parent = tendons.load_parent()
    hill, fem = hill_forces(names), (fem_forces(names, law) if law is not None else None)
    parent_curve = hill_forces(names, parent_passive=True)
    out = {}
    for p in PLANES:
        geo = geometry(model, names, p)
        expected = {}
        for m, ts in muscles.items():
            ref = D.PATH_SOURCE.get(ts[0], "myoarm")  # the path source's moment-arm table
            f0 = sum(parent[D.FULL_MUSCLES[t]].f0 for t in ts)
            expected[m] = {}
            for c in GH_COORDINATES:
                arm, at = refs.peak(ref, m, c, p, GIRDLE, V.ELEVATIONS)
                expected[m][c] = {"reference": ref, "ref_peak_mm": arm, "ref_peak_deg": at, "F0_N": f0,
                                  "expected_Nm": f0 * arm / 1000.0}
        i0 = int(np.argmin(np.abs(geo["elevation_deg"])))
        lam0 = {t: float(statics_v2.fibres(geo["L"][i0, k], parent[D.FULL_MUSCLES[t]])[0]) for k, t in enumerate(names)}
        out[p] = {"elevation_deg": geo["elevation_deg"].tolist(), "gravity_elevation_Nm": geo["gravity"][:, 1].tolist(),
                  "L_at_0_mm": {t: float(geo["L"][i0, k] * 1000.0) for k, t in enumerate(names)}, "lam_at_0": lam0,
                  "hill": quantities(geo, hill, idx), "fem": quantities(geo, fem, idx) if fem else None,
                  "parent_passive_curve": quantities(geo, parent_curve, idx), "expected": expected}
    return out


def _shown(s: dict, fmt) -> str:
    """A target's note: `fmt` of the FEM tables' quantities and of the parent-passive-curve estimate's."""
    parts = ([f"the FEM tables: {fmt(s['fem'])}"] if s["fem"] else []) + [
        f"with the parent's passive curve: {fmt(s['parent_passive_curve'])}"]
    return "; ".join(parts) + " (shown, no target)"


def targets(sec: dict) -> list[dict]:
    """`force/rest/<plane>`, `force/passive/<DOF>/<plane>`, `peak/<muscle>/<DOF>/<plane>` on the static estimate;
    the FEM tables' value in each target's note."""
    out, cond = [], "rotation 0, girdle coupled, static estimate"
    for p, s in sec.items():
        h, fem, where = s["hill"], s["fem"], f"{V.PLANE_NAMES[p]} plane"
        rest = h["relaxed_rest_deg"]
        out.append(V.target(f"force/rest/{p}", f"{V.REST_TEXT} ({where}, along elevation, {cond})",
                            abs(rest) <= V.REST_MAX_DEG + V.TOL, f"{rest:.1f} deg", V.REST_BOUND,
                            _shown(s, lambda q: f"{q['relaxed_rest_deg']:.1f} deg")))
        for c in GH_COORDINATES:
            dof, v, at = references.DOF_LABELS[c], h["passive_max_Nm"][c], h["passive_max_at_deg"][c]
            out.append(V.target(f"force/passive/{c}/{p}", f"{V.PASSIVE_TEXT}, {dof} ({where}, {cond})",
                                abs(v) < V.PASSIVE_MAX_NM, f"largest {v:+.2f} N m at {at:g} deg", V.PASSIVE_BOUND,
                                _shown(s, lambda q, c=c: f"{q['passive_max_Nm'][c]:+.2f} N m")))
        for m, by_dof in h["peak_isometric"].items():
            for c, pk in by_dof.items():
                e = s["expected"][m][c]
                ratio = pk["peak_Nm"] / e["expected_Nm"] if e["expected_Nm"] else float("nan")
                note = (f"expected F0 {e['F0_N']:.0f} N x {references.SHORT[e['reference']]}'s peak "
                        f"{e['ref_peak_mm']:+.1f} mm at {e['ref_peak_deg']:g} deg = {e['expected_Nm']:+.2f} N m")
                if fem:
                    fp = fem["peak_isometric"][m][c]["peak_Nm"]
                    note += f"; the FEM tables (shown, no target): {fp:+.2f} N m (ratio {fp / e['expected_Nm']:.2f})"
                out.append(V.target(
                    f"peak/{m}/{c}/{p}", f"{m} peak isometric {references.DOF_LABELS[c]} torque against F0 x the "
                    f"path source's peak moment arm ({where}, {cond}, 0-120 deg)",
                    abs(ratio - 1.0) <= V.PEAK_TORQUE_TOL + V.TOL,
                    f"{pk['peak_Nm']:+.2f} N m at {pk['at_deg']:g} deg (ratio {ratio:.2f})", V.PEAK_BOUND, note))
    return out
