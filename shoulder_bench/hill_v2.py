"""Hill tables for the v2 model (interim, before the FEM tables along the v2 paths; docs/model_v2.md "Muscles on v2").

One table per v2 tendon (ssp, isp, dmi, ld1, ld2, ld3), in `shoulder_bench.muscle`'s format, over the locked 1-DOF
variant's elevation (`mobl.model_xml(locked_plane_deg=plane)`, `shoulder_elv`, girdle coupled), written to
`models/muscles_v2/<tendon>_hill.npz`:

* force_N: `statics_v2.tendon_force` (rigid tendon at the parent's l_ts, constant-width pennation, Blemker curves,
  F = F0 (a f_active + f_passive) cos a; the parent's F0, l_opt, l_ts, a0) at MuJoCo's `ten_length` of the locked
  variant posed on its coupling (`statics_v2.LockedPath`), at hill.ANGLE_GRID_DEG and hill.ACTIVATION_GRID (the law is
  linear in activation, so three levels are exact);
* moment_arm_m: r = -ten_J S, the total elevation moment arm with the girdle coupled: ten_J the tendon Jacobian of
  that same path length, S = dqpos/d(shoulder_elv) the coupling slopes;
* torque_Nm = force_N x moment_arm_m.

Why a tendon transmission (`mobl.model_xml(actuators=True)`): MuJoCo applies F ten_J^T to the joints, and ten_J is the
exact derivative of the path length the fibre length comes from, so along the coupling the generalised force
S^T ten_J^T F equals the table's F r at every grid pose, to rounding (`applied_vs_table`). Tables from another source
(the FEM's) change the data, not the transmission.

ld1-3 are three tables and three actuators: driving them with one "ld" activation is for the tasks' switch-over.

`python -m shoulder_bench.hill_v2 [--plane 0]` rewrites the tables (default plane: validate.TASK_PLANE_V2).
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import mujoco
import numpy as np

from shoulder_bench import anatomy, mobl, references, statics_v2, tendons
from shoulder_bench.hill import ACTIVATION_GRID, ANGLE_GRID_DEG
from shoulder_bench.model import MODELS_DIR, attach_law, tendon_jacobian
from shoulder_bench.muscle import ForceLaw, MuscleTable, replacing, table_path

FOLDER = MODELS_DIR / "muscles_v2"
TENDONS = statics_v2.TENDONS  # ssp, isp, dmi, ld1, ld2, ld3
PARENT_MUSCLE = {t: b for m in anatomy.MUSCLES for t, b in references.V2_TENDONS[m].items()}  # ld1 -> LAT1
CODE_VERSION = "hill-v2-1"
BOUND_PCT = 1.0  # the model-v2 issue: applied torque = table torque within 1 % of each muscle's peak
PROVENANCE = ("MoBL-ARMS parent (models/reference/mobl_arms_parent_muscles.csv, from stanfordnmbl/osim-rl@610b95c "
              "osim/models/MoBL_ARMS_J.osim; models/reference/README.md)")


def default_plane() -> int:
    from shoulder_bench.validate import TASK_PLANE_V2

    return int(TASK_PLANE_V2)


def coupling_slopes(path: statics_v2.LockedPath, elevation_rad: float) -> np.ndarray:
    """S (nv,): dqvel/d(shoulder_elv rate) along the couplings (1 on shoulder_elv, each polycoef's derivative)."""
    m = path.m
    x = elevation_rad - m.qpos0[path.q]
    s = np.zeros(m.nv)
    s[int(m.jnt_dofadr[path.q_joint])] = 1.0
    for _, dof, c in path.couplings:
        s[dof] = sum(k * c[k] * x ** (k - 1) for k in range(1, 5))
    return s


def _path(plane_deg: float) -> statics_v2.LockedPath:
    path = statics_v2.LockedPath(plane_deg)
    path.q_joint = path.m.joint(statics_v2.GIRDLE_DRIVER).id
    return path


def geometry(plane_deg: float, angle_deg=ANGLE_GRID_DEG) -> tuple[np.ndarray, np.ndarray]:
    """(lengths (K, 6) m, total coupled moment arms r = -ten_J S (K, 6) m) of the locked variant, TENDONS order."""
    path = _path(plane_deg)
    tid = [path.m.tendon(t).id for t in TENDONS]
    L, r = np.zeros((len(angle_deg), len(TENDONS))), np.zeros((len(angle_deg), len(TENDONS)))
    for k, q in enumerate(np.radians(angle_deg)):
        d = path.pose(q)
        mujoco.mj_tendon(path.m, d)
        L[k] = d.ten_length[tid]
        r[k] = -(tendon_jacobian(path.m, d)[tid] @ coupling_slopes(path, q))
    return L, r


def tables(plane_deg: float) -> dict[str, dict]:
    """The arrays and meta of each tendon's table (what `build_tables` writes)."""
    L, r = geometry(plane_deg)
    parent = tendons.load_parent()
    out = {}
    for k, t in enumerate(TENDONS):
        p = parent[PARENT_MUSCLE[t]]
        f = np.stack([statics_v2.tendon_force(L[:, k], p, a) for a in ACTIVATION_GRID], axis=1)
        meta = {"model": "hill", "source": "hill", "muscle": t, "parent_muscle": PARENT_MUSCLE[t],
                "model_file": f"mobl.model_xml(locked_plane_deg={plane_deg:g})", "plane_deg": float(plane_deg),
                "joint": statics_v2.GIRDLE_DRIVER, "girdle": "coupled",
                "law": "statics_v2.tendon_force: rigid tendon, constant-width pennation, Blemker curves "
                       "(fem.material), F = F0 (a f_active + f_passive) cos(pennation)",
                "moment_arm": "-ten_J S (tendon Jacobian along the coupling slopes), the total coupled arm",
                "parameters": PROVENANCE, "F0_N": p.f0, "optimal_fibre_length_m": p.l_opt,
                "tendon_slack_length_m": p.l_ts, "pennation_angle_rad": p.alpha0,
                "grid": {"angle_deg": [ANGLE_GRID_DEG[0], ANGLE_GRID_DEG[-1], 5.0],
                         "activation": ACTIVATION_GRID.tolist()},
                "code_version": CODE_VERSION}
        out[t] = {"angle_deg": ANGLE_GRID_DEG, "activation": ACTIVATION_GRID, "force_N": f,
                  "torque_Nm": f * r[:, k:k + 1], "moment_arm_m": r[:, k].copy(), "meta": meta}
    return out


def build_tables(plane_deg: float | None = None, folder: Path | None = None) -> list[Path]:
    """Write models/muscles_v2/<tendon>_hill.npz (atomically, `muscle.replacing`)."""
    plane = default_plane() if plane_deg is None else plane_deg
    written = []
    for t, arrays in tables(plane).items():
        out = table_path(t, "hill", folder or FOLDER)
        with replacing(out) as tmp:
            np.savez(tmp, **{k: v for k, v in arrays.items() if k != "meta"},
                     meta=np.array(json.dumps(arrays["meta"])))
        written.append(out)
    return written


def load_law(plane_deg: float | None = None, folder: Path | None = None) -> ForceLaw:
    """The v2 tables as a `ForceLaw`, checked against the locked variant's moment arms in `plane_deg`.

    Built from `MuscleTable.load` directly: `ForceLaw.load` accepts only anatomy.MUSCLES (v1's four) and checks the
    arms against v1's MJCF (`muscle._model_moment_arms`)."""
    plane = default_plane() if plane_deg is None else plane_deg
    paths = [table_path(t, "hill", folder or FOLDER) for t in TENDONS]
    loaded = [MuscleTable.load(p) for p in paths]
    _, r = geometry(plane, loaded[0].angle_deg)
    for k, (t, p) in enumerate(zip(loaded, paths)):
        if t.meta.get("plane_deg") != float(plane):
            raise ValueError(f"{p} was built for plane {t.meta.get('plane_deg')}, not {plane}; "
                             f"rebuild with `python -m shoulder_bench.hill_v2 --plane {plane}`")
        err = float(np.max(np.abs(t.moment_arm_m - r[:, k])))
        if err > 1e-6:
            raise ValueError(f"{p}: moment arms differ from the v2 model's by {err * 1000:.4f} mm; rebuild it "
                             "with `python -m shoulder_bench.hill_v2`")
    return ForceLaw(loaded)


def compile_actuated(plane_deg: float) -> mujoco.MjModel:
    """The locked variant with actuators and dynamics settings, compiled as `model.compile_model` does (user
    actuators compiled as fixed-gain ones, set back to user afterwards), then `mobl.harden_couplings`."""
    spec = mujoco.MjSpec.from_string(mobl.model_xml(locked_plane_deg=plane_deg, dynamics=True, actuators=True))
    for act in spec.actuators:
        act.gaintype, act.biastype = mujoco.mjtGain.mjGAIN_FIXED, mujoco.mjtBias.mjBIAS_NONE
    m = spec.compile()
    m.actuator_gaintype[:] = mujoco.mjtGain.mjGAIN_USER
    m.actuator_biastype[:] = mujoco.mjtBias.mjBIAS_USER
    return mobl.harden_couplings(m)


def applied_vs_table(plane_deg: float | None = None, folder: Path | None = None) -> dict[str, dict]:
    """At every grid pose and activation level, the generalised force MuJoCo applies along shoulder_elv (S^T
    qfrc_actuator, one actuator on at a time) against the table's torque_Nm; per tendon the max error in N m and
    as % of the muscle's peak |torque_Nm|.

    The force is the law's (`ForceLaw.gain_bias` at velocity 0, i.e. what `model._gain`/`_bias` return, negated as
    they do) put into the actuator as a fixed gain and affine bias, because model.py's callback reads the joint
    `abduction` (v1's, `model.JOINT`); everything from the actuator force to qfrc_actuator is MuJoCo's."""
    plane = default_plane() if plane_deg is None else plane_deg
    law = load_law(plane, folder)
    m = compile_actuated(plane)
    attach_law(m, law)  # checks the names; fills actuator_user with the law id and each actuator's column
    cols = [int(c) for c in m.actuator_user[:, 1]]
    m.actuator_gaintype[:] = mujoco.mjtGain.mjGAIN_FIXED
    m.actuator_biastype[:] = mujoco.mjtBias.mjBIAS_AFFINE
    d, path = mujoco.MjData(m), _path(plane)
    if path.m.nv != m.nv:
        raise ValueError("the actuated variant's chain differs from statics_v2.LockedPath's")
    q_adr = int(m.jnt_qposadr[m.joint(statics_v2.GIRDLE_DRIVER).id])
    err = np.zeros((len(law.tables[0].angle_deg), len(law.levels), m.nu))
    for i, q in enumerate(np.radians(law.tables[0].angle_deg)):
        d.qpos[:] = path.pose(q).qpos  # on the coupling manifold, as the builder posed it
        d.qvel[:] = 0.0
        assert abs(d.qpos[q_adr] - q) < 1e-12
        s = coupling_slopes(path, q)
        for j, a in enumerate(law.levels):
            gain, bias = law.gain_bias(np.array([q]), np.zeros(1), np.full((1, m.nu), a))
            for k in range(m.nu):
                m.actuator_gainprm[:, 0] = 0.0
                m.actuator_biasprm[:, :3] = 0.0
                m.actuator_gainprm[k, 0] = -gain[0, cols[k]]
                m.actuator_biasprm[k, 0] = -bias[0, cols[k]]
                d.ctrl[:] = a
                mujoco.mj_forward(m, d)
                table = law.tables[cols[k]]
                err[i, j, k] = float(s @ d.qfrc_actuator) - np.interp(a, table.activation, table.torque_Nm[i])
    out = {}
    for k in range(m.nu):
        t = law.tables[cols[k]]
        peak = float(np.max(np.abs(t.torque_Nm)))
        e = float(np.max(np.abs(err[:, :, k])))
        out[m.actuator(k).name] = {"max_err_Nm": e, "peak_Nm": peak, "max_err_pct_of_peak": 100.0 * e / peak,
                                   "poses": err.shape[0], "levels": err.shape[1]}
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description="v2 Hill tables (models/muscles_v2/<tendon>_hill.npz)")
    ap.add_argument("--plane", type=float, default=None, help="plane of elevation, deg (default TASK_PLANE_V2)")
    ap.add_argument("--folder", type=Path, default=None, help="output folder (default models/muscles_v2)")
    args = ap.parse_args(argv)
    for p in build_tables(args.plane, args.folder):
        print(p)
    print("applied (S^T qfrc_actuator) vs table torque, every grid pose and activation level:")
    for t, r in applied_vs_table(args.plane, args.folder).items():
        print(f"  {t:4s} max |err| {r['max_err_Nm']:.3e} N m = {r['max_err_pct_of_peak']:.2e} % of peak "
              f"{r['peak_Nm']:.3f} N m (bound {BOUND_PCT:g} %)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
