"""Footprint sheets of the full shoulder (issue 12 §2, first step): the sheet's geometry follows the model's bones, its
reduction gives back the MJCF moment arms when the sheet is a line, and with the real footprint the solved line of
action is its own (shoulder_bench/authoring/fem/footprint.py, docs/fem.md "Footprint sheets")."""
import json

import numpy as np
import pytest

from shoulder_bench.authoring.fem import footprint as F
from shoulder_bench.authoring.fem.footprint_compare import compare
from shoulder_bench.cli.fem import main as fem_main

POSES = [(30.0, 45.0, 0.0), (0.0, 10.0, 0.0), (60.0, 100.0, 30.0), (90.0, 130.0, -40.0)]


@pytest.fixture(scope="module")
def pose():
    from shoulder_bench import full_arm

    return full_arm.Pose()


@pytest.mark.parametrize("tendon", [t for t in F.TENDONS if t not in ("dmi", "dpo")] + ["cor"])  # dmi, dpo: inside
def test_the_sheets_fibres_start_on_mujocos_wrapped_path(tendon, pose):
    """The central fibre's initial shape (sphere: tangent-arc-tangent, cylinder: a helix, on the side site's side,
    straight where an end is inside the object), with the straight segments beyond it over a second proximal bone
    (dan, ld1-3), differs from the MJCF tendon's length by a constant (the path's fixed parts on the bones) at the
    report's 72 poses (the pose space's ends and middle) and 20 random ones."""
    from shoulder_bench.authoring.fem.footprint_report import report_poses

    sheet = F.FootprintSheet(tendon, "coarse", width_m=0.01, pose=pose, mjcf_insertion=True)
    rng = np.random.default_rng(0)
    poses = np.r_[report_poses(), np.c_[rng.uniform(0, 90, 20), rng.uniform(0, 140, 20), rng.uniform(-45, 60, 20)]]
    fixed = []
    for p in poses:
        sheet._set(p)
        fixed.append(pose.tendon_geometry(p, (tendon,))[0][0, 0] - sheet.central_length() - sheet.beyond_length())
    assert np.ptp(fixed) < 1e-9 and min(fixed) >= 0.0
    assert (sheet.beyond_length() > 0.01) == (tendon in ("dan", "ld1", "ld2", "ld3"))
    sheet._set(poses[-1])
    centre = sheet.draped().reshape(sheet.ns, sheet.nt, 3)[:, sheet.nt // 2]  # its 15-node polyline
    assert np.linalg.norm(np.diff(centre, axis=0), axis=1).sum() == pytest.approx(sheet.central_length(), abs=3e-4)


@pytest.mark.parametrize("tendon", ["ssp", "isp", "ssc", "dan", "ld2"])
def test_a_narrow_sheet_gives_back_the_mjcf_moment_arms(tendon, pose):
    """A 1 mm sheet is nearly MuJoCo's line: its solved generalised force over its tension (origin, insertion and
    contact forces, and for dan and ld2 the pull of their path beyond it over a second proximal bone, through the
    bodies' Jacobians and the coupling slopes) must equal -ten_J S to within 1 mm, in poses with and without contact
    on the wrap sphere."""
    sheet = F.FootprintSheet(tendon, "coarse", width_m=0.001, pose=pose, mjcf_insertion=True)
    contacts = []
    for p in POSES[1:3]:
        s = sheet.solve(p)
        contacts.append(s["contact_N"])
        np.testing.assert_allclose(s["moment_arm_m"], sheet.mjcf_moment_arm(p), atol=1e-3)
        assert s["tension_N"] > 0.3 * sheet.f0  # active at a = 1: the sheet pulls
    if tendon == "ssp":
        assert contacts[0] > 10.0 and contacts[1] == 0.0  # both cases were exercised
    if tendon == "isp":  # the cylinder
        s = sheet.solve((90.0, 0.0, 60.0))
        assert s["contact_N"] > 100.0
        np.testing.assert_allclose(s["moment_arm_m"], sheet.mjcf_moment_arm((90.0, 0.0, 60.0)), atol=1e-3)


def test_with_its_footprint_the_sheets_line_of_action_is_its_own(pose):
    """Infraspinatus at plane 90, elevation 100, external rotation 45 (fibres at stretch 0.61, taut): the 1 mm sheet
    clears its cylinder and gives back the MJCF moment arms; the 29 mm sheet (Curtis 2006) touches the cylinder
    with its lateral fibres and its solved moment arms differ from the MJCF line's by more than 3 mm: the line of
    action is an output of the solve, not the MJCF path's."""
    p = (90.0, 100.0, -45.0)
    narrow = F.FootprintSheet("isp", "coarse", width_m=0.001, pose=pose).solve(p)
    sheet = F.FootprintSheet("isp", "coarse", pose=pose)
    wide = sheet.solve(p)
    mjcf = sheet.mjcf_moment_arm(p)
    assert narrow["contact_N"] == 0.0 and wide["contact_N"] > 50.0
    np.testing.assert_allclose(narrow["moment_arm_m"], mjcf, atol=1e-3)
    assert np.max(np.abs(wide["moment_arm_m"] - mjcf)) > 3e-3


def test_paths_it_cannot_drape_and_tendons_without_a_footprint_are_refused(pose):
    assert F.free_part(pose.m, "dmi").inside and not F.free_part(pose.m, "ssp").inside
    with pytest.raises(ValueError, match="side site lies inside the object"):  # inside wrapping: the head only
        F.FootprintSheet("dmi", pose=pose)
    with pytest.raises(ValueError, match="no footprint for 'cor'"):
        F.FootprintSheet("cor", pose=pose)
    with pytest.raises(SystemExit, match="no footprint sheet for cor"):
        fem_main(["footprint", "--tendon", "cor"])


def test_a_path_beyond_the_free_part_is_followed_where_straight_and_refused_where_it_wraps(pose):
    """dan runs on from the acromion (scapula) to the clavicle: those two sites are `beyond`; ssp's path stays on the
    scapula (none). A path that wraps an object on a second proximal bone is refused (no tendon of the model does)."""
    import mujoco

    m = pose.m
    dan = F.free_part(m, "dan")
    assert [m.body(m.site_bodyid[s]).name for s in dan.beyond] == ["scapula", "clavicle"]
    assert dan.beyond[0] == dan.origin_site and F.free_part(m, "ssp").beyond == ()
    xml = """<mujoco><worldbody><body name="a"><site name="pa"/><body name="b" pos="0 0.1 0"><joint type="hinge"/>
      <geom name="w" type="sphere" size="0.01" pos="0 0.05 0"/><site name="pb" pos="0 0.1 0"/></body>
      <body name="humerus" pos="0.1 0 0"><joint type="hinge"/><geom size="0.01"/><site name="ph"/></body></body>
      </worldbody><tendon><spatial name="t"><site site="ph"/><site site="pa"/><geom geom="w"/><site site="pb"/>
      </spatial></tendon></mujoco>"""
    with pytest.raises(ValueError, match="second proximal bone after its first and wraps an object there"):
        F.free_part(mujoco.MjModel.from_xml_string(xml), "t")


def test_the_report_refuses_a_file_as_its_folder(tmp_path):
    afile = tmp_path / "x.json"
    afile.write_text("{}")
    with pytest.raises(SystemExit, match="is a file, not a folder"):
        fem_main(["footprint", "--out", str(afile)])
    assert afile.read_text() == "{}"


def test_the_report_summarises_converged_poses_and_the_taut_ones_apart():
    from shoulder_bench.authoring.fem.footprint_report import summary

    res = {"tendon": "x", "width_m": 0.02, "converged": np.array([True, True, False]),
           "fem_m": np.array([[0.011, 0.0, 0.0], [0.0, 0.0, 0.0], [np.nan] * 3]),
           "mjcf_m": np.array([[0.010, 0.0, 0.002], [0.004, 0.0, 0.0], [0.0] * 3]),
           "contact_N": np.array([5.0, 1.0, np.nan]), "stretch": np.array([1.0, 0.5, 1.0])}
    s = summary(res)
    assert (s["converged"], s["active_poses"], s["poses"]) == (2, 1, 3)
    assert s["active"]["plane"]["max_diff_mm"] == pytest.approx(1.0)
    assert s["active"]["rotation"]["rms_diff_mm"] == pytest.approx(2.0)
    assert s["all"]["plane"]["max_diff_mm"] == pytest.approx(4.0)  # the slack pose (stretch 0.5) counts in "all"


def test_on_the_humeral_head_a_narrow_sheet_pulls_along_its_geodesic(pose):
    """With contact on the humeral head sphere (fitted to the parent's humerus), a 1 mm sheet's solved moment arms
    equal -dL/dq of its central fibre's geodesic over the head (finite differences through the couplings), the
    definition MuJoCo's tendon Jacobian follows: the reduction holds for a surface the MJCF does not have."""
    sheet = F.FootprintSheet("ssp", "coarse", width_m=0.001, pose=pose, surface="head")
    p = np.array([0.0, 10.0, 0.0])
    s = sheet.solve(p)
    assert s["contact_N"] > 10.0
    h = 0.05
    fd = []
    for k in range(3):
        e = np.zeros(3)
        e[k] = h
        sheet._set(p + e)
        up = sheet.central_length()
        sheet._set(p - e)
        fd.append(-(up - sheet.central_length()) / np.radians(2 * h))
    np.testing.assert_allclose(s["moment_arm_m"], fd, atol=1e-3)


def test_the_flat_drape_keeps_a_band_on_the_head_together(pose):
    """The posterior deltoid flexed and internally rotated, on the humeral head: with each fibre over its own great
    circle the drape is torn (the equilibrium lies millimetres from the stress-free drape, the sheet pulls above F0);
    draped flat (FLAT_DRAPE) it lies within a millimetre of it and pulls F0, with the same line of action."""
    p = (90.0, 100.0, 60.0)
    flat = F.FootprintSheet("dpo", "coarse", surface="head", rest="pose", pose=pose)
    assert flat.flat  # dpo is in FLAT_DRAPE
    s_flat = flat.solve(p)
    circles = F.FootprintSheet("dpo", "coarse", surface="head", rest="pose", pose=pose, flat=False)
    s_circles = circles.solve(p)
    moved = {k: np.abs(s["nodes"] - sheet.problem.X).max() for k, s, sheet in
             (("flat", s_flat, flat), ("circles", s_circles, circles))}
    assert s_flat["contact_N"] > 10.0 and moved["flat"] < 1e-3 and moved["circles"] > 3e-3
    assert abs(s_flat["tension_N"] / flat.f0 - 1.0) < 0.02 < s_circles["tension_N"] / circles.f0 - 1.0
    np.testing.assert_allclose(s_flat["moment_arm_m"], s_circles["moment_arm_m"], atol=2e-4)


def test_the_head_is_a_sphere_about_the_joint_centre_and_the_cuff_insertions_inside_it_are_refused(pose):
    centre, radius = np.asarray(F.HUMERAL_HEAD["centre_m"]), F.HUMERAL_HEAD["radius_m"]
    assert np.linalg.norm(centre) < 3e-3 and 0.019 <= radius <= 0.028  # Iannotti 1992: 24 mm (19-28)
    for tendon, kw in (("ssc", {"mjcf_insertion": True}), ("tmi", {})):
        with pytest.raises(ValueError, match="insertion site lies inside the humeral head sphere"):
            F.FootprintSheet(tendon, "coarse", pose=pose, surface="head", **kw)
    with pytest.raises(ValueError, match="unknown contact surface"):
        F.FootprintSheet("ssp", pose=pose, surface="glenoid")


def test_the_subscapularis_inserts_on_the_lesser_tuberosity_not_on_the_articular_cap(pose):
    """ssc's insertion line is centred on INSERTION_M (the parent's lesser tuberosity), outside the head sphere, and
    carried by the humerus: at two poses it lies where the humerus takes that point, not at the MJCF site (2 mm inside
    the sphere); on the head its band solves, internal rotation where the parent's path has almost none."""
    centre, radius = np.asarray(F.HUMERAL_HEAD["centre_m"]), F.HUMERAL_HEAD["radius_m"]
    q = np.asarray(F.INSERTION_M["ssc"])
    assert 0.0 < np.linalg.norm(q - centre) - radius < 0.003
    sheet = F.FootprintSheet("ssc", "coarse", pose=pose, surface="head", rest="pose")
    site = sheet.part.insertion_site
    for p in POSES[:2]:
        sheet._set(p)
        b = sheet.bodies["insertion"]
        expected = sheet.d.xpos[b] + sheet.d.xmat[b].reshape(3, 3) @ q
        np.testing.assert_allclose(sheet._ends()[1], expected, atol=1e-12)
        assert np.linalg.norm(sheet._ends()[1] - sheet.d.site_xpos[site]) > 0.015
    s = sheet.solve((0.0, 0.0, 60.0))
    assert s["moment_arm_m"][2] > 0.015 > 0.005 > abs(sheet.mjcf_moment_arm((0.0, 0.0, 60.0))[2])


def test_a_report_with_every_tendon_skipped_says_why_and_writes_nothing(tmp_path, capsys):
    from shoulder_bench.cli import main

    assert main(["fem", "footprint", "--rest", "pose", "--surface", "head", "--tendon", "tmi",
                 "--out", str(tmp_path)]) == 2
    assert "no sheet to solve: tmi: its insertion site lies inside the humeral head sphere" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_two_reports_compare_over_the_poses_both_solved(tmp_path):
    from shoulder_bench.authoring.fem.footprint_report import mesh_difference

    def report(path, rows):
        path.write_text(json.dumps({"resolution": "x", "poses": [
            {"tendon": t, "pose_deg": p, "fem_mm": f} for t, p, f in rows]}))
        return path

    a = report(tmp_path / "a.json", [("ssp", [0, 0, 0], [1.0, 2.0, 3.0]), ("ssp", [0, 10, 0], None),
                                     ("tma", [0, 0, 0], [0.0, 0.0, 0.0])])
    b = report(tmp_path / "b.json", [("ssp", [0, 0, 0], [1.5, 2.0, 1.0]), ("ssp", [0, 10, 0], [9.0, 9.0, 9.0])])
    out = mesh_difference(a, b)  # tma is not in b: left out, not an error
    assert out == {"ssp": {"poses": 1, "max_diff_mm": [0.5, 0.0, 2.0]}}


def _levels_result(torque, tension):
    from shoulder_bench.authoring.fem.footprint_activation import LEVELS

    assert torque.shape[1] == len(LEVELS)
    return {"tendon": "x", "poses_deg": np.zeros((len(torque), 3)), "levels": LEVELS, "torque_Nm": torque,
            "tension_N": tension, "f0_N": 100.0}


def test_the_activation_measures_are_zero_for_a_linear_fixed_line_of_action_and_see_a_departure():
    from shoulder_bench.authoring.fem.footprint_activation import LEVELS, measures

    rng = np.random.default_rng(0)
    arm = rng.uniform(-0.03, 0.03, (5, 1, 3))  # m, per pose: the same at every level
    tension = 10.0 + 200.0 * np.array(LEVELS)[None, :] * rng.uniform(0.5, 1.0, (5, 1))  # linear in a
    m = measures(_levels_result(arm * tension[..., None], tension))
    for a in ("0.25", "0.5"):
        assert m["arm_mm"][a]["taut_poses"] == 5
        assert max(v for k, v in m["arm_mm"][a].items() if k != "taut_poses") < 1e-9
        assert max(m["linearity_pct"][a].values()) < 1e-9
    bent = arm * tension[..., None]
    bent[2, LEVELS.index(0.5), 1] += 0.05 * np.abs(bent[..., 1]).max()  # 5 % of the peak, elevation, a = 0.5
    m = measures(_levels_result(bent, tension))
    assert m["linearity_pct"]["0.5"]["shoulder_elv"] == pytest.approx(5.0, rel=1e-6)
    assert m["arm_mm"]["0.5"]["shoulder_elv"] > 0.1 and m["linearity_pct"]["0.25"]["shoulder_elv"] < 1e-9


def test_solved_over_activations_the_full_activation_arms_are_the_reports(pose):
    """solve_levels at a = 1 is the report's solve (same sheet, same poses): the same moment arms."""
    from shoulder_bench.authoring.fem.footprint_activation import LEVELS, measures, solve_levels

    poses = np.array(POSES[:2])
    res = solve_levels("tmi", poses, "coarse", "wrap", pose)
    one = LEVELS.index(1.0)
    arms = res["torque_Nm"][:, one] / res["tension_N"][:, one, None]
    np.testing.assert_allclose(arms, compare("tmi", poses, "coarse", pose=pose)["fem_m"], atol=1e-9)
    m = measures(res)
    assert m["solved"] == 2 and all(np.isfinite(v) for v in m["linearity_pct"]["0.5"].values())


def test_the_grid_checks_cells_are_held_out_poses_with_their_grid_corners():
    from shoulder_bench import full_arm
    from shoulder_bench.authoring.fem.footprint_grid import cells

    centres, corners, index = cells(5)
    grid = {tuple(p) for p in full_arm.pose_grid()}
    assert all(tuple(p) in grid for p in corners)  # every corner is a pose of the tasks' grid
    np.testing.assert_allclose(corners[index].mean(axis=1), centres)  # the centre of its 8 corners
    step = np.array([full_arm.POSE_STEP_DEG[c] for c in full_arm.COORDINATES])
    assert (np.abs(corners[index] - centres[:, None]) == step / 2).all()
    # refined: each cell is a sub-cell of the same tasks' grid cell, on the grid 2 times finer
    fine_centres, fine_corners, fine_index = cells(5, refine=2)
    np.testing.assert_allclose(fine_corners[fine_index].mean(axis=1), fine_centres)
    assert (np.abs(fine_corners[fine_index] - fine_centres[:, None]) == step / 4).all()
    assert (np.abs(fine_centres - centres) == step / 4).all()  # inside its cell, a quarter step off its centre


def test_the_grid_check_scores_the_scheme_against_a_fresh_solve(pose, monkeypatch, tmp_path):
    """A torque field that is trilinear in the pose and linear in a is reproduced exactly by the scheme (0 %); one
    that is not is scored by how far it is off, in % of the peak."""
    from shoulder_bench.authoring.fem import footprint_grid

    def field(poses, a, bend):
        p = np.radians(poses)
        return (1.0 + a) * np.stack([p[:, 0] + 2 * p[:, 1], p[:, 1] - p[:, 2], 3 + p[:, 2]], 1) + bend * np.cos(
            4 * p) * a ** 2

    for bend, expect_zero in ((0.0, True), (0.5, False)):
        def fake(tendon, poses, resolution, surface, pose, progress=None, levels=(), bend=bend):
            ones = np.ones((len(poses), len(levels)))
            return {"torque_Nm": np.stack([field(poses, a, bend) for a in levels], axis=1), "tension_N": 50 * ones,
                    "contact_N": 0 * ones, "f0_N": 100.0}

        monkeypatch.setattr(footprint_grid, "solve_levels", fake)
        for refine in (1, 2):
            r = footprint_grid.check("tmi", 4, pose=pose, refine=refine)
            worst = max(r["scheme_a05"].values())
            assert r["checked"] == 4 and (worst < 1e-9) == expect_zero, worst
            assert [c["tension_a1_pct_f0"] for c in r["cell_records"]] == [50.0] * 4
            assert (max(r["arm_a05"].values()) < 1e-9) == expect_zero  # the tension is exact and constant here
    assert r["within_tol"] is (worst <= 2.0)
    # `run` writes the scores (JSON) and the solves they came from (npz), for other schemes to be scored on
    footprint_grid.run(("tmi",), out=tmp_path, n=4, refine=2)
    text = json.loads((tmp_path / "footprint_grid_refine2.json").read_text())
    assert text["refine"] == 2 and "solves" not in text["tendons"][0]
    solves = np.load(tmp_path / "footprint_grid_refine2.npz")
    assert solves["tmi/centre_torque_Nm"].shape == (4, 3, 3) and solves["tmi/corner_index"].shape == (4, 8)


def test_the_line_of_action_score_leaves_out_the_force():
    """A sheet whose tension bends across a cell while its line of action stays put: the torque table misses, the
    line of action alone does not; bend the line of action instead and the second score sees it."""
    from shoulder_bench.authoring.fem.footprint_grid import cells, scores

    centres, corners, index = cells(6)
    r0 = np.array([0.02, -0.01, 0.015])

    def solves(tension, arm):
        corner_t = np.stack([tension(corners, a) for a in (0.0, 1.0)], 1)
        centre_t = np.stack([tension(centres, a) for a in (0.0, 0.5, 1.0)], 1)
        corner_tau = np.stack([tension(corners, a)[:, None] * arm(corners) for a in (0.0, 1.0)], 1)
        centre_tau = np.stack([tension(centres, a)[:, None] * arm(centres) for a in (0.0, 0.5, 1.0)], 1)
        return {"corner_index": index, "corner_torque_Nm": corner_tau, "corner_tension_N": corner_t,
                "centre_torque_Nm": centre_tau, "centre_tension_N": centre_t}

    def bent_tension(p, a):
        return 100 * (0.2 + a) * (1 + 0.5 * np.cos(np.radians(p).sum(1) * 6))

    pct, _ = scores(solves(bent_tension, lambda p: np.tile(r0, (len(p), 1))))
    assert pct["scheme_a05"].max() > 1.0 and pct["arm_a05"].max() < 1e-9
    pct, _ = scores(solves(lambda p, a: 100 * (0.2 + a) * np.ones(len(p)),
                           lambda p: r0 * (1 + 0.5 * np.cos(np.radians(p)[:, :1] * 6))))
    assert pct["arm_a05"].max() > 1.0


def test_rescoring_saved_solves_reports_how_the_error_falls_with_the_step(tmp_path, capsys):
    """Solves of a field quadratic in the pose, saved as two --grid runs (tasks' grid, twice as fine): trilinear
    interpolation's error at a cell's centre is h^2 f''/8 per coordinate, so halving the step quarters it."""
    from shoulder_bench.authoring.fem.footprint_grid import cells, rescore

    def field(p, a):
        x = np.radians(p)
        return (0.5 + a) * np.stack([x[:, 0] ** 2 + x[:, 1], x[:, 1] ** 2, x[:, 2] ** 2 - x[:, 0]], 1)

    for refine in (1, 2):
        centres, corners, index = cells(6, refine=refine)
        d = {"corner_index": index, "corner_tension_N": np.ones((len(corners), 2)),
             "centre_tension_N": np.ones((6, 3)),
             "corner_torque_Nm": np.stack([field(corners, a) for a in (0.0, 1.0)], 1),
             "centre_torque_Nm": np.stack([field(centres, a) for a in (0.0, 0.5, 1.0)], 1)}
        np.savez(tmp_path / f"k{refine}.npz", **{f"tmi/{k}": v for k, v in d.items()})
    rescore(tmp_path / "k1.npz", tmp_path / "k2.npz")
    ratio = capsys.readouterr().out.splitlines()[-1]
    assert "pose_a1 0.25, pose_a0 0.25, scheme_a05 0.25" in ratio, ratio


def test_solving_along_a_line_finds_the_equilibria_solving_from_the_reference_finds(pose):
    """solve_path continues each pose from the one before; for a contact-free sheet the equilibrium is unique, so it
    must be solve()'s (from the reference) to the solver's tolerance."""
    sheet = F.FootprintSheet("tmi", "coarse", pose=pose)
    line = np.array([[30.0, e, -15.0] for e in (0.0, 20.0, 40.0, 60.0)])
    along = sheet.solve_path(line)
    for q, r in zip(line, along):
        np.testing.assert_allclose(r["torque_Nm"], sheet.solve(q)["torque_Nm"], atol=2e-3 * abs(r["torque_Nm"]).max())
    np.testing.assert_array_equal([r["pose_deg"] for r in along], line)


def test_the_taut_band_is_stress_free_at_each_pose_and_needs_no_walk(pose):
    """rest="pose": at the reference pose the taut band is the walked sheet (the same stress-free state); elsewhere
    the band is built where it is solved, so a pose's equilibrium does not depend on what was solved before, and where
    the walked sheet goes slack (ssp at plane 45, elevation 120, rotation 45: 16 % of F0 on the coarse sheet) the band
    still pulls and has a line of action."""
    walk = F.FootprintSheet("ssp", "coarse", pose=pose)
    band = F.FootprintSheet("ssp", "coarse", pose=pose, rest="pose")
    ref = walk.solve(F.REFERENCE_POSE_DEG)
    np.testing.assert_allclose(band.solve(F.REFERENCE_POSE_DEG)["torque_Nm"], ref["torque_Nm"], rtol=1e-9, atol=1e-9)
    slack = (45.0, 120.0, 45.0)
    alone = band.solve(slack)
    band.solve((0.0, 0.0, 0.0))  # something else in between
    again = band.solve(slack)
    np.testing.assert_array_equal(again["torque_Nm"], alone["torque_Nm"])
    assert walk.solve(slack)["tension_N"] < 0.2 * walk.f0 < 0.5 * walk.f0 < alone["tension_N"]
    assert band.solve_path([slack])[0]["torque_Nm"] == pytest.approx(alone["torque_Nm"])
    with pytest.raises(ValueError, match="stress-free"):
        F.FootprintSheet("ssp", "coarse", pose=pose, rest="slack")
    # Newton from an equilibrium of the sheet built at that pose stays there; from a neighbour's it finds one too
    same = band.solve_from(slack, alone["nodes"])
    np.testing.assert_allclose(same["torque_Nm"], alone["torque_Nm"], rtol=1e-6, atol=1e-9)
    assert np.isfinite(same["energy_J"]) and same["energy_J"] > 0
    near = band.solve_from(slack, band.solve((45.0, 117.5, 45.0))["nodes"])
    assert near["tension_N"] > 0.5 * band.f0
    with pytest.raises(ValueError, match='rest="pose" only'):
        walk.solve_from(slack, alone["nodes"])


@pytest.mark.parametrize("layout", ["COLAMD", "NATURAL"])
def test_the_band_reaches_the_same_equilibrium_in_every_layout(layout, pose, monkeypatch):
    """The sheets' Newton systems are factorised by LAPACK's banded LU (`MuscleProblem.layout`, faster: the nodes are
    numbered row by row): SuperLU, in its default column ordering or the nodes' own, takes the same steps, to
    rounding, with the band pressing on its wrap sphere (contact blocks in the tangent)."""
    band = F.FootprintSheet("ssp", "coarse", pose=pose, rest="pose")
    at = (0.0, 10.0, 0.0)  # pressing on its wrap sphere
    banded = band.solve(at)
    assert banded["contact_N"] > 0 and F._Problem.layout == "BANDED"
    monkeypatch.setattr(F._Problem, "layout", layout)
    other = band.solve(at)
    np.testing.assert_allclose(other["moment_arm_m"], banded["moment_arm_m"], rtol=0, atol=1e-12)
    np.testing.assert_allclose(other["tension_N"], banded["tension_N"], rtol=1e-12)


@pytest.mark.parametrize("tendon", ["ssp", "isp"])
def test_a_narrow_taut_band_gives_back_the_mjcf_moment_arms(tendon, pose):
    """A 1 mm taut band pulls along MuJoCo's line wherever it is solved, the walked sheet's slack poses included."""
    band = F.FootprintSheet(tendon, "coarse", width_m=0.001, pose=pose, rest="pose")
    for p in (POSES[1], (45.0, 120.0, 45.0), (90.0, 0.0, 60.0)):
        s = band.solve(p)
        np.testing.assert_allclose(s["moment_arm_m"], band.mjcf_moment_arm(p), atol=1e-3)
        assert s["tension_N"] > 0.5 * band.f0


def test_the_taut_bands_grid_check_scores_its_moment_arms(pose, monkeypatch, tmp_path):
    """check_taut tables the band's moment arms, the MJCF arms and the band's correction to them: a band that is the
    MJCF arm (not trilinear) plus a trilinear field scores 0 on the correction only; bent, it scores on every one.
    The run writes footprint_grid_taut.json and its npz; --activation with the taut band is refused."""
    from shoulder_bench.authoring.fem import footprint_compare, footprint_grid

    class Band:  # what `footprint_compare.compare` reads of a sheet
        f0, width, ns, nt, reference_length = 100.0, 0.03, 3, 3, 1.0

        def __init__(self, *args, bend=0.0, **kw):
            self.bend = bend

        def _set(self, p):
            pass

        def central_length(self):
            return 1.0

        def mjcf_moment_arm(self, p):
            return 0.02 * np.cos(np.radians(np.asarray(p, float)) * 3)

        def solve(self, p):
            q = np.radians(np.asarray(p, float))
            arm = 0.01 * np.array([1 + q[0] + 2 * q[1], q[1] - q[2] + q[0] * q[2], 3 + q[2]])
            arm = arm + self.bend * np.cos(4 * q) + self.mjcf_moment_arm(p)
            return {"moment_arm_m": arm, "tension_N": 80.0, "contact_N": 0.0, "nodes": np.zeros((self.ns * self.nt, 3))}

    for bend, zero in ((0.0, True), (0.002, False)):
        monkeypatch.setattr(footprint_compare, "FootprintSheet", lambda *a, bend=bend, **k: Band(bend=bend))
        r = footprint_grid.check_taut("tmi", 4, pose=pose)
        assert r["checked"] == 4 and (max(r["correction_a1"].values()) < 1e-9) == zero
        assert min(r["arm_a1"].values()) > 0.01 and min(r["mjcf_a1"].values()) > 0.01
        assert r["within_tol"] is (max(r["correction_a1"].values()) <= 2.0)
        assert [c["tension_a1_pct_f0"] for c in r["cell_records"]] == [80.0] * 4
    footprint_grid.run(("tmi",), out=tmp_path, n=4, rest="pose")
    text = json.loads((tmp_path / "footprint_grid_taut.json").read_text())
    assert text["rest"] == "pose" and text["tendons"][0]["correction_a1"] is not None
    saved = np.load(tmp_path / "footprint_grid_taut.npz")
    assert saved["tmi/centre_arm_m"].shape == saved["tmi/centre_mjcf_m"].shape == (4, 3)
    with pytest.raises(SystemExit, match="--activation goes with --rest reference"):
        fem_main(["footprint", "--activation", "--rest", "pose", "--tendon", "tmi"])
