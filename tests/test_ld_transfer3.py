"""The latissimus dorsi transfer on the full shoulder (`ld_transfer` on the 3-DOF tasks; docs/surgery.md): the full
task model with ld1-3 rerouted as on the v2 arm, their FEM tables re-tensioned by the same rule, and the condition
loading that model and those tables in the single env, the batched env, the reference controller and the statics."""
import json

import numpy as np
import pytest

import shoulder_bench
from shoulder_bench import full_arm
from shoulder_bench.authoring import transfer
from shoulder_bench.authoring.fem.verify_full import applied_vs_fem
from shoulder_bench.model import MODELS_DIR
from shoulder_bench.tasks.track3d import law_for, pose_for
from shoulder_bench.tendon_law import table_path

LD = transfer.REROUTED
POSES = np.array([[0.0, 0.0, 0.0], [30.0, 60.0, -20.0], [80.0, 120.0, 40.0]])


def test_the_full_transfer_model_is_generated_and_reroutes_only_ld():
    rerun = "rerun `python -m shoulder_bench.authoring.mobl`"
    assert (MODELS_DIR / transfer.FULL_TASK_FILENAME).read_text() == transfer.full_task_model_xml(), rerun
    assert full_arm.model_file("ld_transfer") == MODELS_DIR / transfer.FULL_TASK_FILENAME
    pre, post = full_arm.compile_full(), full_arm.compile_full("ld_transfer")
    for key in ("body_pos", "body_quat", "qpos0", "jnt_axis", "site_pos", "geom_size", "eq_data", "actuator_gear"):
        np.testing.assert_array_equal(getattr(pre, key), getattr(post, key), err_msg=key)
    others = [t for t in full_arm.TENDONS if t not in LD]
    L0, r0 = full_arm.Pose(pre).tendon_geometry(POSES, full_arm.TENDONS)
    L1, r1 = full_arm.Pose(post).tendon_geometry(POSES, full_arm.TENDONS)
    keep = [full_arm.TENDONS.index(t) for t in others]
    np.testing.assert_array_equal(L0[:, keep], L1[:, keep])
    ld = [full_arm.TENDONS.index(t) for t in LD]
    # at the side the intact latissimus rotates internally (rotation arm > 0), the transferred one externally, as the
    # infraspinatus whose insertion and head wrap it takes
    assert (r0[0, ld, 2] > 0.005).all() and (r1[0, ld, 2] < -0.015).all()
    assert r1[0, full_arm.TENDONS.index("isp"), 2] < -0.015
    # the same paths as the v2 arm's transfer: the side lengths the re-tensioning rule is computed from
    side = transfer.side_lengths()
    np.testing.assert_allclose(L0[0, ld], [side[t][0] for t in LD], rtol=0, atol=1e-12)
    np.testing.assert_allclose(L1[0, ld], [side[t][1] for t in LD], rtol=0, atol=1e-12)


def test_the_transfer_tables_are_re_tensioned_and_applied_as_tabled():
    slack = transfer.slack_lengths()
    for t in LD:
        with np.load(table_path(t, "fem", full_arm.GEOMETRIES["ld_transfer"]["tables"])) as z:
            meta = json.loads(str(z["meta"]))
        assert meta["geometry"] == "ld_transfer" and meta["model_file"] == "models/shoulder_full_task_ld_transfer.xml"
        assert meta["tendon_slack_length_m"] == pytest.approx(slack[t], abs=1e-12)
    # the surgeon's rule: at the side the transferred bundle is as stretched as the intact one, so the same force
    intact, moved = law_for(), law_for(geometry="ld_transfer")
    L0, _ = pose_for().tendon_geometry(POSES[:1], intact.actuators)
    L1, _ = pose_for("ld_transfer").tendon_geometry(POSES[:1], moved.actuators)
    a = np.ones((1, len(intact.muscles)))
    f0, f1 = intact.force(L0, 0 * L0, a), moved.force(L1, 0 * L1, a)
    ld = [intact.actuators.index(t) for t in LD]
    np.testing.assert_allclose(f1[0, ld], f0[0, ld], rtol=0.02)
    assert not np.allclose(L1[0, ld], L0[0, ld])
    # what MuJoCo applies on the transfer's model is the table's force times its moment arms (`fem verify --full
    # --variant ld_transfer`'s second section)
    checks = applied_vs_fem(muscles=["ld"], geometry="ld_transfer")
    assert len(checks) == 3 and all(ok for _, ok, _ in checks), checks


def test_the_condition_loads_the_rerouted_model_everywhere():
    env = shoulder_bench.load("track_3dof", seed=0, condition="posterosuperior_tear+ld_transfer")
    m = env.physics.model.ptr
    wraps = {m.wrap_objid[k] for k in range(m.tendon_adr[m.tendon("ld1").id],
                                               m.tendon_adr[m.tendon("ld1").id] + m.tendon_num[m.tendon("ld1").id])}
    assert m.geom(transfer.WRAP).id in wraps  # ld1 wraps over the infraspinatus's head cylinder
    assert env.task.geometry == "ld_transfer"
    venv = shoulder_bench.make_vec("track_3dof", 2, seed=0, condition="ld_transfer")
    assert venv.sim.model.ntendon == m.ntendon
    L = pose_for("ld_transfer").tendon_geometry(POSES, LD)[0]
    np.testing.assert_allclose(venv.pose.tendon_geometry(POSES, LD)[0], L, rtol=0, atol=1e-12)
    assert venv.law.tables[venv.law.actuators.index("ld1")].meta["geometry"] == "ld_transfer"
    from shoulder_bench.eval.reference3 import ReferenceController3

    ref = ReferenceController3("track_3dof", condition="posterosuperior_tear+ld_transfer")
    assert ref.law.tables[ref.law.actuators.index("ld2")].meta["geometry"] == "ld_transfer"
    np.testing.assert_allclose(ref.pose.tendon_geometry(POSES, LD)[0], L, rtol=0, atol=1e-12)


def test_variant_requests_are_refused_before_any_solve(tmp_path):
    from shoulder_bench.authoring.fem import full
    from shoulder_bench.cli.fem import main as fem_main

    with pytest.raises(SystemExit, match="--variant is for --full"):
        fem_main(["build", "--variant", "ld_transfer", "--out", str(tmp_path)])
    with pytest.raises(SystemExit, match="--variant is for --full"):
        fem_main(["verify", "--variant", "ld_transfer"])
    with pytest.raises(SystemExit, match="leave --tables out with --variant"):
        fem_main(["verify", "--full", "--variant", "ld_transfer", "--tables", str(tmp_path)])
    with pytest.raises(ValueError, match=r"unknown tendon\(s\) \['ssp'\]; choose from ld1, ld2, ld3 \(the tendons "
                                         r"ld_transfer reroutes\)"):
        full.build(out=tmp_path, tendons_=("ssp",), geometry="ld_transfer")
    with pytest.raises(ValueError, match="--coarse without --out would replace .*muscles_full_ld_transfer"):
        full.build(coarse=True, geometry="ld_transfer")
    assert not any(tmp_path.iterdir())
