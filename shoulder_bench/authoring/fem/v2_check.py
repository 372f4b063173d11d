"""Checks of the v2 FEM tables: loading through ForceLaw, MuJoCo-applied vs table torque, FEM vs the Hill tables.

`applied_vs_table` is hill_v2.applied_vs_table's check (for any source): at every grid pose and activation level, one
tendon at a time, the generalised force MuJoCo applies along shoulder_elv (S^T qfrc_actuator after mj_forward, qvel 0)
through the real callback path (the actuated locked variant, `model.attach_law` on shoulder_elv, the callbacks
installed) against the table's torque_Nm; the bound is 1 % of that muscle's peak |torque_Nm| (hill_v2.BOUND_PCT).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from shoulder_bench.authoring import hill_v2, statics_v2, transfer
from shoulder_bench.muscle import ForceLaw, MuscleTable, table_path

TENDONS = hill_v2.TENDONS


def load_law(source: str = "fem", plane_deg: float | None = None, folder: Path | None = None,
             variant: str | None = None) -> ForceLaw:
    """The v2 tables of `source` as a ForceLaw, checked against the locked variant's arms (`hill_v2.load_law`)."""
    return hill_v2.load_law(plane_deg, folder, source, variant)


def applied_vs_table(source: str = "fem", plane_deg: float | None = None, folder: Path | None = None,
                     variant: str | None = None) -> dict:
    """Per tendon: max |S^T qfrc_actuator - torque_Nm| over every grid pose and level, in N m and % of peak
    (`hill_v2.applied_vs_table`)."""
    return hill_v2.applied_vs_table(plane_deg, folder, source, variant)


def compare_with_hill(folder: Path | None = None, hill_folder: Path | None = None,
                      variant: str | None = None) -> dict:
    """Per tendon, FEM vs the Hill table on the FEM's activation levels (the Hill law is linear in activation, so
    interpolating its levels is exact): max |dF| and |dtau| as % of the FEM table's peak |F| and |tau|, where, and
    the fibre stretch range of the FEM (element min..max) and of Hill."""
    v = transfer.variant(variant)
    params = v.parameters()
    out = {}
    for t in v.tendons:
        fem = np.load(table_path(t, "fem", folder or v.folder))
        hill = MuscleTable.load(table_path(t, "hill", hill_folder or v.folder))
        a = fem["activation"]
        f_h = np.stack([np.interp(a, hill.activation, row) for row in hill.force_N])
        d_f, d_t = fem["force_N"] - f_h, fem["torque_Nm"] - f_h * fem["moment_arm_m"][:, None]
        i, j = np.unravel_index(np.argmax(np.abs(d_f)), d_f.shape)
        lam_h, _ = statics_v2.fibres(fem["musculotendon_length_m"], params[t])
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
