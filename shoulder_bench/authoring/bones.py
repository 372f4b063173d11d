"""Hand-built bone surface meshes (humerus, scapula, clavicle, thorax) placed on the landmarks of `anatomy`.

Why hand-built: the benchmark must run offline, and no public shoulder segmentation can be downloaded at run time;
BodyParts3D, which the paper renders, is not shipped with this repository. So the four meshes are built here from
analytic primitives (spheres, ellipsoids, tubes swept along splines, thick plates) on the same landmarks as the MJCF
and the muscle paths, and written as small binary STL files. `python -m shoulder_bench.authoring.bones` regenerates
`models/assets/*.stl`; the output is deterministic (no randomness), and a test checks the shipped files are current.

Simplifications (shapes are for display and clearance, not for contact):
- humerus: a full sphere of radius HUMERAL_HEAD_RADIUS at the origin (the wrapping sphere) stands for the head and
  anatomical neck; tubercles, the deltoid tuberosity, epicondyles and the condyle are ellipsoids or a capsule; the
  shaft is a tube with a tapered elliptical section that flares into the distal end. No torsion or retroversion.
- scapula: the blade is a thin lens-shaped plate spanned between the glenoid neck and the superior and inferior
  angles; the spine and acromion are one tube whose section turns from an upright ridge into a flat plate over the
  head; the glenoid is a shallow spherical shell concentric with the head; the coracoid is a hooked tube.
- clavicle: one S-shaped tube, rounder medially and flattened laterally.
- thorax: eight flat rib bands on the THORAX ellipsoid (right half, descending anteriorly), a sternum strip and a
  vertebral column rod; only the region near the shoulder, not a closed cage.
Each mesh is a concatenation of closed, consistently outward-oriented parts; parts may overlap (no booleans).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh

from shoulder_bench.authoring import anatomy as A
from shoulder_bench.paths import MODELS_DIR

ASSET_NAMES = ("humerus", "scapula", "clavicle", "thorax")


# ----------------------------------------------------------------------------------------------------- primitives
def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _outward(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """Flip the winding of a closed part whose signed volume is negative (normals pointing inwards)."""
    if mesh.volume < 0:
        mesh.invert()
    return mesh


def _spline(points, n: int, closed: bool = False) -> np.ndarray:
    """`n` points spaced evenly by arc length on a uniform Catmull-Rom spline through `points`."""
    p = np.asarray(points, dtype=float)
    if closed:
        ext = np.vstack([p[-1], p, p[0], p[1]])
    else:
        ext = np.vstack([2 * p[0] - p[1], p, 2 * p[-1] - p[-2]])
    t = np.linspace(0.0, 1.0, 40, endpoint=False)[:, None]
    dense = []
    for i in range(len(ext) - 3):
        p0, p1, p2, p3 = ext[i:i + 4]
        dense.append(0.5 * (2 * p1 + (p2 - p0) * t + (2 * p0 - 5 * p1 + 4 * p2 - p3) * t**2
                            + (3 * p1 - p0 - 3 * p2 + p3) * t**3))
    dense.append(ext[-2][None] if not closed else ext[1][None])
    dense = np.vstack(dense)
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(dense, axis=0), axis=1))])
    targets = np.linspace(0.0, s[-1], n + 1 if closed else n)
    out = np.column_stack([np.interp(targets, s, dense[:, k]) for k in range(3)])
    return out[:-1] if closed else out


def _ellipsoid(centre, radii, subdivisions: int = 2) -> trimesh.Trimesh:
    m = trimesh.creation.icosphere(subdivisions=subdivisions, radius=1.0)
    m.vertices = m.vertices * np.asarray(radii) + np.asarray(centre)
    return _outward(m)


def _tube(path, a, b, hints, sides: int = 12, end_rings: int = 3) -> trimesh.Trimesh:
    """Closed tube along `path` with an elliptical section: semi-axis `a` along `hints`, `b` across; rounded ends.

    `a`, `b` are scalars or per-point arrays; `hints` is one vector or one per point (projected off the tangent).
    """
    path = np.asarray(path, dtype=float)
    n = len(path)
    a = np.broadcast_to(np.asarray(a, dtype=float), (n,))
    b = np.broadcast_to(np.asarray(b, dtype=float), (n,))
    hints = np.broadcast_to(np.asarray(hints, dtype=float), (n, 3))
    tan = _unit(np.gradient(path, axis=0))
    nor = _unit(hints - np.sum(hints * tan, axis=1, keepdims=True) * tan)
    bin_ = np.cross(tan, nor)
    # rounded ends: extra rings beyond each end, shrinking on a quarter circle
    centres, aa, bb, nn, bn = [], [], [], [], []
    for end, sign in ((0, -1.0), (n - 1, 1.0)):
        r_end = 0.5 * (a[end] + b[end])
        phis = np.linspace(0.0, 0.5 * np.pi, end_rings + 2)[1:-1]
        rings = [(path[end] + sign * r_end * np.sin(f) * tan[end], np.cos(f)) for f in phis]
        if sign < 0:
            rings = rings[::-1]
        centres.append([c for c, _ in rings])
        aa.append([a[end] * s for _, s in rings])
        bb.append([b[end] * s for _, s in rings])
        nn.append([nor[end]] * len(rings))
        bn.append([bin_[end]] * len(rings))
    cen = np.vstack([centres[0], path, centres[1]])
    aa = np.concatenate([aa[0], a, aa[1]])
    bb = np.concatenate([bb[0], b, bb[1]])
    nn = np.vstack([nn[0], nor, nn[1]])
    bn = np.vstack([bn[0], bin_, bn[1]])
    th = np.linspace(0.0, 2 * np.pi, sides, endpoint=False)
    rings = (cen[:, None, :] + aa[:, None, None] * np.cos(th)[None, :, None] * nn[:, None, :]
             + bb[:, None, None] * np.sin(th)[None, :, None] * bn[:, None, :])
    m = len(cen)
    tips = np.vstack([path[0] - 0.5 * (a[0] + b[0]) * tan[0], path[-1] + 0.5 * (a[-1] + b[-1]) * tan[-1]])
    verts = np.vstack([rings.reshape(-1, 3), tips])
    idx = np.arange(m * sides).reshape(m, sides)
    j1 = np.roll(np.arange(sides), -1)
    faces = []
    for i in range(m - 1):
        faces.append(np.column_stack([idx[i], idx[i + 1], idx[i + 1, j1]]))
        faces.append(np.column_stack([idx[i], idx[i + 1, j1], idx[i, j1]]))
    t0, t1 = m * sides, m * sides + 1
    faces.append(np.column_stack([np.full(sides, t0), idx[0], idx[0, j1]]))
    faces.append(np.column_stack([np.full(sides, t1), idx[-1, j1], idx[-1]]))
    return _outward(trimesh.Trimesh(verts, np.vstack(faces)))


def _plate(top: np.ndarray, bottom: np.ndarray, top_centre, bottom_centre) -> trimesh.Trimesh:
    """Closed plate from two polar grids (rings x angles x 3), innermost ring first, joined at the outer rim."""
    k, j = top.shape[:2]
    verts = np.vstack([top_centre, top.reshape(-1, 3), bottom_centre, bottom.reshape(-1, 3)])
    ti = 1 + np.arange(k * j).reshape(k, j)
    bi = ti + k * j + 1
    j1 = np.roll(np.arange(j), -1)
    faces = [np.column_stack([np.zeros(j, int), ti[0], ti[0, j1]]),
             np.column_stack([np.full(j, k * j + 1), bi[0, j1], bi[0]])]
    for r in range(k - 1):
        faces += [np.column_stack([ti[r], ti[r + 1], ti[r + 1, j1]]),
                  np.column_stack([ti[r], ti[r + 1, j1], ti[r, j1]]),
                  np.column_stack([bi[r], bi[r + 1, j1], bi[r + 1]]),
                  np.column_stack([bi[r], bi[r, j1], bi[r + 1, j1]])]
    faces += [np.column_stack([ti[-1, j1], ti[-1], bi[-1]]), np.column_stack([ti[-1, j1], bi[-1], bi[-1, j1]])]
    return _outward(trimesh.Trimesh(verts, np.vstack(faces)))


def _join(parts: list[trimesh.Trimesh]) -> trimesh.Trimesh:
    return trimesh.util.concatenate(parts)


# ---------------------------------------------------------------------------------------------------------- bones
def humerus() -> trimesh.Trimesh:
    """Humerus in its body frame: head sphere at the origin, shaft down -z to -HUMERUS_LENGTH."""
    r, length = A.HUMERAL_HEAD_RADIUS, A.HUMERUS_LENGTH
    head = trimesh.creation.icosphere(subdivisions=3, radius=r)
    greater = _ellipsoid((-0.003, 0.013, -0.007), (0.012, 0.0125, 0.016))
    lesser = _ellipsoid((0.014, 0.001, -0.013), (0.007, 0.006, 0.009), subdivisions=1)
    # shaft: semi-axes (AP along x, ML along y) as a function of height
    zk = np.array([-0.005, -0.030, -0.060, -0.120, -0.200, -0.235, -0.262, -0.280])
    ax = np.array([0.0185, 0.0160, 0.0130, 0.0115, 0.0110, 0.0100, 0.0095, 0.0090])
    ay = np.array([0.0190, 0.0160, 0.0128, 0.0115, 0.0125, 0.0170, 0.0240, 0.0255])
    z = np.linspace(zk[0], zk[-1], 30)
    path = np.column_stack([np.zeros_like(z), np.zeros_like(z), z])
    shaft = _tube(path, np.interp(-z, -zk, ax), np.interp(-z, -zk, ay), (1.0, 0.0, 0.0), sides=16, end_rings=1)
    deltoid = _ellipsoid((0.005, 0.0075, -0.125), (0.0065, 0.0065, 0.022), subdivisions=1)
    zc = -length + 0.011
    condyle = _tube([(0.006, -0.019, zc), (0.006, 0.0, zc + 0.001), (0.006, 0.016, zc)], 0.011, 0.011,
                    (1.0, 0.0, 0.0), sides=14, end_rings=2)
    medial_epi = _ellipsoid((-0.002, -0.029, -0.275), (0.008, 0.010, 0.010), subdivisions=1)
    lateral_epi = _ellipsoid((-0.001, 0.025, -0.276), (0.007, 0.006, 0.009), subdivisions=1)
    return _join([head, greater, lesser, shaft, deltoid, condyle, medial_epi, lateral_epi])


def _blade_frame() -> tuple[np.ndarray, np.ndarray]:
    """Outline of the scapular blade (closed, 3-D) and its posterior unit normal."""
    S = A.SCAPULA
    outline = np.array([
        (-0.011, -0.038, 0.012),           # lateral angle, above the glenoid neck
        (-0.020, -0.048, 0.030),           # superior border near the coracoid base / notch
        (-0.040, -0.072, 0.040),
        S["superior_angle"],
        (-0.066, -0.108, 0.025),
        S["medial_spine_root"],
        (-0.066, -0.104, -0.040),          # medial (vertebral) border
        (-0.061, -0.092, -0.095),
        S["inferior_angle"],
        (-0.040, -0.066, -0.110),          # lateral (axillary) border
        (-0.024, -0.050, -0.060),
        (-0.012, -0.039, -0.016),
    ], dtype=float)
    c = outline.mean(axis=0)
    _, _, vt = np.linalg.svd(outline - c)
    normal = vt[2] if vt[2][0] < 0 else -vt[2]  # posterior side: -x
    return outline, normal


def scapula() -> trimesh.Trimesh:
    """Scapula (world frame): blade, spine and acromion over the head, glenoid cup, coracoid process."""
    S = A.SCAPULA
    outline_pts, normal = _blade_frame()
    outline = _spline(outline_pts, 56, closed=True)
    centre = outline_pts.mean(axis=0)
    fr = np.linspace(0.18, 1.0, 7)
    half = 0.0012 + 0.0016 * (1 - fr**2)  # half-thickness, thinning to the rim
    ring = centre + fr[:, None, None] * (outline[None] - centre)
    # concave anterior surface: bow the plate posteriorly towards its centre (it rides on the rib cage)
    bow = (0.0025 * (1 - fr**2))[:, None, None] * normal
    blade = _plate(ring + bow + half[:, None, None] * normal, ring + bow - half[:, None, None] * normal,
                   centre + 0.0053 * normal, centre - 0.0003 * normal)
    # thicker lateral (axillary) border
    lat_border = _tube(_spline([(-0.015, -0.041, -0.012), (-0.024, -0.050, -0.060), (-0.040, -0.066, -0.108)], 14),
                       0.0035, 0.0030, normal, sides=10)

    # glenoid: spherical shell concentric with the head; concave face at r_in, back at r_out
    axis = _unit(np.asarray(A.GLENOID_CENTRE, dtype=float))
    e_sup = _unit(np.array([0.0, 0.0, 1.0]) - axis[2] * axis)
    e_ant = np.cross(e_sup, axis)
    k, j = 6, 32
    fr = np.linspace(1.0 / k, 1.0, k)
    ang = np.linspace(0.0, 2 * np.pi, j, endpoint=False)
    half_sup, half_ant = np.radians(40.0), np.radians(27.0)
    # pear shape: wider below the equator
    widen = 1.0 + 0.18 * (np.sin(ang) < 0) * -np.sin(ang)
    ts = np.tan(fr[:, None] * half_sup * np.sin(ang)[None])
    ta = np.tan(fr[:, None] * half_ant * widen[None] * np.cos(ang)[None])
    dirs = _unit(axis + ts[..., None] * e_sup + ta[..., None] * e_ant)
    r_in = A.HUMERAL_HEAD_RADIUS + 0.0025
    r_out = (0.0335 - 0.0045 * fr**2)[:, None, None]
    glenoid = _plate(r_out * dirs, r_in * dirs, 0.0335 * axis, r_in * axis)
    neck = _tube([0.036 * axis + (-0.001, 0.0, -0.002), (-0.011, -0.042, -0.002), (-0.018, -0.050, -0.004)],
                 [0.0125, 0.0105, 0.008], [0.0065, 0.0055, 0.004], (0.0, 0.0, 1.0), sides=12)

    # spine -> acromion: upright ridge on the posterior face turning into a flat plate above the head
    root = np.asarray(S["medial_spine_root"], dtype=float)
    spine_ctrl = np.array([root + 0.002 * normal, (-0.058, -0.080, 0.019) + 0.004 * normal,
                           (-0.046, -0.050, 0.030) + 0.005 * normal, (-0.036, -0.020, 0.039),
                           (-0.020, 0.010, 0.043), (-0.004, 0.027, 0.043), S["acromion_tip"]])
    path = _spline(spine_ctrl, 30)
    s = np.linspace(0.0, 1.0, len(path))
    w = np.clip((s - 0.40) / 0.25, 0.0, 1.0)[:, None]  # 0 on the spine, 1 on the acromion
    hints = _unit((1 - w) * normal + w * np.array([0.0, 0.0, 1.0]))
    a = (1 - w[:, 0]) * 0.0085 + w[:, 0] * 0.0035
    b = (1 - w[:, 0]) * 0.0035 + w[:, 0] * np.interp(s, [0.6, 0.85, 1.0], [0.009, 0.011, 0.008])
    spine = _tube(path, a, b, hints, sides=14)

    coracoid = _tube(_spline([(-0.012, -0.045, 0.016), (-0.005, -0.041, 0.026), (0.010, -0.034, 0.027),
                              (0.025, -0.022, 0.024), S["coracoid_tip"]], 16),
                     np.interp(np.linspace(0.0, 1.0, 16), [0.0, 0.5, 1.0], [0.0075, 0.0055, 0.0048]), 0.006,
                     (0.0, 0.0, 1.0), sides=12)
    return _join([blade, lat_border, glenoid, neck, spine, coracoid])


def clavicle() -> trimesh.Trimesh:
    """Clavicle (world frame): S-shaped tube from the sternal to the acromial end."""
    s_end = np.asarray(A.CLAVICLE["sternal_end"], dtype=float)
    a_end = np.asarray(A.CLAVICLE["acromial_end"], dtype=float)
    t = np.linspace(0.0, 1.0, 9)
    # anterior bow on the medial 60 %, posterior bow laterally; a slight upward arch
    dx = np.where(t < 0.6, 0.012 * np.sin(np.pi * t / 0.6), -0.010 * np.sin(np.pi * (t - 0.6) / 0.4))
    dz = 0.006 * np.sin(np.pi * t)
    ctrl = s_end + t[:, None] * (a_end - s_end) + np.column_stack([dx, np.zeros_like(t), dz])
    path = _spline(ctrl, 32)
    u = np.linspace(0.0, 1.0, len(path))
    a = np.interp(u, [0.0, 0.15, 0.5, 0.8, 1.0], [0.0095, 0.0075, 0.0062, 0.0052, 0.0048])  # vertical
    b = np.interp(u, [0.0, 0.15, 0.5, 0.8, 1.0], [0.0090, 0.0072, 0.0065, 0.0085, 0.0100])  # horizontal
    return _tube(path, a, b, (0.0, 0.0, 1.0), sides=14, end_rings=3)


def thorax() -> trimesh.Trimesh:
    """Rib-cage section (world frame): right-half rib bands on the THORAX ellipsoid, sternum, vertebral column."""
    c = np.asarray(A.THORAX["centre"], dtype=float)
    rad = np.asarray(A.THORAX["radii"], dtype=float)
    inset = 0.965  # centre lines just inside the ellipsoid so the bands sit on its surface

    def surface(phi: np.ndarray, z: np.ndarray) -> np.ndarray:
        # phi: 0 lateral (+y), +pi/2 anterior (+x), -pi/2 posterior (-x)
        s = np.sqrt(np.clip(1.0 - ((z - c[2]) / rad[2]) ** 2, 0.0, 1.0)) * inset
        return np.column_stack([c[0] + rad[0] * s * np.sin(phi), c[1] + rad[1] * s * np.cos(phi), z])

    parts = []
    phi = np.linspace(np.radians(-100.0), np.radians(80.0), 30)
    u = (phi - phi[0]) / (phi[-1] - phi[0])
    for k in range(8):
        z_post = 0.040 - 0.042 * k
        z = z_post - (0.05 + 0.004 * k) * u**1.3  # ribs descend from the spine to the front
        path = surface(phi, z)
        normals = _unit((path - c) / rad**2)
        width = 0.0048 + 0.0012 * min(k, 4) / 4
        parts.append(_tube(path, 0.0030, width, normals, sides=8, end_rings=1))
    zs = np.linspace(0.005, -0.215, 10)
    sternum_path = surface(np.full_like(zs, np.pi / 2), zs) + (0.004, 0.0, 0.0)
    parts.append(_tube(sternum_path, 0.0045, np.interp(zs, [-0.215, -0.05, 0.005], [0.010, 0.012, 0.018]),
                       (1.0, 0.0, 0.0), sides=10, end_rings=1))
    zv = np.linspace(0.06, -0.30, 12)
    spine_path = np.column_stack([np.full_like(zv, c[0] - 0.088), np.full_like(zv, c[1]), zv])
    parts.append(_tube(spine_path, 0.012, 0.011, (1.0, 0.0, 0.0), sides=12, end_rings=1))
    return _join(parts)


BUILDERS = {"humerus": humerus, "scapula": scapula, "clavicle": clavicle, "thorax": thorax}


def build_bone_meshes(out_dir: Path | str) -> dict[str, Path]:
    """Build the four bone meshes and write them as binary STL files into `out_dir`; returns name -> path."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = {}
    for name in ASSET_NAMES:
        path = out / f"{name}.stl"
        path.write_bytes(trimesh.exchange.stl.export_stl(BUILDERS[name]()))
        paths[name] = path
    return paths


if __name__ == "__main__":
    for name, p in build_bone_meshes(MODELS_DIR / "assets").items():
        print(f"{name}: {p} ({p.stat().st_size} bytes)")
