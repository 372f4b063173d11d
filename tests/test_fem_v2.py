"""The v2 FEM tables (shoulder_bench.authoring.fem.v2, docs/fem.md "v2 sheets"): format, exact transmission,
staleness, physics.

The tables here are built on the coarse sheets (once per module, a few seconds); the shipped full tables are checked
for staleness by their input hash (no solving)."""
from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from shoulder_bench.authoring import hill_v2
from shoulder_bench.authoring.fem import v2, v2_check
from shoulder_bench.authoring.fem.v2_sheet import SheetProblem
from shoulder_bench.authoring.validate import TASK_PLANE_V2
from shoulder_bench.muscle import ForceLaw, MuscleTable, table_path


@pytest.fixture(scope="module")
def coarse(tmp_path_factory):
    folder = tmp_path_factory.mktemp("fem_v2")
    metas = v2.build(TASK_PLANE_V2, coarse=True, out=folder, quiet=True)
    return folder, metas


def test_coarse_tables_load_through_forcelaw(coarse):
    folder, metas = coarse
    law = v2_check.load_law("fem", TASK_PLANE_V2, folder)
    assert law.muscles == hill_v2.TENDONS
    same = ForceLaw.load("fem", muscles=hill_v2.TENDONS, folder=folder,
                         arms=lambda g: dict(zip(hill_v2.TENDONS, hill_v2.geometry(TASK_PLANE_V2, g)[1].T)))
    assert same.muscles == law.muscles
    for t in law.tables:
        np.testing.assert_array_equal(t.angle_deg, hill_v2.ANGLE_GRID_DEG)
        np.testing.assert_array_equal(t.activation, v2.ACTIVATIONS)
        assert np.all(t.force_N >= 0.0)
        np.testing.assert_allclose(t.torque_Nm, t.force_N * t.moment_arm_m[:, None], rtol=0, atol=1e-12)
        m = t.meta
        assert m["model"] == "fem" and m["source"] == "fem" and m["plane_deg"] == TASK_PLANE_V2
        assert m["parent_muscle"] == hill_v2.PARENT_MUSCLE[t.muscle] and m["code_version"] == v2.CODE_VERSION
        for key in ("optimal_fibre_length_m", "tendon_slack_length_m", "pennation_angle_rad", "F0_N", "input_hash"):
            assert key in m, key
        assert metas[t.muscle]["tolerance"].endswith("for 0 stalled solves)")  # every solve met 1e-4 F0


def test_applied_torque_equals_table_at_every_grid_pose(coarse):
    """Through model.py's callbacks on the actuated locked variant: S^T qfrc_actuator = torque_Nm, no exceptions."""
    res = v2_check.applied_vs_table("fem", TASK_PLANE_V2, coarse[0])
    assert set(res) == set(hill_v2.TENDONS)
    for t, r in res.items():
        assert r["poses"] == len(hill_v2.ANGLE_GRID_DEG) and r["levels"] == len(v2.ACTIVATIONS)
        assert r["max_err_pct_of_peak"] < hill_v2.BOUND_PCT, (t, r)
        assert r["max_err_pct_of_peak"] < 1e-4, (t, r)  # rounding plus ForceLaw's edge clamp at 160 deg


def test_second_build_has_nothing_to_do(coarse):
    folder, _ = coarse
    before = {t: table_path(t, "fem", folder).stat().st_mtime_ns for t in hill_v2.TENDONS}
    again = v2.build(TASK_PLANE_V2, coarse=True, out=folder, quiet=True)
    assert all(m["cached"] and not m["written"] for m in again.values())
    assert before == {t: table_path(t, "fem", folder).stat().st_mtime_ns for t in hill_v2.TENDONS}


def test_shipped_tables_are_up_to_date():
    """The shipped tables carry the input hash the code would build now (a stale table fails) and load against
    the model's arms."""
    want = v2.input_hashes(TASK_PLANE_V2)
    for t in hill_v2.TENDONS:
        meta = MuscleTable.load(table_path(t, "fem", v2.FOLDER)).meta
        assert meta["input_hash"] == want[t], f"{t}: stale, rebuild with `python -m shoulder_bench.authoring.fem.v2`"
    assert v2_check.load_law("fem", TASK_PLANE_V2).muscles == hill_v2.TENDONS
    assert want != v2.input_hashes(TASK_PLANE_V2, coarse=True)


def test_slack_passive_sheet_pulls_nothing_and_force_rises_with_activation(coarse):
    folder, _ = coarse
    for t in hill_v2.TENDONS:
        with np.load(table_path(t, "fem", folder)) as z:
            f, lam, meta = z["force_N"], z["fibre_stretch"], json.loads(str(z["meta"]))
        slack = lam[:, 0, 2] < 1.0  # every element's fibre shorter than optimal, a = 0
        assert np.all(f[slack, 0] < 1e-3 * meta["F0_N"]), t
        assert np.all(np.diff(f, axis=1) > -1e-3 * meta["F0_N"]), t


def test_unpennated_sheet_at_rest_pulls_a_f0():
    """alpha0 = 0 at the rest extent: the undeformed sheet is in equilibrium and the tendon force is exactly
    a F0 (fibre stress sigma_max a times the PCSA), whatever the mesh."""
    spec = dataclasses.replace(v2.specs()["dmi"], alpha0=0.0)
    problem = SheetProblem(spec, "coarse")
    for a in (0.5, 1.0):
        r = problem.sweep_extents(np.array([spec.rest_extent]), a)
        assert r["force_N"][0] == pytest.approx(a * spec.f0, rel=1e-6)
        assert abs(r["lateral_N"][0]) < 1e-6 * spec.f0


def test_coarse_needs_out():
    with pytest.raises(ValueError, match="--coarse without --out"):
        v2.build(TASK_PLANE_V2, coarse=True)
