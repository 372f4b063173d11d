"""The band tables applied in MuJoCo (shoulder_bench/band_lines.py, the passive callbacks; the 3-DOF tasks'
line_of_action="band", and "band_fibres"): the correction read as scipy reads the tables, the compiled and the Python
callbacks alike, the applied generalised force the band's, the statics and the options (the batched env against the
single env with the bands: tests/test_tasks_3dof.py)."""
from __future__ import annotations

import mujoco
import numpy as np
import pytest

import shoulder_bench
from shoulder_bench import full_arm
from shoulder_bench.band_lines import BAND_TENDONS, BandLines, table_path
from shoulder_bench.model import attach_law, install_callbacks
from shoulder_bench.tendon_law import TendonLaw

POSE = np.array([37.0, 63.0, 11.0])  # deg, between grid poses in every coordinate


def _forward(law, pose_deg, activation: float, native: bool = True, rates=None):
    """mj_forward at a pose with every muscle at `activation` (and the coordinates at `rates` rad/s, default at
    rest); native=False: the Python actuator callbacks (the band forces come from the compiled passive callback
    either way)."""
    m = full_arm.compile_full()
    attach_law(m, law)
    install_callbacks(native=native)
    try:
        pose, d = full_arm.Pose(m), mujoco.MjData(m)
        d.qpos[:] = pose.qpos(pose_deg)[0]
        d.qvel[pose.dadr] = 0.0 if rates is None else rates
        d.ctrl[:] = activation
        mujoco.mj_forward(m, d)
    finally:
        install_callbacks()
    return m, d, pose


def test_the_correction_is_the_tables_read_trilinearly():
    from shoulder_bench.authoring.fem.bands import BandTable

    lines = BandLines.load()
    rng = np.random.default_rng(0)
    lo, hi = np.array([0.0, 0.0, -45.0]), np.array([90.0, 140.0, 60.0])
    poses = lo + (hi - lo) * rng.random((200, 3))
    got = lines.correction(poses)
    for b, t in enumerate(BAND_TENDONS):
        np.testing.assert_allclose(got[:, b], BandTable(table_path(t)).correction(poses), rtol=0, atol=1e-12)
    # beyond the grid: its edge values
    np.testing.assert_allclose(lines.correction([[-30.0, 70.0, 200.0]]), lines.correction([[0.0, 70.0, 60.0]]),
                               atol=1e-8)


def test_mujoco_applies_the_band_line_of_action_with_either_callback():
    law = TendonLaw.load("fem", groups=full_arm.ACTUATORS, line_of_action="band")
    m, d, pose = _forward(law, POSE, 0.4)
    _, d_python, _ = _forward(law, POSE, 0.4, native=False)
    _, d_mjcf, _ = _forward(TendonLaw.load("fem", groups=full_arm.ACTUATORS), POSE, 0.4)
    np.testing.assert_allclose(d_python.qfrc_passive, d.qfrc_passive, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(d_python.qacc, d.qacc, rtol=1e-9, atol=1e-9)
    S = pose.slopes(POSE)
    band = S.T @ (d.qfrc_passive - d_mjcf.qfrc_passive)
    assert np.abs(band).max() > 0.05  # N m: the corrections matter at this pose
    # the whole generalised force is sum_t F_t (r_MJCF + c_t), the bands' arms for their tendons
    L, r = law.geometry(pose, POSE, np.full(len(law.muscles), 0.4))  # the arms at a = 0.4 (tma's level table)
    f = law.force(L, np.zeros_like(L), np.full((1, len(law.muscles)), 0.4))[0]
    own = d.qfrc_passive - d.qfrc_spring - d.qfrc_damper - d.qfrc_gravcomp - d.qfrc_fluid
    np.testing.assert_allclose(S.T @ (d.qfrc_actuator + own), f @ r[0], rtol=1e-9)
    cols = [law.actuators.index(t) for t in law.lines.tendons]  # the lines' order: the model's
    np.testing.assert_allclose(band, f[cols] @ law.lines.correction(POSE, 0.4)[0], rtol=1e-9)


def test_the_band_force_is_read_at_the_band_length_and_lengthening_rate_with_either_callback():
    law = TendonLaw.load("fem", groups=full_arm.ACTUATORS, line_of_action="band")
    m = full_arm.compile_full()
    attach_law(m, law)
    pose, out = full_arm.Pose(m), {}
    rates = np.array([0.4, -0.7, 1.1])  # rad/s about plane, elevation, rotation
    for native in (True, False):
        install_callbacks(native=native)
        try:
            d = mujoco.MjData(m)
            d.qpos[:] = pose.qpos(POSE)[0]
            d.qvel[pose.dadr] = rates
            d.ctrl[:] = 0.6
            mujoco.mj_forward(m, d)
            out[native] = d
        finally:
            install_callbacks()
    d = out[True]
    np.testing.assert_allclose(out[False].actuator_force, d.actuator_force, rtol=1e-12, atol=1e-9)
    cols = [law.actuators.index(t) for t in law.lines.tendons]
    dl, dv = law.lines.lengthening(POSE, rates, 0.6)
    np.testing.assert_allclose(dv[0], -(law.lines.correction(POSE, 0.6)[0] @ rates), rtol=1e-12)
    ids = [m.actuator(t).id for t in law.actuators]
    length, speed = d.actuator_length[ids].copy(), d.actuator_velocity[ids].copy()
    length[cols] += dl[0]
    speed[cols] += dv[0]
    act = np.full((1, len(law.muscles)), 0.6)
    # what the planners read (TendonLaw.geometry, lengthening_rates) is what the callbacks read
    np.testing.assert_allclose(law.geometry(pose, POSE, act)[0][0], length, rtol=0, atol=1e-12)
    np.testing.assert_allclose(law.lengthening_rates(POSE, rates, d.actuator_velocity[ids], act)[0], speed, atol=1e-15)
    np.testing.assert_allclose(-d.actuator_force[ids], law.force(length[None], speed[None], act)[0], rtol=1e-9)
    # the length counts: at the MJCF path's length ssc's force differs by newtons here
    mjcf = law.force(d.actuator_length[ids][None], speed[None], act)[0]
    k = law.actuators.index("ssc")
    assert abs(mjcf[k] + d.actuator_force[ids[k]]) > 5.0
    assert abs(dl[0, law.lines.tendons.index("ssc")]) > 5e-4  # m


def test_the_band_length_is_the_least_squares_potential_of_the_correction():
    from shoulder_bench.band_lines import LENGTH_ANCHOR_DEG, integrate_arms

    axes = [np.linspace(0.0, 90.0, 7), np.linspace(0.0, 140.0, 15), np.linspace(-45.0, 60.0, 8)]
    q = np.radians(np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1))
    steps = [np.radians(a[1] - a[0]) for a in axes]
    length = 0.01 * np.sin(q[..., 0]) * np.cos(q[..., 1]) + 0.004 * q[..., 2] ** 2  # m
    arms = -np.stack([0.01 * np.cos(q[..., 0]) * np.cos(q[..., 1]), -0.01 * np.sin(q[..., 0]) * np.sin(q[..., 1]),
                      0.008 * q[..., 2]], axis=-1)
    got, residual = integrate_arms(arms, steps)
    np.testing.assert_allclose(got, length - length[0, 0, 0], atol=2e-4)  # the trapezoid rule's error
    assert np.abs(residual).max() < 1e-4
    swirl = np.stack([-q[..., 2], np.zeros_like(q[..., 0]), q[..., 0]], axis=-1) * 0.01  # no potential
    assert np.abs(integrate_arms(swirl, steps)[1]).max() > 1e-3
    lines = BandLines.load(("ssc",))
    assert abs(lines.lengthening([LENGTH_ANCHOR_DEG])[0][0, 0]) < 1e-12  # zero at the anchor
    assert np.ptp(lines.lengths) > 0.01  # ssc's band length departs from its MJCF path's by centimetres


def test_the_applied_check_passes_with_the_bands_and_fails_without():
    from shoulder_bench.authoring.fem.verify_full import applied_checks, applied_vs_fem

    assert all(ok for _, ok, _ in applied_vs_fem(line_of_action="band", muscles=("tmi",)))
    with np.load(table_path("tmi")) as z:
        arms = z["moment_arm_m"].reshape(-1, 1, 3)
    checks = applied_checks(TendonLaw.load("fem", ("tmi",)), "tmi", full_arm.pose_grid(), arms)  # MJCF line only
    assert not all(ok for _, ok, _ in checks)


def test_the_holding_activations_hold_the_arm_with_the_bands():
    from shoulder_bench.statics_full import Statics

    law = TendonLaw.load("fem", groups=full_arm.ACTUATORS, line_of_action="band")
    st = Statics(law)
    for pose_deg in ([30, 30, -20], [70, 90, 30]):
        a, residual = st.holding(pose_deg)
        assert residual < 1e-3
        m = full_arm.compile_full()
        attach_law(m, law)
        install_callbacks()
        d = mujoco.MjData(m)
        d.qpos[:] = st.pose.qpos(pose_deg)[0]
        for k, muscle in enumerate(law.muscles):
            d.ctrl[[m.actuator(t).id for t in law.groups[muscle]]] = a[k]
        mujoco.mj_forward(m, d)
        net = st.pose.slopes(pose_deg).T @ (d.qfrc_actuator + d.qfrc_passive - d.qfrc_bias)
        assert np.abs(net).max() < 0.01  # N m: at rest (the joints' own springs and dampers are zero here)


def test_line_of_action_option_errors():
    with pytest.raises(ValueError, match="line_of_action must be one of 'mjcf', 'band'"):
        shoulder_bench.load("track_3dof", line_of_action="fem")
    with pytest.raises(ValueError, match="3-DOF tasks only"):
        shoulder_bench.load("abduction_4m", line_of_action="band")
    from shoulder_bench.tasks import check_options

    assert check_options("track_3dof", line_of_action="band") == {"line_of_action": "band"}
    with pytest.raises(ValueError, match="abduction"):  # a band law on a model without the three coordinates
        from shoulder_bench.model import compile_model

        law = TendonLaw.load("fem", ("ssp",))
        law.lines = BandLines.load(("ssp",))
        attach_law(compile_model(), law)
    m = full_arm.compile_full()  # a band actuator whose ctrl is not the muscle's activation in [0, 1]
    m.actuator_ctrllimited[m.actuator("ld2").id] = 0
    with pytest.raises(ValueError, match="actuator 'ld2': a band correction needs a ctrl limited to"):
        attach_law(m, TendonLaw.load("fem", groups=full_arm.ACTUATORS, line_of_action="band"))


def test_fibre_tables_on_other_grids_are_refused(tmp_path):
    """The fibres are read on their tables' own grid, so all must share one: a table on every other plane is refused."""
    import shutil

    from shoulder_bench.band_lines import fibres_path, table_path

    for t in ("ssp", "pec2"):
        for path in (table_path(t), fibres_path(t)):
            shutil.copy(path, tmp_path / path.name)
    assert BandLines.load(("ssp", "pec2"), tmp_path, fibres=True).fibres.shape[:5] == (2, 1, 7, 15, 8)
    with np.load(fibres_path("pec2")) as z:
        arrays = {k: z[k] for k in z.files}
    arrays["plane_deg"], arrays["departure_m"] = arrays["plane_deg"][::2], arrays["departure_m"][::2]
    np.savez(fibres_path("pec2", tmp_path), **arrays)
    with pytest.raises(ValueError, match="fibre tables of ssp, pec2 on other grids"):
        BandLines.load(("ssp", "pec2"), tmp_path, fibres=True)


def test_mujoco_applies_the_fibres_force_with_either_callback():
    """line_of_action="band_fibres": each band tendon's force MuJoCo applies is the mean of its fibres' law, each at
    the band's length plus its departure read from the fibre table (`fibre_force`), with the compiled and the Python
    callbacks alike; the bands' line as with "band"; the other tendons as before."""
    from shoulder_bench.authoring.fem import band_fibres as F

    pose_deg, rates = np.array([52.0, 118.0, 27.0]), np.array([0.3, -0.5, 0.8])
    out = {}
    for line, native in (("band_fibres", True), ("band_fibres", False), ("band", True)):
        law = TendonLaw.load("fem", groups=full_arm.ACTUATORS, line_of_action=line)
        out[line, native] = (law, *_forward(law, pose_deg, 0.7, native, rates)[:2])
    law, m, d = out["band_fibres", True]
    np.testing.assert_allclose(out["band_fibres", False][2].actuator_force, d.actuator_force, rtol=1e-12, atol=1e-9)
    ids = [m.actuator(t).id for t in law.actuators]
    cols = [law.actuators.index(t) for t in law.lines.tendons]
    dl, dv = law.lines.lengthening(pose_deg, rates, 0.7)
    length, speed = d.actuator_length[ids].copy(), d.actuator_velocity[ids].copy()
    length[cols] += dl[0]
    speed[cols] += dv[0]
    departures = law.lines.departures(pose_deg)[0]
    assert law.lines.fibres.shape[2:5] == (7, 15, 8)  # on the fibre tables' own grid, not the nesting one
    for b, t in enumerate(law.lines.tendons):
        one = TendonLaw.load("fem", (t,))
        want = F.fibre_force(one, length[cols[b]], departures[b][None], 0.7, speed[cols[b]])[0]
        assert -d.actuator_force[ids[cols[b]]] == pytest.approx(want, rel=1e-9)
        np.testing.assert_allclose(departures[b], F.FibreTable.load(t).departure([pose_deg])[0], atol=1e-12)
    # what the planners read (TendonLaw.force with TendonLaw.departures) is what MuJoCo applies, every tendon
    act = np.full((1, len(law.muscles)), 0.7)
    np.testing.assert_allclose(law.force(length[None], speed[None], act, law.departures(pose_deg)),
                               -d.actuator_force[ids][None], rtol=1e-9)
    assert not law.departures(pose_deg)[0][:, [k for k in range(len(ids)) if k not in cols]].any()
    np.testing.assert_allclose(law.force(length[None], speed[None], act, np.zeros((1, 9, len(ids)))),
                               law.force(length[None], speed[None], act), rtol=1e-12)
    band = out["band", True][2]
    others = [ids[k] for k in range(len(ids)) if k not in cols]
    np.testing.assert_allclose(band.actuator_force[others], d.actuator_force[others], rtol=1e-12)
    gap = np.abs(band.actuator_force[ids] - d.actuator_force[ids])[cols]
    assert gap.max() > 1.0  # N: the fibres change some band tendon's force here


def test_mujoco_applies_the_compliant_tendons_law():
    """tendon="compliant" (`tendon_compliance`): the compiled callbacks apply the compliant tables' force, every
    tendon's less than with the rigid tendon."""
    out = {}
    for tendon in ("rigid", "compliant"):
        law = TendonLaw.load("fem", groups=full_arm.ACTUATORS, tendon=tendon)
        m, d, _ = _forward(law, POSE, 0.8)
        ids = [m.actuator(t).id for t in law.actuators]
        f = law.force(d.actuator_length[ids][None], d.actuator_velocity[ids][None],
                      np.full((1, len(law.muscles)), 0.8))[0]
        np.testing.assert_allclose(-d.actuator_force[ids], f, rtol=1e-9)
        out[tendon] = f
    assert np.all(out["compliant"] <= out["rigid"] + 1e-9) and (out["rigid"] - out["compliant"]).max() > 5.0
