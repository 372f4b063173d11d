"""The shipped bone meshes are current, small, closed and clear of the humeral head and of each other."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh

from shoulder_bench.authoring import anatomy as A
from shoulder_bench.authoring import bones

ASSETS = Path(__file__).resolve().parents[1] / "models" / "assets"


def _load(path: Path) -> trimesh.Trimesh:
    return trimesh.load(path, file_type="stl", force="mesh")


@pytest.fixture(scope="module")
def meshes() -> dict[str, trimesh.Trimesh]:
    return {name: _load(ASSETS / f"{name}.stl") for name in bones.ASSET_NAMES}


def _inside_thorax(points: np.ndarray) -> np.ndarray:
    c, r = np.asarray(A.THORAX["centre"]), np.asarray(A.THORAX["radii"])
    return np.sum(((points - c) / r) ** 2, axis=1) < 1.0


def test_regenerated_meshes_match_shipped_files(tmp_path):
    paths = bones.build_bone_meshes(tmp_path)
    assert sorted(paths) == sorted(bones.ASSET_NAMES)
    for name, path in paths.items():
        shipped = ASSETS / f"{name}.stl"
        if path.read_bytes() == shipped.read_bytes():
            continue
        # other platforms may round a float differently: the triangles must still agree (STL stores float32)
        new, old = _load(path), _load(shipped)
        assert len(new.faces) == len(old.faces), name
        np.testing.assert_allclose(new.triangles, old.triangles, atol=1e-6, err_msg=name)


def test_sizes_and_face_counts(meshes):
    total = 0
    for name, mesh in meshes.items():
        assert 500 <= len(mesh.faces) <= 6000, (name, len(mesh.faces))
        total += (ASSETS / f"{name}.stl").stat().st_size
    assert total < 1.5e6


@pytest.mark.parametrize("name", bones.ASSET_NAMES)
def test_parts_closed_and_outward(name):
    mesh = bones.BUILDERS[name]()
    for part in mesh.split(only_watertight=False):
        assert part.is_watertight and part.is_winding_consistent, name
        assert part.volume > 0, name


def test_humerus_shape(meshes):
    v = meshes["humerus"].vertices
    assert v[:, 2].min() == pytest.approx(-A.HUMERUS_LENGTH, abs=0.005)
    assert 0.30 <= np.ptp(v[:, 2]) <= 0.34
    r = np.linalg.norm(v, axis=1)
    assert r[v[:, 2] > 0].max() <= 0.027  # head no bigger than the wrapping sphere on the superior side
    assert v[v[:, 2] > -0.05, 1].max() <= 0.027  # nor laterally (greater tubercle included)
    assert np.ptp(v[v[:, 2] < -0.25, 1]) > 0.05  # epicondyles widen the distal end
    shaft = v[(v[:, 2] < -0.17) & (v[:, 2] > -0.19)]
    assert 0.009 < np.abs(shaft[:, :2]).max() < 0.015


def test_scapula_and_clavicle_clear_of_head(meshes):
    for name in ("scapula", "clavicle"):
        assert np.linalg.norm(meshes[name].vertices, axis=1).min() > A.HUMERAL_HEAD_RADIUS, name
    # the acromion arches over the head: the spine/acromion part lies above z = 0.03 lateral of the glenoid
    tip = np.asarray(A.SCAPULA["acromion_tip"])
    parts = meshes["scapula"].split(only_watertight=False)
    acromion = min(parts, key=lambda p: np.linalg.norm(p.vertices - tip, axis=1).min())
    over_head = acromion.vertices[acromion.vertices[:, 1] > -0.02]
    assert len(over_head) and over_head[:, 2].min() > 0.03
    # the glenoid faces the head from the medial side
    g = np.asarray(A.GLENOID_CENTRE)
    near_glenoid = meshes["scapula"].vertices[np.linalg.norm(meshes["scapula"].vertices - g, axis=1) < 0.01]
    assert len(near_glenoid)


def test_bone_placement(meshes):
    c = meshes["clavicle"].vertices
    for end in ("sternal_end", "acromial_end"):
        assert np.linalg.norm(c - np.asarray(A.CLAVICLE[end]), axis=1).min() < 0.01, end
    s = meshes["scapula"].vertices
    for landmark in ("superior_angle", "inferior_angle", "medial_spine_root", "coracoid_tip"):
        assert np.linalg.norm(s - np.asarray(A.SCAPULA[landmark]), axis=1).min() < 0.01, landmark
    t = meshes["thorax"]
    assert -0.36 < t.bounds[0, 2] and t.bounds[1, 2] < 0.09
    assert t.bounds[1, 1] < -0.05  # the rib cage stays medial of the arm


def test_humerus_clear_of_thorax_over_joint_range(meshes):
    v = meshes["humerus"].vertices
    for deg in np.linspace(*A.JOINT_RANGE_DEG, 18):
        rot = trimesh.transformations.rotation_matrix(np.radians(deg), (1.0, 0.0, 0.0))[:3, :3]
        assert not _inside_thorax(v @ rot.T).any(), deg
