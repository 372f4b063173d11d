"""The parent's muscle parameters and the rigid-tendon fibre stretch on the v2 paths
(shoulder_bench.authoring.tendons)."""
from __future__ import annotations

import csv
import importlib.util
import math

import numpy as np
import pytest

from shoulder_bench.authoring import tendons
from shoulder_bench.authoring.kinematics import ShoulderPoser
from shoulder_bench.authoring.mobl_data import MUSCLES, REFERENCE_DIR

# ../shared/reference/shoulder_parameters.md (the MoBL-ARMS F0s, N)
SHOULDER_PARAMETERS_F0 = {"SUPSP": 499.2, "INFSP": 1075.8, "DELT2": 1103.5, "LAT1": 290.5, "LAT2": 317.5,
                          "LAT3": 189.0, "DELT1": 1218.9, "DELT3": 201.6, "SUBSC": 1306.9, "TMIN": 269.5, "TMAJ": 144}
SCRIPT = REFERENCE_DIR / "scripts" / "extract_parent_muscles.py"


@pytest.fixture(scope="module")
def model():
    return tendons.load_model()


def test_parent_parameters_match_the_cross_checks():
    p = tendons.load_parent()
    assert set(p) == {"SUPSP", "INFSP", "DELT1", "DELT2", "DELT3", "SUBSC", "TMIN", "TMAJ", "PECM1", "PECM2",
                      "PECM3", "LAT1", "LAT2", "LAT3", "CORB"}
    # shared README section 6.1: "The parent file lists SUPSP as 499.2 N / 68.2 / 39.5"
    assert (p["SUPSP"].f0, p["SUPSP"].l_opt, p["SUPSP"].l_ts) == (499.2, 0.0682, 0.0395)
    assert math.degrees(p["SUPSP"].alpha0) == pytest.approx(7.0, abs=1e-6)
    for m, f0 in SHOULDER_PARAMETERS_F0.items():
        assert p[m].f0 == f0, m
    assert {q.cls for q in p.values()} == {"Schutte1993Muscle_Deprecated"}
    assert all(q.l_opt > 0 and q.l_ts > 0 and 0 <= q.alpha0 < math.pi / 2 for q in p.values())


def test_extraction_script_on_a_small_file(tmp_path):
    spec = importlib.util.spec_from_file_location("extract_parent_muscles", SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    body = "".join(
        f'<Schutte1993Muscle_Deprecated name="{m}"><max_isometric_force>{i + 1}.5</max_isometric_force>'
        f"<optimal_fiber_length>0.1</optimal_fiber_length><tendon_slack_length>0.02</tendon_slack_length>"
        f"<pennation_angle_at_optimal>0.1</pennation_angle_at_optimal>"
        f"<SimmSpline><max_isometric_force>999</max_isometric_force></SimmSpline></Schutte1993Muscle_Deprecated>"
        for i, m in enumerate(mod.MUSCLES))
    osim = tmp_path / "m.osim"
    osim.write_text(f'<OpenSimDocument><Model name="x"><ForceSet><objects>{body}</objects></ForceSet></Model>'
                    "</OpenSimDocument>")
    out = tmp_path / "out.csv"
    assert mod.main([str(osim), "--out", str(out)]) == 0
    rows = list(csv.DictReader(open(out, newline="")))
    assert [r["muscle"] for r in rows] == list(mod.MUSCLES)
    assert rows[0]["max_isometric_force_N"] == "1.5" and rows[0]["class"] == "Schutte1993Muscle_Deprecated"
    with open(REFERENCE_DIR / "mobl_arms_parent_muscles.csv", newline="") as f:
        assert tuple(csv.DictReader(f).fieldnames) == mod.COLUMNS
    osim.write_text(osim.read_text().replace('name="CORB"', 'name="XX"'))
    with pytest.raises(SystemExit, match="CORB"):
        mod.main([str(osim)])


def test_stretch_equals_the_formula_from_ten_length(model):
    p = tendons.load_parent()
    poser = ShoulderPoser(model)
    for pose, girdle in (((0, 60, 0), "coupled"), ((30, 0, 0), "fixed"), ((30, 120, 0), "fixed")):
        d = poser.pose(*np.radians(pose), girdle)
        for t, m in MUSCLES.items():
            L = float(d.ten_length[model.tendon(t).id])
            q = p[m]
            by_hand = math.sqrt((L - q.l_ts) ** 2 + (q.l_opt * math.sin(q.alpha0)) ** 2) / q.l_opt
            assert L > q.l_ts  # the slack branch is not used on these paths
            assert float(tendons.stretch(L, q)) == pytest.approx(by_hand, rel=1e-12)
            got = tendons.tendon_lengths(model, [t], pose[0], [pose[1]], girdle)[0, 0]
            assert got == L
    q = p["SUPSP"]
    assert float(tendons.stretch(q.l_ts - 0.01, q)) == pytest.approx(math.sin(q.alpha0))  # slack: fibres at width
    assert float(tendons.stretch(q.l_ts + q.l_opt * math.cos(q.alpha0), q)) == pytest.approx(1.0)


def test_analysis_rows_and_table(model, capsys):
    rows = tendons.analyse(model, step_deg=10.0)
    assert len(rows) == len(MUSCLES) * len(tendons.PLANES) * len(tendons.GIRDLES)
    p = tendons.load_parent()
    for r in rows:
        lo, hi = r["lam_task"]
        assert r["lam_wide"][0] <= lo <= r["lam_rest"] <= hi <= r["lam_wide"][1]
        assert r["in_band"] == (lo >= 0.85 and hi <= 1.15)
        assert r["lam_rest"] == pytest.approx(float(tendons.stretch(r["L_rest"], p[r["muscle"]])))
        assert r["excursion_mm"] > 0 and r["parent_excursion_mm"] > 0
    assert tendons.main(["--step", "20"]) == 0
    out = capsys.readouterr().out
    assert out.count("| ssp (SUPSP) |") == 4 and "| ld3 | LAT3 | 189 |" in out
