"""The latissimus dorsi transfer (issue 13 `ld_transfer`, shoulder_bench/authoring/transfer.py, docs/surgery.md): a
geometric reroute of ld1-3 with its own model files and tables, loaded by the condition in every API."""
from __future__ import annotations

import json

import mujoco
import numpy as np
import pytest

import shoulder_bench
from shoulder_bench import arm as arm_
from shoulder_bench import conditions
from shoulder_bench.authoring import hill_v2, transfer
from shoulder_bench.authoring.fem import v2
from shoulder_bench.authoring.validate import TASK_PLANE_V2
from shoulder_bench.model import MODELS_DIR
from shoulder_bench.muscle import MuscleTable, table_path

LD = transfer.REROUTED


def test_shipped_transfer_models_are_generated():
    rerun = "rerun `python -m shoulder_bench.authoring.mobl`"
    assert (MODELS_DIR / transfer.FILENAME).read_text() == transfer.model_xml(), rerun
    assert (MODELS_DIR / transfer.TASK_FILENAME).read_text() == transfer.task_model_xml(), rerun
    assert arm_.model_file("ld_transfer") == MODELS_DIR / transfer.TASK_FILENAME


def test_only_the_ld_routes_change():
    pre, post = (mujoco.MjModel.from_xml_path(str(arm_.model_file(g, dofs=3))) for g in (None, "ld_transfer"))
    for key in ("body_pos", "body_quat", "qpos0", "jnt_axis", "site_pos", "geom_size", "eq_data"):
        np.testing.assert_array_equal(getattr(pre, key), getattr(post, key), err_msg=key)
    d0, d1 = mujoco.MjData(pre), mujoco.MjData(post)
    mujoco.mj_forward(pre, d0)
    mujoco.mj_forward(post, d1)
    for t in ("ssp", "isp", "dmi"):
        assert d0.ten_length[pre.tendon(t).id] == d1.ten_length[post.tendon(t).id]
    for t in LD:  # new insertion and wrap: isp's; the kept items: the bundle's own scapular and thoracic points
        items = transfer.rerouted_paths()[t]
        assert items[0].name == transfer.INSERTION and items[1].name == transfer.WRAP
        assert all(it.body in ("scapula", "thorax") for it in items[2:])
        assert d0.ten_length[pre.tendon(t).id] != d1.ten_length[post.tendon(t).id]


def test_rerouted_moment_arms_differ_as_documented():
    """docs/surgery.md: the intact ld rotates internally at 0 deg (-6.7..-11.2 mm external), the transferred ld
    externally, about as the infraspinatus (18.4-21.0 mm); its adducting elevation arm at 60-120 deg is smaller."""
    from shoulder_bench.eval.conditions import rotation_arms

    pre, post = (rotation_arms(g, [0.0], LD + ("isp",))[0] * 1000 for g in (None, "ld_transfer"))
    assert np.all(pre[:3] < -5.0) and np.all(post[:3] > 15.0)
    assert np.all(np.abs(post[:3] - post[3]) < 3.0)  # wraps like the infraspinatus
    assert pre[3] == post[3]
    deg = [60.0, 90.0, 120.0]
    e0 = arm_.arm().tendon_geometry(deg, LD)[1]
    e1 = arm_.arm("ld_transfer").tendon_geometry(deg, LD)[1]
    assert np.all(e0.sum(axis=1) < e1.sum(axis=1)) and np.all(e1.sum(axis=1) < 0)


def test_retensioning_keeps_the_fibre_stretch_at_the_side():
    L = transfer.side_lengths()
    lts = transfer.slack_lengths()
    parent = transfer.variant(None).parameters()
    for t in LD:
        old, new = L[t]
        assert new - lts[t] == pytest.approx(old - parent[t].l_ts, abs=1e-12)
        meta = MuscleTable.load(table_path(t, "hill", transfer.FOLDER)).meta
        assert meta["tendon_slack_length_m"] == pytest.approx(lts[t], abs=1e-15)
        assert meta["optimal_fibre_length_m"] == parent[t].l_opt and meta["variant"] == "ld_transfer"


def test_transfer_tables_are_up_to_date():
    built = hill_v2.tables(TASK_PLANE_V2, "ld_transfer")
    for t in LD:
        shipped = MuscleTable.load(table_path(t, "hill", transfer.FOLDER))
        for key in ("force_N", "torque_Nm", "moment_arm_m"):
            np.testing.assert_allclose(getattr(shipped, key), built[t][key], rtol=1e-9, atol=1e-9, err_msg=t)
        assert shipped.meta == json.loads(json.dumps(built[t]["meta"]))
    want = v2.input_hashes(TASK_PLANE_V2, variant="ld_transfer")
    for t in LD:
        meta = MuscleTable.load(table_path(t, "fem", transfer.FOLDER)).meta
        assert meta["input_hash"] == want[t], f"{t}: rebuild with `python -m shoulder_bench.authoring.fem.v2 " \
                                              "--variant ld_transfer`"


def test_applied_torque_equals_transfer_table():
    for t, r in hill_v2.applied_vs_table(TASK_PLANE_V2, source="hill", variant="ld_transfer").items():
        assert r["max_err_pct_of_peak"] < hill_v2.BOUND_PCT, (t, r)


def test_conditions_compose_with_the_transfer():
    c = "posterosuperior_tear+ld_transfer"
    assert conditions.geometry(c) == "ld_transfer" and conditions.geometry("ssp_tear") is None
    assert conditions.factors(c, arm_.MUSCLES) == {"ssp": 0.0, "isp": 0.0}
    assert conditions.factors("ld_transfer", arm_.MUSCLES) == {}
    law = arm_.arm_for(c).load_law("fem", arm_.MUSCLES, c)
    assert law.actuators == arm_.actuators_of(arm_.MUSCLES)
    with pytest.raises(ValueError, match="arm_for"):
        arm_.arm().load_law("fem", arm_.MUSCLES, "ld_transfer")
    with pytest.raises(ValueError, match="unknown condition 'ld'"):
        conditions.names("ld+posterosuperior_tear")


def _ld_length(physics_model, data) -> float:
    return float(data.ten_length[physics_model.tendon("ld1").id])


def test_every_api_loads_the_transfer_and_preop_is_unchanged():
    pre_law = arm_.arm().load_law("fem", arm_.MUSCLES)
    want = {}
    for g in (None, "ld_transfer"):
        m = arm_.compile_arm(g)
        d = mujoco.MjData(m)
        mujoco.mj_forward(m, d)
        want[g] = _ld_length(m, d)
    env = shoulder_bench.load("abduction_4m", condition="posterosuperior_tear+ld_transfer", seed=0)
    env.reset()
    ph = env.physics
    mujoco.mj_forward(ph.model.ptr, ph.data.ptr)
    got = float(ph.data.ten_length[ph.model.name2id("ld1", "tendon")])
    m = arm_.compile_arm("ld_transfer")
    d = mujoco.MjData(m)
    d.qpos[:] = ph.data.qpos
    mujoco.mj_forward(m, d)
    assert got == pytest.approx(_ld_length(m, d), abs=1e-12)
    vec = shoulder_bench.make_vec("abduction_4m", 2, condition="ld_transfer", seed=0)
    assert vec.arm.geometry == "ld_transfer" and vec.sim.model.ntendon == m.ntendon
    vec_m = vec.sim.model
    d2 = mujoco.MjData(vec_m)
    mujoco.mj_forward(vec_m, d2)
    assert _ld_length(vec_m, d2) == pytest.approx(want["ld_transfer"], abs=1e-12)
    # the pre-op shoulder, loaded after, is the intact one
    pre = shoulder_bench.load("abduction_4m", seed=0)
    pre.reset()
    m0 = arm_.compile_arm()
    d0 = mujoco.MjData(m0)
    d0.qpos[:] = pre.physics.data.qpos
    mujoco.mj_forward(m0, d0)
    mujoco.mj_forward(pre.physics.model.ptr, pre.physics.data.ptr)
    assert float(pre.physics.data.ten_length[pre.physics.model.name2id("ld1", "tendon")]) == _ld_length(m0, d0)
    again = arm_.arm().load_law("fem", arm_.MUSCLES)
    for a, b in zip(pre_law.tables, again.tables):
        np.testing.assert_array_equal(a.force_N, b.force_N)
        np.testing.assert_array_equal(a.moment_arm_m, b.moment_arm_m)
    assert want[None] != want["ld_transfer"]
