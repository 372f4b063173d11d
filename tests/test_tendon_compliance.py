"""The parent's compliant tendon in series with the full shoulder's FEM sheets (`tendon="compliant"`)."""
import numpy as np
import pytest

import shoulder_bench
from shoulder_bench import full_arm
from shoulder_bench import tendon_compliance as tc
from shoulder_bench.tendon_law import TendonTable, table_path


def _table(tendon: str) -> TendonTable:
    return TendonTable.load(table_path(tendon, "fem"))


def test_the_parents_tendon_reaches_f0_at_3_3_percent_strain():
    force, strain = tc.strain_curve("SUPSP")
    assert force[0] == 0.0 and strain[0] == 0.0 and np.all(np.diff(force) > 0)
    assert np.interp(1.0, force, strain) == pytest.approx(0.033, abs=0.001)  # docs/tendons.md's 3.3 %
    assert np.interp(0.227, force, strain) == pytest.approx(0.0123, rel=1e-6)  # the toe region's last knot


def test_each_knot_of_a_compliant_table_is_the_series_equilibrium():
    for t in ("dmi", "cor", "pec3"):
        table = _table(t)
        soft = tc.compliant_table(table)
        assert len(soft.length_m) == (len(table.length_m) - 1) * tc.REFINE + 1
        for j, a in enumerate(soft.activation):
            f = soft.force_N[:, j]
            sheet = tc.read(table, soft.length_m - tc.stretch(table, f), a)  # the sheet, shorter by the stretch
            np.testing.assert_allclose(f, sheet, atol=1e-6 * table.meta["F0_N"])
            rigid = tc.read(table, soft.length_m, a)
            assert np.all(f <= rigid + 1e-6 * table.meta["F0_N"])  # on their rising limb: the stretch costs force
        assert (tc.read(table, soft.length_m, 1.0) - soft.force_N[:, -1]).max() > 0.01 * table.meta["F0_N"]


def test_the_least_stretch_root_is_kept():
    f0, l_ts, length = 100.0, 0.1, 0.2
    curve = (np.array([0.0, 1.0, 10.0]), np.array([0.0, 0.01, 0.1]))  # linear: 1 mm of stretch per F0

    def rigid(x):  # zero at the full length; beyond 1.5 mm shorter, far more than the tendon carries there
        return np.where(length - x < 1.5e-3, 0.0, 300.0)

    f = tc.series_force(rigid, np.array([length]), f0, l_ts, curve, 300.0)
    assert f[0] == pytest.approx(0.0, abs=1e-9)  # not the root at 300 N (3 mm of stretch)


def test_the_compliant_tables_read_the_equilibrium_between_their_knots():
    for t in full_arm.TENDONS:
        table = _table(t)
        err = tc.interpolation_error(table, tc.compliant_table(table))
        assert err["max_F0"] < 0.005, (t, err)  # benchmarks/tendon_compliance.py's bound


def test_the_option_reaches_the_task_and_its_reference_controller():
    from shoulder_bench.eval.board3 import law_of
    from shoulder_bench.eval.evaluate import law_options
    from shoulder_bench.eval.reference3 import ReferenceController3

    env = shoulder_bench.load("track_3dof", tendon="compliant", seed=0)
    assert all("compliant" in t.meta["tendon"] for t in env.physics.law.tables)
    assert all("tendon" not in t.meta for t in shoulder_bench.load("track_3dof", seed=0).physics.law.tables)
    ctrl = ReferenceController3("track_3dof", tendon="compliant")
    assert all("tendon" in t.meta for t in ctrl.law.tables)
    assert law_options({"tendon": "compliant", "alpha": 0.1}) == {"tendon": "compliant"}
    # the board's reference rows: one per law its runs simulate, the defaults left out of the key
    assert law_of({"tendon": "compliant", "line_of_action": "mjcf", "alpha": 0.1}) == '{"tendon": "compliant"}'
    assert law_of(None) == law_of({"tendon": "rigid"}) == "{}"
    with pytest.raises(ValueError, match="tendon must be one of 'rigid', 'compliant'"):
        shoulder_bench.load("track_3dof", tendon="soft")
    with pytest.raises(ValueError, match="3-DOF tasks only"):
        shoulder_bench.load("abduction_4m", tendon="compliant")
