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
S^T ten_J^T F equals the table's F r at every grid pose, to rounding (`applied_vs_table`, through the muscle callback
on the law's joint shoulder_elv). Tables from another source
(the FEM's) change the data, not the transmission.

ld1-3 are three tables and three actuators: driving them with one "ld" activation is for the tasks' switch-over.

`python -m shoulder_bench.authoring.hill_v2 [--plane 0] [--variant ld_transfer]` rewrites the tables (default plane:
validate.TASK_PLANE_V2). `variant` (`transfer.VARIANTS`): "ld_transfer" builds ld1-3's tables on the latissimus
transfer's model with its re-tensioned slack lengths into models/muscles_v2_ld_transfer (docs/surgery.md).
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import mujoco
import numpy as np

from shoulder_bench import arm
from shoulder_bench.authoring import statics_v2, transfer
from shoulder_bench.authoring.hill import ACTIVATION_GRID, ANGLE_GRID_DEG
from shoulder_bench.model import MODELS_DIR, attach_law, compile_model, install_callbacks
from shoulder_bench.muscle import ForceLaw, replacing, table_path

FOLDER = MODELS_DIR / "muscles_v2"
TENDONS = statics_v2.TENDONS  # ssp, isp, dmi, ld1, ld2, ld3
PARENT_MUSCLE = statics_v2.PARENT_MUSCLE  # ld1 -> LAT1
CODE_VERSION = "hill-v2-1"
BOUND_PCT = 1.0  # the model-v2 issue: applied torque = table torque within 1 % of each muscle's peak
PROVENANCE = ("MoBL-ARMS parent (models/reference/mobl_arms_parent_muscles.csv, from stanfordnmbl/osim-rl@610b95c "
              "osim/models/MoBL_ARMS_J.osim; models/reference/README.md)")


def default_plane() -> int:
    from shoulder_bench.authoring.validate import TASK_PLANE_V2

    return int(TASK_PLANE_V2)


def geometry(plane_deg: float, angle_deg=ANGLE_GRID_DEG, variant: str | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(lengths (K, n) m, total coupled moment arms r = -ten_J S (K, n) m) of the locked variant, TENDONS order (a
    `variant`'s tendons on its model)."""
    v = transfer.variant(variant)
    if v.name is None:
        return statics_v2.LockedPath(plane_deg).tendon_geometry(angle_deg, TENDONS)
    model = mujoco.MjModel.from_xml_string(v.model_xml(locked_plane_deg=plane_deg))
    return statics_v2.LockedPath(model=model).tendon_geometry(angle_deg, v.tendons)


def tables(plane_deg: float, variant: str | None = None) -> dict[str, dict]:
    """The arrays and meta of each tendon's table (what `build_tables` writes)."""
    L, r = geometry(plane_deg, variant=variant)
    v = transfer.variant(variant)
    params = v.parameters()
    out = {}
    for k, t in enumerate(v.tendons):
        p = params[t]
        f = np.stack([statics_v2.tendon_force(L[:, k], p, a) for a in ACTIVATION_GRID], axis=1)
        meta = {"model": "hill", "source": "hill", "muscle": t, "parent_muscle": PARENT_MUSCLE[t],
                "model_file": f"{'mobl' if v.name is None else 'transfer'}.model_xml(locked_plane_deg={plane_deg:g})",
                "plane_deg": float(plane_deg),
                "joint": arm.JOINT, "girdle": "coupled",
                "law": "statics_v2.tendon_force: rigid tendon, constant-width pennation, Blemker curves "
                       "(fem.material), F = F0 (a f_active + f_passive) cos(pennation)",
                "moment_arm": "-ten_J S (tendon Jacobian along the coupling slopes), the total coupled arm",
                "parameters": PROVENANCE, "F0_N": p.f0, "optimal_fibre_length_m": p.l_opt,
                "tendon_slack_length_m": p.l_ts, "pennation_angle_rad": p.alpha0,
                "grid": {"angle_deg": [ANGLE_GRID_DEG[0], ANGLE_GRID_DEG[-1], 5.0],
                         "activation": ACTIVATION_GRID.tolist()},
                "code_version": CODE_VERSION}
        if v.name is not None:
            meta.update(variant=v.name, tendon_slack_rule=transfer.SLACK_RULE)
        out[t] = {"angle_deg": ANGLE_GRID_DEG, "activation": ACTIVATION_GRID, "force_N": f,
                  "torque_Nm": f * r[:, k:k + 1], "moment_arm_m": r[:, k].copy(), "meta": meta}
    return out


def build_tables(plane_deg: float | None = None, folder: Path | None = None, variant: str | None = None) -> list[Path]:
    """Write models/muscles_v2/<tendon>_hill.npz (a variant's: its folder; atomically, `muscle.replacing`)."""
    plane = default_plane() if plane_deg is None else plane_deg
    written = []
    for t, arrays in tables(plane, variant).items():
        out = table_path(t, "hill", folder or transfer.variant(variant).folder)
        with replacing(out) as tmp:
            np.savez(tmp, **{k: v for k, v in arrays.items() if k != "meta"},
                     meta=np.array(json.dumps(arrays["meta"])))
        written.append(out)
    return written


REBUILD_V2 = {"hill": "python -m shoulder_bench.authoring.hill_v2", "fem": "python -m shoulder_bench.authoring.fem.v2"}


def load_law(plane_deg: float | None = None, folder: Path | None = None, source: str = "hill",
             variant: str | None = None) -> ForceLaw:
    """The v2 tables of `source` ("hill" or "fem") as a `ForceLaw` (`ForceLaw.load` on the v2 folder, or a
    variant's tendons in its folder), checked against the locked variant's coupled moment arms in `plane_deg`
    (`geometry`) and refused if built for another plane."""
    plane = default_plane() if plane_deg is None else float(plane_deg)
    v = transfer.variant(variant)
    fix = f"rebuild with `{REBUILD_V2[source]} --plane {plane:g}" + (f" --variant {v.name}`" if v.name else "`")
    try:
        law = ForceLaw.load(source, muscles=v.tendons, folder=folder or v.folder,
                            arms=lambda grid: dict(zip(v.tendons, geometry(plane, grid, variant)[1].T)))
    except ValueError as exc:
        if "does not match the model" not in str(exc):
            raise
        raise ValueError(f"{exc} (v2 tables: {fix})") from exc
    for t in law.tables:
        if t.meta.get("plane_deg") != plane:
            raise ValueError(f"the {t.muscle} table was built for plane {t.meta.get('plane_deg')}, not {plane}; {fix}")
    return law


def compile_actuated(plane_deg: float, variant: str | None = None) -> mujoco.MjModel:
    """The locked variant with actuators and dynamics settings (`model.compile_model`, then `arm.harden_couplings`)."""
    xml = transfer.variant(variant).model_xml(locked_plane_deg=plane_deg, dynamics=True, actuators=True)
    return compile_model(xml=xml, prepare=arm.harden_couplings)


def applied_vs_table(plane_deg: float | None = None, folder: Path | None = None,
                     source: str = "hill", variant: str | None = None) -> dict[str, dict]:
    """At every grid pose and activation level, the generalised force MuJoCo applies along shoulder_elv (S^T
    qfrc_actuator, qvel 0) against the table's torque_Nm; per tendon the max error in N m and as % of the muscle's
    peak |torque_Nm|.

    Through the real callback path: the actuated locked variant (`compile_actuated`), the law attached with
    `model.attach_law` (joint shoulder_elv) and the callbacks installed, `mj_forward`. One tendon at a time: a law
    of that tendon's table alone is attached, so the other actuators exert nothing (the callback gives them zero)."""
    plane = default_plane() if plane_deg is None else plane_deg
    law = load_law(plane, folder, source, variant)
    m = compile_actuated(plane, variant)
    d = mujoco.MjData(m)
    path = statics_v2.LockedPath(model=mujoco.MjModel.from_xml_string(
        transfer.variant(variant).model_xml(locked_plane_deg=plane)))
    if path.m.nv != m.nv:
        raise ValueError("the actuated variant's chain differs from statics_v2.LockedPath's")
    install_callbacks()
    q_adr = int(m.jnt_qposadr[m.joint(arm.JOINT).id])
    grid = np.radians(law.tables[0].angle_deg)
    poses = [path.pose(q).qpos.copy() for q in grid]  # on the coupling manifold, as the builder posed it
    slopes = [path.slopes(q) for q in grid]
    out = {}
    for table in law.tables:
        attach_law(m, ForceLaw([table]), joint=arm.JOINT)
        k = m.actuator(table.muscle).id
        err = np.zeros((len(grid), len(table.activation)))
        for i, (qpos, s) in enumerate(zip(poses, slopes)):
            for j, a in enumerate(table.activation):
                d.qpos[:], d.qvel[:], d.ctrl[:] = qpos, 0.0, 0.0
                d.ctrl[k] = a
                assert abs(d.qpos[q_adr] - grid[i]) < 1e-12
                mujoco.mj_forward(m, d)
                err[i, j] = float(s @ d.qfrc_actuator) - table.torque_Nm[i, j]
        peak, e = float(np.max(np.abs(table.torque_Nm))), float(np.max(np.abs(err)))
        out[table.muscle] = {"max_err_Nm": e, "peak_Nm": peak, "max_err_pct_of_peak": 100.0 * e / peak,
                             "poses": err.shape[0], "levels": err.shape[1]}
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description="v2 Hill tables (models/muscles_v2/<tendon>_hill.npz)")
    ap.add_argument("--plane", type=float, default=None, help="plane of elevation, deg (default TASK_PLANE_V2)")
    ap.add_argument("--folder", type=Path, default=None, help="output folder (default models/muscles_v2, or the "
                    "variant's)")
    ap.add_argument("--variant", choices=[k for k in transfer.VARIANTS if k], default=None,
                    help="a rerouted geometry's tables (ld_transfer: ld1-3 into models/muscles_v2_ld_transfer)")
    args = ap.parse_args(argv)
    for p in build_tables(args.plane, args.folder, args.variant):
        print(p)
    print("applied (S^T qfrc_actuator) vs table torque, every grid pose and activation level:")
    for t, r in applied_vs_table(args.plane, args.folder, "hill", args.variant).items():
        print(f"  {t:4s} max |err| {r['max_err_Nm']:.3e} N m = {r['max_err_pct_of_peak']:.2e} % of peak "
              f"{r['peak_Nm']:.3f} N m (bound {BOUND_PCT:g} %)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
