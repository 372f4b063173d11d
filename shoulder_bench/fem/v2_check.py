"""Checks of the v2 FEM tables: loading through ForceLaw, MuJoCo-applied vs table torque, FEM vs the Hill tables.

`applied_vs_table` is hill_v2.applied_vs_table's check for any source: at every grid pose and activation level, one
tendon at a time, the generalised force MuJoCo applies along shoulder_elv (S^T qfrc_actuator after mj_forward, qvel 0)
through the real callback path (the actuated locked variant, `model.attach_law` on shoulder_elv, the callbacks
installed) against the table's torque_Nm; the bound is 1 % of that muscle's peak |torque_Nm| (hill_v2.BOUND_PCT).
"""
from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np

from shoulder_bench import hill_v2, statics_v2
from shoulder_bench.model import attach_law, install_callbacks
from shoulder_bench.muscle import ForceLaw, MuscleTable, table_path

TENDONS = hill_v2.TENDONS


def load_law(source: str = "fem", plane_deg: float | None = None, folder: Path | None = None) -> ForceLaw:
    """The v2 tables of `source` as a ForceLaw, checked against the locked variant's arms; refused if built for
    another plane."""
    plane = hill_v2.default_plane() if plane_deg is None else float(plane_deg)
    law = ForceLaw.load(source, muscles=TENDONS, folder=folder or hill_v2.FOLDER,
                        arms=lambda grid: dict(zip(TENDONS, hill_v2.geometry(plane, grid)[1].T)))
    for t in law.tables:
        if t.meta.get("plane_deg") != plane:
            raise ValueError(f"the {t.muscle} table was built for plane {t.meta.get('plane_deg')}, not {plane}; "
                             f"rebuild with `python -m shoulder_bench.fem.v2 --plane {plane:g}`")
    return law


def applied_vs_table(source: str = "fem", plane_deg: float | None = None, folder: Path | None = None) -> dict:
    """Per tendon: max |S^T qfrc_actuator - torque_Nm| over every grid pose and level, in N m and % of peak."""
    plane = hill_v2.default_plane() if plane_deg is None else float(plane_deg)
    law = load_law(source, plane, folder)
    m = hill_v2.compile_actuated(plane)
    d, path = mujoco.MjData(m), statics_v2.LockedPath(plane)
    install_callbacks()
    grid = np.radians(law.tables[0].angle_deg)
    poses = [path.pose(q).qpos.copy() for q in grid]
    slopes = [path.slopes(q) for q in grid]
    out = {}
    for table in law.tables:
        attach_law(m, ForceLaw([table]), joint=statics_v2.GIRDLE_DRIVER)
        k = m.actuator(table.muscle).id
        err = np.zeros((len(grid), len(table.activation)))
        for i, (qpos, s) in enumerate(zip(poses, slopes)):
            for j, a in enumerate(table.activation):
                d.qpos[:], d.qvel[:], d.ctrl[:] = qpos, 0.0, 0.0
                d.ctrl[k] = a
                mujoco.mj_forward(m, d)
                err[i, j] = float(s @ d.qfrc_actuator) - table.torque_Nm[i, j]
        peak, e = float(np.max(np.abs(table.torque_Nm))), float(np.max(np.abs(err)))
        out[table.muscle] = {"max_err_Nm": e, "peak_Nm": peak, "max_err_pct_of_peak": 100.0 * e / peak,
                             "poses": err.shape[0], "levels": err.shape[1]}
    return out


def compare_with_hill(folder: Path | None = None, hill_folder: Path | None = None) -> dict:
    """Per tendon, FEM vs the Hill table on the FEM's activation levels (the Hill law is linear in activation, so
    interpolating its levels is exact): max |dF| and |dtau| as % of the FEM table's peak |F| and |tau|, where, and
    the fibre stretch range of the FEM (element min..max) and of Hill."""
    out = {}
    for t in TENDONS:
        fem = np.load(table_path(t, "fem", folder or hill_v2.FOLDER))
        hill = MuscleTable.load(table_path(t, "hill", hill_folder or hill_v2.FOLDER))
        a = fem["activation"]
        f_h = np.stack([np.interp(a, hill.activation, row) for row in hill.force_N])
        d_f, d_t = fem["force_N"] - f_h, fem["torque_Nm"] - f_h * fem["moment_arm_m"][:, None]
        i, j = np.unravel_index(np.argmax(np.abs(d_f)), d_f.shape)
        p = hill_v2.tendons.load_parent()[hill_v2.PARENT_MUSCLE[t]]
        lam_h, _ = statics_v2.fibres(fem["musculotendon_length_m"], p)
        out[t] = {"force_pct": 100 * float(np.abs(d_f).max() / np.abs(fem["force_N"]).max()),
                  "torque_pct": 100 * float(np.abs(d_t).max() / np.abs(fem["torque_Nm"]).max()),
                  "at": (float(fem["angle_deg"][i]), float(a[j])), "dF_N": float(d_f[i, j]),
                  "peak_F_fem_N": float(fem["force_N"].max()), "peak_F_hill_N": float(f_h.max()),
                  "passive_max_fem_N": float(fem["force_N"][:, 0].max()),
                  "passive_max_hill_N": float(f_h[:, 0].max()),
                  "stretch_fem": (float(fem["fibre_stretch"][..., 0].min()), float(fem["fibre_stretch"][..., 2].max())),
                  "stretch_fem_mean": (float(fem["fibre_stretch"][..., 1].min()),
                                       float(fem["fibre_stretch"][..., 1].max())),
                  "stretch_hill": (float(lam_h.min()), float(lam_h.max()))}
    return out
