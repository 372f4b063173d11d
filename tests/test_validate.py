"""`shoulder-bench model validate`: the reference tables, the model's moment arms, the target logic, the command."""
import json

import numpy as np
import pytest

from shoulder_bench import anatomy, cli, references, statics, validate
from shoulder_bench.model import tendon_geometry

MGC = anatomy.HUMERUS_MASS * statics.GRAVITY * np.linalg.norm(anatomy.HUMERUS_COM)  # gravity torque at 90 deg


@pytest.fixture(scope="module")
def refs():
    return references.load()


def test_loader_reproduces_the_reference_readme(refs):
    # README section 5 (girdle fixed / coupled, plane 0 = coronal, 30 = scapular, rotation 0), one decimal printed
    cases = [("myoarm", "SUPSP", 0, "fixed", 0, 27.0), ("mobl_opensim", "DELT2", 0, "fixed", 0, 14.4),
             ("myoarm", "DELT2", 30, "coupled", 90, 16.2), ("mobl_opensim", "LAT", 0, "coupled", 120, -23.1),
             ("myoarm", "LAT3", 0, "coupled", 0, 23.0), ("mobl_arms", "DELT2", 0, "fixed", 0, 33.4)]
    for model, muscle, plane, girdle, elv, want in cases:
        got = refs.raw_curve(model, muscle, "shoulder_elv", plane, girdle, [elv])[0]
        assert got == pytest.approx(want, abs=0.05), (model, muscle, plane, girdle, elv)
    # the parent's SUPSP, fixed coronal, at 0/30/60/90/120 (README 6.4)
    parent = refs.curve("mobl_arms", "ssp", "shoulder_elv", 0, "fixed", [0, 30, 60, 90, 120])
    np.testing.assert_allclose(parent, [27.9, 27.7, 26.3, 11.6, -19.7], atol=0.05)
    # signs of README section 3: INFSP externally rotates (-), SUBSC internally (+); elv_angle is 0 at elevation 0
    assert refs.raw_curve("myoarm", "INFSP", "shoulder_rot", 0, "fixed", [0])[0] < -15
    assert refs.raw_curve("myoarm", "SUBSC", "shoulder_rot", 0, "fixed", [0])[0] > 10
    for model in references.REFERENCES:
        assert refs.curve(model, "dmi", "elv_angle", 30, "coupled", [0])[0] == 0.0


def test_ld_is_the_f0_weighted_mean_of_the_lat_bundles(refs):
    f0 = {"LAT1": 335.3, "LAT2": 535.42, "LAT3": 179.495}  # MyoArm, muscle_parameters.csv
    r = {"LAT1": 10.5, "LAT2": 20.8, "LAT3": 23.0}  # coupled coronal at 0 deg, README section 5
    want = sum(f0[b] * r[b] for b in f0) / sum(f0.values())
    assert refs.curve("myoarm", "ld", "shoulder_elv", 0, "coupled", [0])[0] == pytest.approx(want, abs=0.05)
    # the OpenSim file's single LAT is taken as it is
    assert refs.curve("mobl_opensim", "ld", "shoulder_elv", 0, "fixed", [0])[0] == pytest.approx(0.0, abs=0.05)
    assert refs.f0[("mobl_arms", "LAT1")] + refs.f0[("mobl_arms", "LAT2")] + refs.f0[("mobl_arms", "LAT3")] == \
        pytest.approx(anatomy.F0["ld"])


def test_loader_errors_name_the_problem(refs, tmp_path):
    with pytest.raises(KeyError, match="elevation 5 deg"):
        refs.raw_curve("myoarm", "SUPSP", "shoulder_elv", 0, "fixed", [5])
    with pytest.raises(FileNotFoundError, match="moment_arms_mobl_arms_parent"):
        references.ReferenceTables.load(tmp_path)


def test_every_follows_and_exclusion_names_a_real_reference():
    for m in anatomy.MUSCLES:
        ref, why = references.FOLLOWS[m]
        assert ref in references.REFERENCES and len(why) > 20
        assert set(references.ENVELOPE_EXCLUDED.get(m, {})) <= set(references.REFERENCES) - {ref}


def test_model_moment_arms_match_a_finite_difference_of_tendon_length():
    angles, h = np.arange(5.0, 120.0, 10.0), 0.05
    arms = validate.model_moment_arms(angles)
    up, down = tendon_geometry(angles + h)[0], tendon_geometry(angles - h)[0]
    for m in anatomy.MUSCLES:
        fd = -(up[m] - down[m]) / np.radians(2 * h) * 1000.0
        np.testing.assert_allclose(arms[m], fd, atol=0.02, err_msg=m)
    assert arms["dmi"].max() > 10 and arms["ld"].min() < -10  # mm, not m, with the references' sign


def test_envelope_target_at_its_bound():
    refs = {"a": np.zeros(5), "b": np.full(5, 10.0)}  # envelope -3 .. 13 mm
    for curve, ok in ((np.full(5, 12.99), True), (np.full(5, 13.01), False), (np.full(5, -2.99), True),
                      (np.r_[5.0, 5, -3.01, 5, 5], False), (np.r_[0.0, 10, 13, -3, 5], True)):
        passed, env = validate.inside_envelope(curve, refs)
        assert passed is ok, curve
        assert env["outside_mm"] == pytest.approx(0.0 if ok else 0.01, abs=1e-9)
    assert validate.inside_envelope(np.r_[5.0, 5, -3.01, 5, 5], refs)[1]["index"] == 2


def test_rmse_target_at_its_bound():
    far, near = np.full(4, 40.0), np.array([0.0, 1.0, 2.0, 3.0])
    refs = {"far": far, "near": near}
    for offset, ok in ((4.99, True), (5.01, False), (-4.99, True)):
        passed, name, err = validate.near_one(near + offset, refs)
        assert (passed, name) == (ok, "near") and err == pytest.approx(abs(offset))
    assert validate.near_one(far + 1.0, refs)[:2] == (True, "far")  # any one reference is enough
    assert validate.rmse([0, 0, 0, 0], [3, 4, 3, 4]) == pytest.approx(np.sqrt(12.5))


class _ConstantLaw:
    """A one-muscle law with a constant torque: passive `p` at activation 0, `p + active` at 1."""
    muscles = ("x",)

    def __init__(self, passive, active=0.0):
        self.passive, self.active = passive, active

    def torque(self, angle, velocity, activation):
        return self.passive + self.active * np.asarray(activation) + 0.0 * np.asarray(angle)[:, None]


def test_rest_angle_reach_and_passive_on_a_known_law():
    p = 1.0
    assert validate.relaxed_rest_angle(_ConstantLaw(p)) == pytest.approx(np.degrees(np.arcsin(p / MGC)), abs=0.01)
    assert validate.relaxed_rest_angle(_ConstantLaw(0.0)) == 0.0
    assert validate.relaxed_rest_angle(_ConstantLaw(-p)) == pytest.approx(anatomy.JOINT_RANGE_DEG[0])  # the limit
    reach = validate.static_reach(_ConstantLaw(0.0, active=p))  # held up to asin(p / MGC); again above 180 - that
    assert np.degrees(np.arcsin(p / MGC)) - 0.1 <= reach <= np.degrees(np.arcsin(p / MGC))
    assert validate.static_reach(_ConstantLaw(0.0, active=2 * MGC)) == pytest.approx(159.9)
    assert validate.static_reach(_ConstantLaw(-1.0)) is None
    np.testing.assert_allclose(validate.passive_torque(_ConstantLaw(0.3, active=5), [0, 10, 20]), 0.3)


def test_not_modelled_conditions_give_no_curve():
    view = validate.inspect_model()
    arms = {"ssp": np.ones(3)}
    assert validate.model_curve(view, arms, "ssp", "shoulder_elv", view.task_plane, view.girdle) == (arms["ssp"], "")
    missing = [c for c in references.COORDINATES if c not in view.coordinates]
    for coord in missing:
        assert validate.model_curve(view, arms, "ssp", coord, view.task_plane, view.girdle) == (None, view.missing)


def _run(argv, capsys):
    rc = cli.main(argv)
    return rc, capsys.readouterr()


def test_command_end_to_end(tmp_path, capsys):
    rc, out = _run(["model", "validate", "--json", "--out", str(tmp_path / "figs")], capsys)
    report = json.loads(out.out)
    for key in ("model", "follows", "envelope_excluded", "moment_arms", "relaxed_rest_deg", "passive_torque_Nm",
                "peak_isometric_torque", "capacity_ratio_ssp_dmi", "ssp_static_reach_deg", "targets", "passed",
                "figures"):
        assert key in report, key
    rows = report["moment_arms"]["rmse"]
    assert len(rows) == len(anatomy.MUSCLES) * 3 * 2 * 2  # muscle x DOF x plane x girdle
    assert {r["muscle"] for r in rows} == set(anatomy.MUSCLES)
    targets = report["targets"]
    ids = {t["id"] for t in targets}
    for m in anatomy.MUSCLES:
        assert {f"envelope/{m}", f"rmse/{m}", f"peak_torque/{m}"} <= ids
    assert {"rest_angle", "passive_torque", "early/ssp_above_dmi", "sign/isp/shoulder_rot", "sign/ld/elv_angle"} <= ids
    for t in targets:  # a condition the model cannot pose never passes
        if "not modelled" in t["note"]:
            assert not t["passed"], t
    failed = [t for t in targets if not t["passed"]]
    assert report["passed"] is (not failed)
    assert rc == (1 if failed else 0)
    figures = sorted((tmp_path / "figs").iterdir())
    assert [f.name for f in figures] == sorted(f"validate_{m}.png" for m in anatomy.MUSCLES)
    assert report["figures"] == [str(tmp_path / "figs" / f"validate_{m}.png") for m in anatomy.MUSCLES]
    for f in figures:
        assert f.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and f.stat().st_size > 10_000

    rc_text, out = _run(["model", "validate", "--out", str(tmp_path / "figs")], capsys)
    assert rc_text == rc
    lines = out.out.splitlines()
    assert sum(x.startswith("[FAIL]") for x in lines) == len(failed)
    assert sum(x.startswith("[pass]") for x in lines) == len(targets) - len(failed)
    assert "Moment-arm RMSE" in out.out and "relaxed rest angle" in out.out


def test_command_rejects_a_file_as_out_before_any_work(tmp_path, capsys):
    f = tmp_path / "taken"
    f.write_text("x")
    rc, out = _run(["model", "validate", "--out", str(f)], capsys)
    assert rc == 2 and "--out" in out.err and "existing file" in out.err
    assert f.read_text() == "x"
