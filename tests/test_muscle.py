"""The force law and its tables: interpolation, the gain/bias split, force-velocity, and errors for bad tables."""
import dataclasses
import json
import shutil

import numpy as np
import pytest

from shoulder_bench.authoring import hill
from shoulder_bench.muscle import FV_MAX, ForceLaw, MuscleTable, replacing, table_path


@pytest.fixture(scope="module")
def law():
    return ForceLaw.load("hill")


def test_interpolation_reproduces_grid_points_and_is_linear_between(law):
    t = law.tables[2]  # dmi
    k = 20
    angle = np.radians(np.full(3, t.angle_deg[k]))
    act = np.zeros((3, 4))
    act[:, 2] = t.activation
    f = law.force(angle, np.zeros(3), act)[:, 2]
    assert np.allclose(f, t.force_N[k], rtol=1e-12)
    mid = np.radians([(t.angle_deg[k] + t.angle_deg[k + 1]) / 2])
    a = np.zeros((1, 4))
    a[0, 2] = 1.0
    expected = (t.force_N[k, -1] + t.force_N[k + 1, -1]) / 2
    assert law.force(mid, np.zeros(1), a)[0, 2] == pytest.approx(expected, rel=1e-12)


def test_gain_times_activation_plus_bias_is_the_force(law):
    rng = np.random.default_rng(1)
    angle, vel = rng.uniform(-0.2, 2.8, 500), rng.normal(0, 3, 500)
    act = rng.uniform(0, 1, (500, 4))
    act[:50] = 0.0
    gain, bias = law.gain_bias(angle, vel, act)
    assert np.allclose(gain * act + bias, law.force(angle, vel, act), rtol=1e-12, atol=1e-9)
    assert np.all(gain[:50] > 0)  # defined (the first cell's slope) at zero activation


def test_force_velocity_factor(law):
    angle = np.radians(np.full(3, 60.0))
    # elevating the arm shortens the deltoid (positive moment arm): force falls; lowering lengthens: force rises
    fv = law.force_velocity(angle, np.array([0.0, 2.0, -2.0]))[:, 2]
    assert fv[0] == pytest.approx(1.0)
    assert fv[1] < 1.0 < fv[2] <= FV_MAX
    very_fast = law.force_velocity(angle, np.array([1e3]))[:, 2]
    assert very_fast[0] == 0.0


TABLE_RTOL = 1e-9  # of each array's largest |value|: another CPU differs by ~1e-16, a real change by >= 1e-6
ARRAYS = ("angle_deg", "activation", "force_N", "torque_Nm", "moment_arm_m")


def _differences(a, b, rtol=TABLE_RTOL) -> list[str]:
    """What differs between two tables: arrays beyond rtol x their largest |value|, metadata exactly except floats
    (to rtol relative)."""
    out = [k for k in ARRAYS if getattr(a, k).shape != getattr(b, k).shape
           or np.max(np.abs(getattr(a, k) - getattr(b, k))) > rtol * np.max(np.abs(getattr(b, k)))]

    def same(x, y):
        if isinstance(x, float) or isinstance(y, float):
            return isinstance(x, (int, float)) and isinstance(y, (int, float)) and np.isclose(x, y, rtol=rtol, atol=0)
        if isinstance(x, dict) and isinstance(y, dict):
            return x.keys() == y.keys() and all(same(x[k], y[k]) for k in x)
        if isinstance(x, list) and isinstance(y, list):
            return len(x) == len(y) and all(same(u, v) for u, v in zip(x, y))
        return type(x) is type(y) and x == y

    return out + [f"meta.{k}" for k in sorted(a.meta.keys() | b.meta.keys())
                  if not same(a.meta.get(k), b.meta.get(k))]


def test_hill_tables_regenerate_within_float_tolerance(tmp_path):
    hill.build_tables(folder=tmp_path)
    for m in ("ssp", "isp", "dmi", "ld"):
        a, b = MuscleTable.load(tmp_path / f"{m}_hill.npz"), MuscleTable.load(table_path(m, "hill"))
        assert _differences(a, b) == [], m


def test_table_comparison_ignores_last_bits_and_catches_a_real_change():
    b = MuscleTable.load(table_path("dmi", "hill"))
    scaled = lambda t, f: dataclasses.replace(t, force_N=t.force_N * f)  # noqa: E731
    assert _differences(scaled(b, 1 + 1e-15), b) == []
    assert _differences(scaled(b, 1 + 1e-6), b) == ["force_N"]
    meta = dict(b.meta, F0_N=b.meta["F0_N"] * (1 + 1e-6), law=b.meta["law"] + " ")
    assert _differences(dataclasses.replace(b, meta=meta), b) == ["meta.F0_N", "meta.law"]
    assert _differences(dataclasses.replace(b, meta=dict(b.meta, F0_N=b.meta["F0_N"] * (1 + 1e-15))), b) == []


def test_missing_table_names_file_and_command(tmp_path):
    with pytest.raises(FileNotFoundError, match=r"ssp_hill\.npz.*python -m shoulder_bench\.authoring\.hill"):
        ForceLaw.load("hill", folder=tmp_path)


def test_corrupt_table_names_file_and_command(tmp_path):
    for m in ("ssp", "isp", "dmi", "ld"):
        shutil.copy(table_path(m, "hill"), tmp_path)
    (tmp_path / "dmi_hill.npz").write_bytes(b"not a zip file")
    with pytest.raises(ValueError, match=r"dmi_hill\.npz.*corrupt.*rebuild"):
        ForceLaw.load("hill", folder=tmp_path)


def test_table_for_another_model_is_rejected(tmp_path):
    for m in ("ssp", "isp", "dmi", "ld"):
        shutil.copy(table_path(m, "hill"), tmp_path)
    with np.load(table_path("isp", "hill")) as z:
        data = dict(z)
    data["moment_arm_m"] = data["moment_arm_m"] + 0.002  # as if built for other tendon paths
    np.savez(tmp_path / "isp_hill.npz", **data)
    with pytest.raises(ValueError, match=r"isp_hill\.npz does not match the model.*rebuild"):
        ForceLaw.load("hill", folder=tmp_path)


def test_unknown_muscle_model():
    with pytest.raises(ValueError, match="fem"):
        ForceLaw.load("spring")


def test_table_metadata_names_its_source():
    t = MuscleTable.load(table_path("ssp", "hill"))
    assert t.meta["model"] == "hill" and "Hill" in t.meta["law"]
    json.dumps(t.meta)


def test_replacing_leaves_the_old_file_and_no_temporary_on_failure(tmp_path):
    path = tmp_path / "t.npz"
    path.write_bytes(b"old")
    with pytest.raises(RuntimeError):
        with replacing(path) as tmp:
            tmp.write_bytes(b"half-writ")
            raise RuntimeError("disk full")
    assert path.read_bytes() == b"old" and sorted(p.name for p in tmp_path.iterdir()) == ["t.npz"]
    with replacing(path) as tmp:
        tmp.write_bytes(b"new")
    assert path.read_bytes() == b"new" and sorted(p.name for p in tmp_path.iterdir()) == ["t.npz"]


def test_load_other_muscles_from_a_folder_against_given_arms():
    """With a folder, muscles outside anatomy (v2's tendons) load; `arms` (dict or callable) replaces v1's MJCF in
    the moment-arm check; without a folder only v1's names are accepted."""
    from shoulder_bench.authoring import hill_v2

    names = ("ssp", "ld2")
    tables = {t: MuscleTable.load(table_path(t, "hill", hill_v2.FOLDER)) for t in names}
    arms = {t: tables[t].moment_arm_m for t in names}
    law = ForceLaw.load("hill", muscles=names, folder=hill_v2.FOLDER, arms=arms)
    assert law.muscles == names
    called = []
    law2 = ForceLaw.load("hill", muscles=names, folder=hill_v2.FOLDER, arms=lambda g: called.append(g) or arms)
    assert len(called) == 1 and np.array_equal(called[0], tables["ssp"].angle_deg) and law2.muscles == names
    with pytest.raises(ValueError, match=r"ld2_hill\.npz does not match the model mobl\.model_xml"):
        ForceLaw.load("hill", muscles=names, folder=hill_v2.FOLDER, arms=dict(arms, ld2=arms["ld2"] + 1e-4))
    with pytest.raises(ValueError, match="no model moment arm given for 'ld2'"):
        ForceLaw.load("hill", muscles=names, folder=hill_v2.FOLDER, arms={"ssp": arms["ssp"]})
    with pytest.raises(ValueError, match=r"unknown muscle\(s\) \['ld2'\]"):
        ForceLaw.load("hill", muscles=names)
