"""The full shoulder's forces (issue 12 §2): length-keyed FEM tables, the law in both callbacks, the build and its
checks (`shoulder-bench fem build --full`, `fem verify --full`)."""
from __future__ import annotations

import dataclasses
import json

import mujoco
import numpy as np
import pytest

from shoulder_bench import full_arm
from shoulder_bench.authoring import mobl
from shoulder_bench.authoring.fem import full, verify_full
from shoulder_bench.locks import FolderLock
from shoulder_bench.model import attach_law, install_callbacks
from shoulder_bench.tendon_law import TendonLaw, TendonTable


@pytest.fixture(scope="module")
def law():
    return TendonLaw.load("fem", groups=full_arm.ACTUATORS)


def test_task_model_is_the_generators_and_the_pose_space_lies_in_its_ranges():
    assert full_arm.MODEL_FILE.read_text() == mobl.full_task_model_xml()
    m = full_arm.compile_full()
    assert m.opt.timestep == mobl.FULL_TIMESTEP and m.nu == len(full_arm.TENDONS) == 15
    for c, (lo, hi) in full_arm.POSE_RANGE_DEG.items():
        jlo, jhi = np.degrees(m.joint(c).range)
        assert jlo <= lo < hi <= jhi
        assert m.dof_armature[m.joint(c).dofadr[0]] == mobl.FULL_ARMATURE


def test_shipped_tables_match_their_inputs(law):
    """Every shipped table carries the input hash the build would give it now (sheet, material, solver, length grid
    over the pose space), so a change of the model's paths or the pose space shows here."""
    grids, specs = full.length_grids(), full.specs()
    for t in law.tables:
        assert t.meta["input_hash"] == full.input_hash(specs[t.muscle], "full", grids[t.muscle],
                                                        full.Material(), full.SETTINGS), t.muscle
        assert t.meta["fibre_stretch_range"][1] < 3.0 and "0 stalled" in t.meta["tolerance"]


@pytest.mark.parametrize("native", [True, False])
def test_both_callbacks_apply_the_law_along_each_tendon(law, native):
    m = full_arm.compile_full()
    attach_law(m, law)
    install_callbacks(native=native)
    d, pose = mujoco.MjData(m), full_arm.Pose(m)
    rng = np.random.default_rng(0)
    ids = [m.actuator(t).id for t in law.actuators]
    for _ in range(10):
        p = rng.uniform([0, 0, -45], [90, 140, 60])
        d.qpos[:] = pose.qpos(p)[0]
        d.qvel[:] = rng.normal(0, 0.5, m.nv)
        a = rng.uniform(0, 1, len(law.muscles))
        for k, mu in enumerate(law.muscles):
            d.ctrl[[m.actuator(t).id for t in full_arm.ACTUATORS[mu]]] = a[k]
        mujoco.mj_forward(m, d)
        f = law.force(d.actuator_length[ids][None], d.actuator_velocity[ids][None], a[None])[0]
        np.testing.assert_allclose(-d.actuator_force[ids], f, rtol=1e-12, atol=1e-9)
    install_callbacks()


def test_law_fv_and_passive_follow_the_table(law):
    t = law.tables[0]
    mid = np.array([[t.length_m[10]] + [x.length_m[10] for x in law.tables[1:]]])
    zero, act = np.zeros_like(mid), np.full((1, len(law.muscles)), 0.5)
    static = law.force(mid, zero, act)[0, 0]
    assert static == pytest.approx(np.interp(0.5, t.activation, t.force_N[10]))
    passive = law.force(mid, zero, np.zeros_like(act))[0, 0]
    assert passive == pytest.approx(t.force_N[10, 0])
    short = law.force(mid, zero - 0.1, act)[0, 0]  # shortening lowers the active part only
    assert passive < short < static


def test_table_errors_name_the_file_and_the_command(tmp_path):
    with pytest.raises(FileNotFoundError, match="fem build --full"):
        TendonTable.load(tmp_path / "ssp_fem.npz")
    bad = tmp_path / "ssp_fem.npz"
    bad.write_bytes(b"not a zip")
    with pytest.raises(ValueError, match=r"ssp_fem.npz is unreadable or corrupt.*fem build --full"):
        TendonTable.load(bad)


def test_build_resumes_caches_and_locks(tmp_path, capsys):
    out = tmp_path / "tables"
    first = full.build(coarse=True, out=out, quiet=True, tendons_=("ssp",))
    assert not first["ssp"]["cached"] and (out / "ssp_fem.npz").exists() and not (out / ".lock").exists()
    again = full.build(coarse=True, out=out, quiet=True, tendons_=("ssp", "tmi"))  # resumes: only tmi is solved
    assert again["ssp"]["cached"] and not again["tmi"]["cached"]
    table = TendonTable.load(out / "tmi_fem.npz")
    assert table.force_N.shape == (full.LENGTH_POINTS, 6) and np.all(np.diff(table.force_N, axis=1) >= -1e-6)
    lock = FolderLock(out)
    try:
        with pytest.raises(ValueError, match="table folder .* is in use by pid"):
            full.build(coarse=True, out=out, quiet=True, tendons_=("ssp",))
    finally:
        lock.release()
    with pytest.raises(ValueError, match="--coarse without --out"):
        full.build(coarse=True)
    with pytest.raises(ValueError, match="unknown tendon"):
        full.build(coarse=True, out=out, tendons_=("deltoid",))


def test_held_out_check_passes_on_its_own_tables_and_fails_on_perturbed_ones(tmp_path):
    out = tmp_path / "tables"
    full.build(coarse=True, out=out, quiet=True, tendons_=("ssp",))
    good = TendonLaw.load("fem", ("ssp",), out)
    pose = full_arm.Pose()
    checks = verify_full.held_out(good, pose, coarse=True)
    assert len(checks) == 3 and all(ok for _, ok, _ in checks), checks
    t = good.tables[0]
    off = TendonLaw([dataclasses.replace(t, force_N=t.force_N * 1.05)])
    assert not all(ok for _, ok, _ in verify_full.held_out(off, pose, coarse=True))


def test_applied_check_passes_and_can_fail(monkeypatch):
    applied = verify_full.applied_vs_fem()
    assert len(applied) == 3 * len(full_arm.MUSCLES) and all(ok for _, ok, _ in applied), \
        [c for c in applied if not c[1]]
    real = TendonLaw.force
    monkeypatch.setattr(TendonLaw, "force", lambda self, *a: 1.02 * real(self, *a))  # the "FEM" side moves by 2 %
    assert not all(ok for _, ok, _ in verify_full.applied_vs_fem())


def test_arm_stays_finite_under_random_activations(law):
    m = full_arm.compile_full()
    attach_law(m, law)
    install_callbacks()
    pose, rng = full_arm.Pose(m), np.random.default_rng(3)
    for start in ([10, 5, 0], [80, 120, 40], [45, 60, -30]):
        d = mujoco.MjData(m)
        d.qpos[:] = pose.qpos(start)[0]
        for _ in range(20):  # 2 s
            d.ctrl[:] = rng.uniform(0, 1, m.nu) ** 3
            mujoco.mj_step(m, d, 10)
        assert np.isfinite(d.qpos).all() and d.warning[mujoco.mjtWarning.mjWARN_BADQACC].number == 0


def test_meta_records_provenance(law):
    meta = law.tables[law.actuators.index("ssc")].meta
    assert meta["parent_muscle"] == "SUBSC" and meta["coordinate"] == "tendon length"
    assert json.loads(json.dumps(meta))["optimal_fibre_length_m"] > 0


def test_cli_errors_for_the_full_build():
    from shoulder_bench.cli.fem import main

    with pytest.raises(SystemExit, match="--coarse without --out"):
        main(["build", "--full", "--coarse"])
    with pytest.raises(SystemExit, match="--jobs is for --full"):
        main(["build", "--jobs", "2"])
    with pytest.raises(SystemExit, match="--tendon"):
        main(["build", "--full", "--muscle", "ssp"])


def _interrupted_first(job):
    """Stands in for `full._solve_one` in the workers: marks its tendon started; the first raises KeyboardInterrupt (as
    Ctrl-C raises it in a worker), the others take a while."""
    import time

    t, spec = job[0], job[1]
    (spec.marks / t).touch()
    if t == spec.first:
        raise KeyboardInterrupt
    time.sleep(0.2)
    return t, {}, 0.0


def test_an_interrupted_parallel_build_drops_the_tendons_not_started(monkeypatch, tmp_path):
    """`fem build --full --jobs 2` interrupted stops without solving the tendons its workers had not started (the
    pool's `map` cancels them) and writes no table."""
    marks = tmp_path / "started"
    marks.mkdir()
    specs = full.specs()
    first = next(iter(specs))
    marked = {t: dataclasses.replace(s) for t, s in specs.items()}
    for s in marked.values():
        object.__setattr__(s, "marks", marks)
        object.__setattr__(s, "first", first)
    monkeypatch.setattr(full, "specs", lambda geometry=None: marked)
    monkeypatch.setattr(full, "input_hash", lambda *a, **k: "x")
    monkeypatch.setattr(full, "_solve_one", _interrupted_first)
    with pytest.raises(KeyboardInterrupt):
        full.build(out=tmp_path / "tables", jobs=2, quiet=True)
    started = sorted(p.name for p in marks.iterdir())
    assert first in started and len(started) <= 8 < len(specs)  # the running and the queued (6 here), a margin
    assert not list((tmp_path / "tables").glob("*.npz"))
