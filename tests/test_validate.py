"""`shoulder-bench model validate`: the reference tables, the model's moment arms, the target logic, the command."""
import json

import numpy as np
import pytest

from shoulder_bench import cli, statics
from shoulder_bench.authoring import anatomy, references, validate, validate_v2
from shoulder_bench.model import tendon_geometry

V1_PATH = validate.MODEL_PATH  # models/shoulder.xml, model v1 (kept for comparison)
V2_PATH = validate.MODEL_PATH.parent / "shoulder_v2.xml"  # the tasks' geometry, the default --model
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


def test_the_default_model_is_v2_the_tasks_geometry():
    from shoulder_bench import arm

    assert validate.DEFAULT_MODEL == V2_PATH and V2_PATH.is_file()
    assert validate.inspect_model().version == "2" and validate.inspect_model(V1_PATH).version == "1"
    # the tasks' model is v2's locked variant, generated from the same source as the validated file
    assert arm.MODEL_FILE.name == "shoulder_v2_task.xml" and arm.MODEL_VERSION == "2"
    assert arm.TASK_PLANE_DEG == validate.TASK_PLANE_V2


def test_not_modelled_conditions_give_no_curve():
    view = validate.inspect_model(V1_PATH)
    arms = {"ssp": np.ones(3)}
    assert validate.model_curve(view, arms, "ssp", "shoulder_elv", view.task_plane, view.girdle) == (arms["ssp"], "")
    missing = [c for c in references.COORDINATES if c not in view.coordinates]
    for coord in missing:
        assert validate.model_curve(view, arms, "ssp", coord, view.task_plane, view.girdle) == (None, view.missing)


def test_start_of_abduction_targets_are_judged_girdle_fixed_and_show_coupled():
    # synthetic 1-deg curves: the fixed girdle meets all four targets, the coupled one misses all four
    x = validate.FINE
    fixed = {"ssp": np.full_like(x, 20.0), "dmi": 30.0 - 0.0025 * (x - 80.0) ** 2}  # 14 mm at 0, peak 30 at 80 deg
    coupled = {"ssp": np.full_like(x, 5.0), "dmi": 10.0 + 0.15 * x}  # 10 mm at 0 (above ssp), peak 28 mm at 120 deg
    curves = {"fixed": fixed, "coupled": coupled}
    rows = validate.early_targets(lambda m, g: (curves[g][m], f"note {g}"), "missing", "coronal")
    assert [t["id"] for t in rows] == list(validate.EARLY_IDS)
    assert validate.EARLY_GIRDLE == "fixed"
    for t in rows:
        assert t["passed"] and t["girdle"] == "fixed" and "girdle fixed" in t["target"], t
        assert t["note"] == "note fixed" and t["coupled"]["note"] == "note coupled"
    by_id = {t["id"]: t for t in rows}
    assert by_id["early/dmi_at_side"]["measured"] == "14.0 mm"
    assert by_id["early/dmi_at_side"]["coupled"]["measured"] == "10.0 mm"
    assert by_id["early/dmi_peak_angle"]["measured"] == "peak at 80 deg"
    assert by_id["early/dmi_peak_angle"]["coupled"]["measured"] == "peak at 120 deg"
    assert by_id["early/dmi_peak"]["coupled"]["measured"] == "28.0 mm"
    assert by_id["early/ssp_above_dmi"]["coupled"]["measured"].startswith("ssp - dmi -")
    # what the model cannot pose fails, with the reason
    rows = validate.early_targets(lambda m, g: (None, "missing"), "missing", "coronal")
    assert not any(t["passed"] for t in rows) and all(t["note"] == "missing" for t in rows)


def _run(argv, capsys):
    rc = cli.main(argv)
    return rc, capsys.readouterr()


def test_command_end_to_end(tmp_path, capsys, monkeypatch):
    # model v1, kept for comparison: --model models/shoulder.xml
    rc, out = _run(["model", "validate", "--model", str(V1_PATH), "--json", "--out", str(tmp_path / "figs")], capsys)
    report = json.loads(out.out)
    assert report["model"]["version"] == "1" and report["model"]["path"] == "models/shoulder.xml"
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
    early = [t for t in targets if t["id"].startswith("early/")]
    assert [t["id"] for t in early] == list(validate.EARLY_IDS)
    for t in early:  # v1's hinge is a fixed girdle: judged in its own condition; the coupled value is the same curve
        assert t["girdle"] == "fixed" and t["note"] == "" and "girdle fixed" in t["target"], t
        assert t["coupled"] == {"measured": t["measured"], "note": "model girdle fixed"}, t
    dmi = np.array(report["moment_arms"]["model_mm"]["dmi"])
    assert early[1]["measured"] == f"{dmi[0]:.1f} mm"
    failed = [t for t in targets if not t["passed"]]
    assert report["passed"] is (not failed)
    assert rc == (1 if failed else 0)
    figures = sorted((tmp_path / "figs").iterdir())
    assert [f.name for f in figures] == sorted(f"validate_{m}.png" for m in anatomy.MUSCLES)
    assert report["figures"] == [str(tmp_path / "figs" / f"validate_{m}.png") for m in anatomy.MUSCLES]
    for f in figures:
        assert f.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and f.stat().st_size > 10_000

    monkeypatch.chdir(tmp_path)  # the default --out: runs/validation under the current folder, not the folder itself
    rc_text, out = _run(["model", "validate", "--model", str(V1_PATH)], capsys)
    assert rc_text == rc
    assert sorted(f.name for f in (tmp_path / "runs" / "validation").iterdir()) == [f.name for f in figures]
    assert not list(tmp_path.glob("*.png"))
    lines = out.out.splitlines()
    assert sum(x.startswith("[FAIL]") for x in lines) == len(failed)
    assert sum(x.startswith("[pass]") for x in lines) == len(targets) - len(failed)
    assert "Moment-arm RMSE" in out.out and "relaxed rest angle" in out.out
    assert sum(x.startswith("       girdle coupled (shown, no target): ") for x in lines) == 4


def test_command_rejects_a_file_as_out_before_any_work(tmp_path, capsys):
    f = tmp_path / "taken"
    f.write_text("x")
    rc, out = _run(["model", "validate", "--out", str(f)], capsys)
    assert rc == 2 and "--out" in out.err and "existing file" in out.err
    assert f.read_text() == "x"


# --- model v2 (the default, models/shoulder_v2.xml: the geometry of the tasks' locked variant) -------------------


@pytest.fixture(scope="module")
def v2_report():
    return validate.evaluate(path=V2_PATH)


def test_v2_moment_arms_are_kinematics_moment_arms(v2_report):
    import mujoco

    from shoulder_bench.authoring.kinematics import moment_arms

    model = mujoco.MjModel.from_xml_path(str(V2_PATH))
    ma = v2_report["moment_arms"]
    for coord, plane, elv, girdle in (("shoulder_elv", 30, 60, "coupled"), ("shoulder_rot", 0, 90, "fixed"),
                                      ("elv_angle", 30, 120, "coupled")):
        want = moment_arms(model, ["ssp", "isp", "dmi", "ld1", "ld2", "ld3"], [(plane, elv, 0)], girdle)[coord][0]
        got = {m: ma["model_mm"][f"{m}/{coord}/{plane}/{girdle}"][ma["elevation_deg"].index(elv)]
               for m in anatomy.MUSCLES}
        for i, m in enumerate(("ssp", "isp", "dmi")):
            assert got[m] == pytest.approx(want[i], abs=6e-4), (m, coord, plane, elv, girdle)
        f0 = np.array([290.5, 317.5, 189.0])  # the parent's LAT1-3 (mobl_arms_parent_muscles.csv)
        assert got["ld"] == pytest.approx(f0 @ want[3:] / f0.sum(), abs=6e-4)
    # the 1-deg curves the early targets and the figures use, off the references' grid
    want = moment_arms(model, ["dmi"], [(0, 37, 0)], "coupled")["shoulder_elv"][0, 0]
    assert ma["model_fine_mm"]["dmi/shoulder_elv/0/coupled"][37] == pytest.approx(want, abs=6e-4)
    # v2 is MyoArm's geometry: the MyoArm RMSE of a single-bundle muscle is 0 to the tables' rounding
    row = next(r for r in ma["rmse"] if (r["muscle"], r["coordinate"], r["plane_deg"], r["girdle"]) ==
               ("isp", "shoulder_rot", 30, "coupled"))
    assert row["rmse_mm"]["myoarm"] < 1e-3 and row["envelope"]["inside"]
    assert set(row["envelope_without_myoarm"]["references"]) == {"mobl_opensim"}


def test_v2_force_targets_are_the_static_estimate_per_plane(v2_report):
    from shoulder_bench.authoring import statics_v2

    by_id = {t["id"]: t for t in v2_report["targets"]}
    force = ["rest_angle", "passive_torque"] + [f"peak_torque/{m}" for m in anatomy.MUSCLES]
    refs = references.load()
    for p in (0, 30):
        s = statics_v2.summary(statics_v2.analyse(p), refs)
        rows = validate.force_targets(s["relaxed_rest_deg"], s["passive_angle_deg"], s["passive_torque_Nm"],
                    s["peak_isometric_torque"], "c")
        for tid, row in zip(force, rows):
            got = by_id[tid]["planes"][str(p)]
            assert (got["passed"], got["measured"]) == (row["passed"], row["measured"]), (tid, p)
            assert "not yet" not in got["measured"]
        assert v2_report["statics"]["planes"][str(p)]["relaxed_rest_deg"] == s["relaxed_rest_deg"]
    chosen = str(validate.TASK_PLANE_V2)
    for tid in force:  # the tasks' plane decides; both planes shown, the method named
        t = by_id[tid]
        assert (t["passed"], t["measured"]) == (t["planes"][chosen]["passed"], t["planes"][chosen]["measured"])
        assert set(t["planes"]) == {"0", "30"} and t["note"] == validate_v2.FORCE_NOTE
        assert "static rigid-tendon Hill estimate" in t["note"]
    for key in validate_v2.FORCE_QUANTITIES:  # the top-level quantities are the tasks' plane's
        assert v2_report[key] == v2_report["statics"]["planes"][chosen][key], key


def test_v2_shows_the_tasks_fem_tables_beside_the_force_targets(v2_report):
    from shoulder_bench.arm import arm
    from shoulder_bench.muscle import MuscleTable

    tab = v2_report["tables"]
    assert tab["label"] == "FEM tables (the tasks' muscles)" and tab["muscle_model"] == "fem"
    assert tab["model"] == "models/shoulder_v2_task.xml" and tab["plane_deg"] == validate.TASK_PLANE_V2 == 0
    by_id = {t["id"]: t for t in v2_report["targets"]}
    for tid in validate_v2.FORCE_IDS:  # beside every force target, never deciding it
        t = by_id[tid]
        assert t["tables"] == {"label": tab["label"], **tab["targets"][tid]}
        assert t["passed"] == t["planes"][str(validate.TASK_PLANE_V2)]["passed"]
    assert by_id["rest_angle"]["tables"]["measured"] == f"{tab['relaxed_rest_deg']:.1f} deg"
    # the peaks against the shipped tables themselves (5-deg grid, the tables' own torque; ld = ld1 + ld2 + ld3)
    folder = validate.MODEL_PATH.parent / "muscles_v2"
    for m, tendons in (("ssp", ["ssp"]), ("isp", ["isp"]), ("dmi", ["dmi"]), ("ld", ["ld1", "ld2", "ld3"])):
        tables = [MuscleTable.load(folder / f"{t}_fem.npz") for t in tendons]
        ang = np.asarray(tables[0].angle_deg)
        sel = (ang >= 0) & (ang <= 120)
        iso = sum(np.asarray(tb.torque_Nm)[:, -1] - np.asarray(tb.torque_Nm)[:, 0] for tb in tables)[sel]
        peak = tab["peak_isometric_torque"][m]
        k = int(np.argmax(np.abs(iso)))
        assert abs(peak["peak_Nm"]) >= abs(iso[k]) - 1e-6, m  # the 1-deg search finds at least the grid's peak
        assert peak["peak_Nm"] == pytest.approx(iso[k], rel=0.05), m
        assert abs(peak["at_deg"] - ang[sel][k]) <= 5.0, m
    # the rest angle: net torque (passive + the tasks' arm's gravity) crosses zero there, pushing up below it
    law, g = arm().load_law("fem"), statics.gravity_torque
    rest = tab["relaxed_rest_deg"]
    below, above = np.radians([rest - 0.5]), np.radians([rest + 0.5])
    assert validate.passive_torque(law, np.degrees(below))[0] + g(below)[0] > 0
    assert validate.passive_torque(law, np.degrees(above))[0] + g(above)[0] < 0
    assert tab["passive_torque_Nm"][0] == pytest.approx(validate.passive_torque(law, [0.0])[0], abs=1e-4)
    # ssp's static reach: ssp alone holds every angle from 0 up to it, not 0.2 deg above it
    ssp = arm().load_law("fem", ("ssp",))
    reach = tab["ssp_static_reach_deg"]
    upto = np.radians(np.arange(0.0, reach + 1e-9, 0.1))
    assert (statics.static_capacity(ssp, upto) >= -g(upto)).all()
    over = np.radians([reach + 0.1, reach + 0.2])
    assert not (statics.static_capacity(ssp, over) >= -g(over)).all()


def test_v2_targets_are_decided_in_the_tasks_plane_and_shown_in_both(v2_report):
    assert validate.TASK_PLANE_V2 in (0, 30) and v2_report["model"]["task_plane_deg"] == validate.TASK_PLANE_V2
    chosen = str(validate.TASK_PLANE_V2)
    planned = [t for t in v2_report["targets"] if "planes" in t]
    assert len(planned) == 22  # 8 envelope/RMSE, 4 early abduction, 6 force, 4 signs
    for t in planned:
        assert set(t["planes"]) == {"0", "30"} and t["passed"] == t["planes"][chosen]["passed"]
    by_id = {t["id"]: t for t in v2_report["targets"]}
    assert by_id["sign/isp/shoulder_rot"]["planes"]["0"]["measured"].startswith("mean -")  # external rotator
    assert by_id["sign/ld/shoulder_rot"]["planes"]["30"]["measured"].startswith("mean +")  # internal rotator
    # once a plane is chosen, that plane's result decides
    rows = {0: [validate.target("x", "t", True, "a", "b")], 30: [validate.target("x", "t", False, "c", "b")]}
    for tp, ok, measured in ((0, True, "a"), (30, False, "c"), (None, False, validate.NO_TASK_PLANE)):
        (t,) = validate_v2.combine(rows, tp)
        assert (t["passed"], t["measured"], t["planes"]["0"]["passed"]) == (ok, measured, True)


def test_v2_start_of_abduction_is_judged_girdle_fixed_with_coupled_shown(v2_report):
    fine = v2_report["moment_arms"]["model_fine_mm"]
    x = np.asarray(v2_report["moment_arms"]["fine_elevation_deg"])
    by_id = {t["id"]: t for t in v2_report["targets"]}
    chosen = str(validate.TASK_PLANE_V2)
    for p in ("0", "30"):
        dmi = {g: np.asarray(fine[f"dmi/shoulder_elv/{p}/{g}"]) for g in ("fixed", "coupled")}
        side, angle, peak = by_id["early/dmi_at_side"], by_id["early/dmi_peak_angle"], by_id["early/dmi_peak"]
        for t, want in ((side, lambda d: f"{d[0]:.1f} mm"), (angle, lambda d: f"peak at {x[np.argmax(d)]:g} deg"),
                        (peak, lambda d: f"{d.max():.1f} mm")):
            assert t["planes"][p]["measured"] == want(dmi["fixed"]), (t["id"], p)
            assert t["planes"][p]["coupled"]["measured"] == want(dmi["coupled"]), (t["id"], p)
    for tid in validate.EARLY_IDS:
        t = by_id[tid]
        assert t["girdle"] == "fixed" and "girdle fixed" in t["target"]
        assert t["coupled"] == t["planes"][chosen]["coupled"]
        assert t["passed"] == t["planes"][chosen]["passed"]
    # the dmi numbers hold with the girdle fixed (30.3 mm at 82 deg coronal), not coupled (24.1 at 110)
    assert by_id["early/dmi_peak"]["planes"]["0"]["measured"] == "30.3 mm"
    assert by_id["early/dmi_peak"]["planes"]["0"]["coupled"]["measured"] == "24.1 mm"
    assert by_id["early/dmi_peak_angle"]["planes"]["0"]["coupled"]["measured"] == "peak at 110 deg"


def test_v2_command_end_to_end(tmp_path, capsys, v2_report):
    rc, out = _run(["model", "validate", "--json", "--out", str(tmp_path)], capsys)  # the default --model: v2
    report = json.loads(out.out)
    assert rc == 1 and report["passed"] is False and report["model"]["version"] == "2"
    assert report["model"]["path"] == "models/shoulder_v2.xml"
    assert [t["id"] for t in report["targets"]] == [t["id"] for t in v2_report["targets"]]
    v1_ids = [t["id"] for t in validate.evaluate(path=V1_PATH)["targets"]]
    assert [t["id"] for t in report["targets"]] == v1_ids  # the same targets as v1
    rows = report["moment_arms"]["rmse"]
    assert len(rows) == len(anatomy.MUSCLES) * 3 * 2 * 2 and all(r["rmse_mm"]["mobl_arms"] is not None for r in rows)
    assert {(r["coordinate"], r["plane_deg"], r["girdle"]) for r in rows} == {
        (c, p, g) for c in references.COORDINATES for p in (0, 30) for g in references.GIRDLES}
    assert all({"outside_mm", "inside", "at_deg"} <= set(r["envelope"]) for r in rows)
    names = sorted(f.name for f in tmp_path.iterdir())
    assert names == sorted(f"validate_v2_{m}.png" for m in anatomy.MUSCLES)
    assert all((tmp_path / n).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" for n in names)

    rc, out = _run(["model", "validate", "--model", str(V2_PATH), "--out", str(tmp_path)], capsys)
    lines = out.out.splitlines()
    failed = sum(not t["passed"] for t in report["targets"])
    assert rc == (1 if failed else 0) and sum(x.startswith("[FAIL]") for x in lines) == failed
    assert "close to tautologies" in out.out and "tasks' plane not chosen yet" not in out.out
    assert "not used by the tasks" not in out.out and "models/shoulder_v2_task.xml" in out.out
    fem = [x for x in lines if x.startswith("       FEM tables (the tasks' muscles), shown, no target: ")]
    assert len(fem) == len(validate_v2.FORCE_IDS)
    assert "Quantities, FEM tables (the tasks' muscles)" in out.out
    per_plane = [sum(x.startswith(f"       {n} ({p} deg) ") for x in lines) for n, p in references.PLANES.items()]
    assert per_plane == [22, 22]  # each target in the tasks' plane, shown in both candidates
    assert "not yet" not in out.out
    assert any(x.startswith("relaxed rest angle (activations 0): coronal (0 deg) ") for x in lines)
    coupled = [x for x in lines if "; girdle coupled (shown, no target): " in x]
    assert len(coupled) == 2 * len(validate.EARLY_IDS)  # beside each start-of-abduction target, in both planes


def test_command_refuses_an_unknown_or_missing_model(tmp_path, capsys):
    other = tmp_path / "other.xml"
    other.write_text('<mujoco><worldbody><body><joint name="j"/><geom size=".1"/></body></worldbody></mujoco>')
    rc, out = _run(["model", "validate", "--model", str(other), "--out", str(tmp_path / "o")], capsys)
    assert rc == 2 and "validate knows the v1 model" in out.err and "['j']" in out.err
    rc, out = _run(["model", "validate", "--model", str(tmp_path / "none.xml"), "--out", str(tmp_path)], capsys)
    assert rc == 2 and "no such file" in out.err
    assert not (tmp_path / "o").exists()
