"""The tasks' arm (model v2's locked variant): range, coupling, reduced quantities, muscle groups, crash margin."""
import mujoco
import numpy as np
import pytest

from shoulder_bench import arm, statics
from shoulder_bench.arm import harden_couplings
from shoulder_bench.muscle import ForceLaw
from shoulder_bench.simulator import BatchSimulator


def test_range_is_the_models():
    a = arm.arm()
    lo, hi = np.degrees(a.m.jnt_range[a.m.joint(arm.JOINT).id])
    assert (lo, hi) == pytest.approx(arm.RANGE_DEG, abs=0.05)


def test_qpos_lies_on_the_couplings():
    """Every joint equality of the compiled model holds at the prescribed pose (MuJoCo's own constraint residual)."""
    a = arm.arm()
    m = arm.compile_arm()
    d = mujoco.MjData(m)
    for deg in (0.0, 45.0, 120.0, 170.0):
        d.qpos[:] = a.qpos(np.radians(deg))[0]
        mujoco.mj_forward(m, d)
        eq = d.efc_type == mujoco.mjtConstraint.mjCNSTR_EQUALITY
        assert eq.sum() == m.neq and np.abs(d.efc_pos[eq]).max() < 1e-12
        assert np.degrees(d.qpos[a.q]) == pytest.approx(deg)


def test_reduced_quantities_match_their_exact_functions():
    a = arm.arm()
    exact = arm.LockedPath()
    for deg in (3.3, 47.1, 91.9):
        q = np.radians(deg)
        assert a.gravity_torque(q) == pytest.approx(exact.gravity_torque(q), abs=2e-5)
        assert a.inertia(q) == pytest.approx(exact.inertia(q), rel=1e-5)
    # at the table's own points (tabled the whole grid at once): its samples are the functions' values, bit for bit
    assert np.array_equal(a.gravity_torque(a._grid), [exact.gravity_torque(q) for q in a._grid])
    assert np.array_equal(a.inertia(a._grid), [exact.inertia(q) for q in a._grid])
    assert np.array_equal(exact.slopes(a._grid), [exact.slopes(q) for q in a._grid])  # (B, nv) = B times (nv,)
    # gravity pulls the arm down, hardly at the side, most near the horizontal
    g = a.gravity_torque(np.radians([0.0, 45.0, 90.0]))
    assert abs(g[0]) < 0.05 and g[1] < 0 and g[2] < g[1]
    assert a.damping() == 0.0  # the model has no joint damping


def test_one_ld_activation_drives_the_three_bundles():
    a = arm.arm()
    assert arm.actuators_of(("ssp", "ld")) == ("ssp", "ld1", "ld2", "ld3")
    law = a.load_law("hill", ("ssp", "ld"))
    assert law.muscles == ("ssp", "ld") and law.actuators == ("ssp", "ld1", "ld2", "ld3")
    q = np.radians([30.0, 80.0])
    act = np.array([[0.2, 0.7], [0.0, 0.3]])
    per = ForceLaw([t for t in law.tables])  # the same tables, each its own muscle
    expanded = act[:, [0, 1, 1, 1]]
    assert np.allclose(law.force(q, q * 0, act), per.force(q, q * 0, expanded))
    tau = per.torque(q, q * 0, expanded)
    assert np.allclose(law.torque(q, q * 0, act), np.stack([tau[:, 0], tau[:, 1:].sum(axis=1)], axis=1))
    with pytest.raises(ValueError, match="unknown muscle"):
        arm.actuators_of(("ld1",))


def test_holding_activation_holds_the_arm():
    """At the holding activations the muscle torque cancels gravity (the episodes' start)."""
    law = arm.arm().load_law("fem")
    deg = np.array([25.0, 60.0, 95.0])
    a = statics.holding_activation(law, deg)
    q = np.radians(deg)
    net = law.torque(q, q * 0, a).sum(axis=1) + statics.gravity_torque(q)
    assert np.abs(net).max() < 1e-3


def test_a_free_fall_stays_within_the_crash_margin():
    """The relaxed arm dropped from the top of the range overshoots the soft lower limit, but by less than the crash
    margin (a fall is not a numerical failure)."""
    a = arm.arm()
    sim = BatchSimulator(None, 1, path=arm.MODEL_FILE, prepare=harden_couplings)
    qpos, qvel = a.qpos(np.radians([arm.RANGE_DEG[1]])), np.zeros((1, sim.nv))
    low = np.inf
    for _ in range(40):
        qpos, qvel, bad = sim.frame_state(qpos, qvel)
        assert not bad.any()
        low = min(low, float(np.degrees(qpos[0, sim.qadr])))
    sim.close()
    assert arm.RANGE_DEG[0] - arm.VALID_MARGIN_DEG < low < arm.RANGE_DEG[0] - 5.0  # it does overshoot
