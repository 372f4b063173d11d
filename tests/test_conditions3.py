"""Shoulder conditions on the 3-DOF tasks (issue 12 §4: the 1-DOF tasks' conditions on the full shoulder): a tear
or a weakness scales the muscle's tabled force in the law MuJoCo applies (`tasks.track3d.law_for`), the same in the
single env, the batched env (tests/test_physiology3.py) and the reference controller's plan (ld_transfer, a
rerouting: tests/test_ld_transfer3.py)."""
import mujoco
import numpy as np
import pytest

import shoulder_bench
from shoulder_bench import full_arm, trajectory3
from shoulder_bench.eval.evaluate import evaluate
from shoulder_bench.eval.reference3 import ReferenceController3
from shoulder_bench.tasks.track3d import law_for


def _forces(env) -> np.ndarray:
    """Each actuator's force with every muscle fully on, at the episode's start."""
    physics = env.physics
    physics.set_activations(full_arm.MUSCLES, np.ones(len(full_arm.MUSCLES)))
    mujoco.mj_forward(physics.model.ptr, physics.data.ptr)
    return physics.data.actuator_force.copy()


def test_a_tear_removes_and_a_partial_tear_scales_the_muscles_force():
    intact = _forces(shoulder_bench.load("track_3dof", seed=0))
    torn = _forces(shoulder_bench.load("track_3dof", seed=0, condition="posterosuperior_tear"))
    partial = _forces(shoulder_bench.load("track_3dof", seed=0, condition="ssp_partial_tear", tear_fraction=0.3))
    ids = {t: k for k, t in enumerate(full_arm.TENDONS)}
    assert np.abs(intact[ids["ssp"]]) > 10.0 and torn[ids["ssp"]] == 0.0 and torn[ids["isp"]] == 0.0
    assert partial[ids["ssp"]] == pytest.approx(0.7 * intact[ids["ssp"]], rel=1e-12)
    others = [ids[t] for t in full_arm.TENDONS if t not in ("ssp", "isp")]
    np.testing.assert_array_equal(torn[others], intact[others])
    law = law_for(factors={"ld": 0.5})  # a muscle's every tendon (ld's three)
    L = np.full((1, len(law.actuators)), 0.15)
    a = np.ones((1, len(law.muscles)))
    ratio = law.force(L, 0 * L, a) / law_for().force(L, 0 * L, a)
    ld = [law.actuators.index(t) for t in full_arm.ACTUATORS["ld"]]
    np.testing.assert_allclose(ratio[0, ld], 0.5)
    np.testing.assert_allclose(np.delete(ratio[0], ld), 1.0)


def test_the_reference_controller_plans_with_the_condition():
    """Planning with the torn shoulder's law tracks it; planning with the intact one leans on a muscle that is not
    there and loses the arm (70 deg MAE on these six trajectories when this test was written)."""
    test = trajectory3.load_test_set()[:6]
    aware = evaluate(ReferenceController3("track_3dof", condition="ssp_tear"), "track_3dof", test,
                     options={"condition": "ssp_tear"})["mae_deg"]
    blind = evaluate(ReferenceController3("track_3dof"), "track_3dof", test, options={"condition": "ssp_tear"})
    assert aware < 8.0 and blind["mae_deg"] > 3 * aware


def test_condition_errors_on_the_3dof_tasks():
    with pytest.raises(ValueError, match="tear_fraction applies only with ssp_partial_tear"):
        shoulder_bench.make_vec("track_3dof", 2, condition="ssp_tear", tear_fraction=0.3)
    with pytest.raises(ValueError, match="unknown condition .frozen_shoulder.; valid conditions: ssp_tear"):
        shoulder_bench.load("track_3dof_discrete", condition="frozen_shoulder")
