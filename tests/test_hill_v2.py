"""The v2 Hill tables (shoulder_bench.authoring.hill_v2) and the exactness of the tendon transmission
(docs/model_v2.md)."""
from __future__ import annotations

import json

import mujoco
import numpy as np
import pytest

from shoulder_bench import arm
from shoulder_bench.authoring import anatomy, hill_v2, mjcf, mobl
from shoulder_bench.authoring.validate import TASK_PLANE_V2
from shoulder_bench.model import MODELS_DIR
from shoulder_bench.muscle import ForceLaw, MuscleTable, table_path


@pytest.fixture(scope="module")
def built():
    return hill_v2.tables(TASK_PLANE_V2)


def test_shipped_tables_are_what_the_builder_writes(built):
    for t in hill_v2.TENDONS:
        shipped = MuscleTable.load(table_path(t, "hill", hill_v2.FOLDER))
        new = built[t]
        for key in ("angle_deg", "activation", "force_N", "torque_Nm", "moment_arm_m"):
            np.testing.assert_allclose(getattr(shipped, key), new[key], rtol=1e-9, atol=1e-9, err_msg=f"{t} {key}")
        assert shipped.meta == json.loads(json.dumps(new["meta"])), t
        assert shipped.meta["source"] == "hill" and shipped.meta["plane_deg"] == TASK_PLANE_V2


def test_tables_are_the_statics_law_times_the_coupled_arm(built):
    """force_N is statics_v2's law at the locked variant's lengths; the Jacobian arm equals the validation's
    finite-difference moment arms (statics_v2.analyse, kinematics.moment_arms) on the grid."""
    st = hill_v2.statics_v2.analyse(TASK_PLANE_V2)
    idx = st.at(hill_v2.ANGLE_GRID_DEG)
    for k, t in enumerate(hill_v2.TENDONS):
        np.testing.assert_allclose(built[t]["moment_arm_m"], st.arms[idx, k], atol=2e-5, err_msg=t)  # 0.02 mm
        for j, a in enumerate(hill_v2.ACTIVATION_GRID):
            f = hill_v2.statics_v2.tendon_force(st.lengths[idx, k], st.params[k], a)
            np.testing.assert_allclose(built[t]["force_N"][:, j], f, rtol=1e-9, atol=1e-6, err_msg=t)


def test_applied_torque_equals_table_at_every_grid_pose():
    """Through model.py's callbacks (law joint shoulder_elv): S^T qfrc_actuator = the table torque."""
    res = hill_v2.applied_vs_table(TASK_PLANE_V2)
    assert set(res) == set(hill_v2.TENDONS)
    for t, r in res.items():
        assert r["poses"] == len(hill_v2.ANGLE_GRID_DEG) and r["levels"] == len(hill_v2.ACTIVATION_GRID)
        assert r["max_err_pct_of_peak"] < hill_v2.BOUND_PCT, (t, r)
        assert r["max_err_pct_of_peak"] < 1e-4, (t, r)  # rounding plus ForceLaw's edge clamp at 160 deg


def test_actuators_have_tendon_transmission_and_user_gain():
    m = hill_v2.compile_actuated(TASK_PLANE_V2)
    assert tuple(m.actuator(k).name for k in range(m.nu)) == hill_v2.TENDONS
    for k, t in enumerate(hill_v2.TENDONS):
        assert m.actuator_trntype[k] == mujoco.mjtTrn.mjTRN_TENDON
        assert m.actuator_trnid[k, 0] == m.tendon(t).id
        assert m.actuator_gaintype[k] == mujoco.mjtGain.mjGAIN_USER
        assert m.actuator_biastype[k] == mujoco.mjtBias.mjBIAS_USER
        assert list(m.actuator_ctrlrange[k]) == [0.0, 1.0] and m.actuator_ctrllimited[k]
        assert list(m.actuator_user[k]) == [0.0, float(k)]
    assert np.all(m.dof_invweight0 == arm.COUPLING_INVWEIGHT)
    assert "<actuator>" not in mobl.model_xml() and "<actuator>" not in mobl.model_xml(locked_plane_deg=0)


def test_table_from_another_plane_is_refused(tmp_path):
    hill_v2.build_tables(30, tmp_path)
    with pytest.raises(ValueError, match="plane"):
        hill_v2.load_law(0, tmp_path)


def test_table_with_other_arms_is_refused(tmp_path):
    """load_law checks the arms through ForceLaw.load(arms=...) and names the v2 command."""
    hill_v2.build_tables(TASK_PLANE_V2, tmp_path)
    path = table_path("isp", "hill", tmp_path)
    with np.load(path) as z:
        data = dict(z)
    data["moment_arm_m"] = data["moment_arm_m"] + 0.002
    np.savez(path, **data)
    with pytest.raises(ValueError, match=r"isp_hill\.npz does not match.*python -m shoulder_bench\.authoring\.hill_v2"):
        hill_v2.load_law(TASK_PLANE_V2, tmp_path)


def test_law_loads_the_v2_names_in_order():
    law = hill_v2.load_law(TASK_PLANE_V2)
    assert law.muscles == hill_v2.TENDONS


def test_v1_xml_and_tables_untouched():
    """v1's MJCF is still its generator's output, its tables still load against it, and v2 writes elsewhere."""
    assert (MODELS_DIR / "shoulder.xml").read_text() == mjcf.model_xml()
    for source in ("fem", "hill"):
        law = ForceLaw.load(source)
        assert law.muscles == anatomy.MUSCLES
    assert hill_v2.FOLDER != MODELS_DIR / "muscles"
    for t in law.tables:  # v1's hill tables are hill.py's, not written over by hill_v2
        assert t.meta["code_version"] != hill_v2.CODE_VERSION and "plane_deg" not in t.meta
