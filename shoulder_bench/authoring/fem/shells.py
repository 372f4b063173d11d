"""Muscle sheets: one fibre membrane per muscle, generated deterministically from `anatomy`.

Each sheet spans the muscle's free part, from its last fixed site (where the MJCF tendon leaves the scapula or thorax;
the part of the muscle proximal to it lies on the bone and has constant length, so it changes neither the MJCF
moment arm nor, here, the forces) to its humerus insertion. A fibre runs from a point of the origin line to a point
of the insertion line; both lines are centred on the MJCF sites and point along n = P x Q (P: last fixed site, Q:
insertion; the normal of the plane through the joint centre that the MJCF wrap lies in). Every fibre follows the
shortest path in its own plane through the joint centre: straight, or tangent-arc-tangent over the humeral head
sphere, as MuJoCo wraps a tendon. So the sheet is draped over the head for ssp, isp and dmi when the line of
action would pass through it.

Thickness: effective (pennation folded in) and per element, h = PCSA / w(s) with PCSA = F0 / sigma_max and w(s) the
sheet width at the element's position along the fibres, so that thickness x width x sigma_max = F0 at every
cross-section.

Reference (stress-free, fibres at optimal length) configuration: the sheet as generated at `theta_ref`, the grid
angle at which the free length L of the central fibre is closest to max(sqrt(L_min L_max), L_max / 1.15): the
stretch range is centred (lambda_max = 1 / lambda_min) unless that would stretch the fibres beyond 1.15 at the end of
the joint range, where the passive force (0.08 F0 at 1.15, 0.31 F0 at 1.3) would hold the arm up or down at rest.
"""
from __future__ import annotations

import hashlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from shoulder_bench.authoring import anatomy
from shoulder_bench.authoring.fem import quantised
from shoulder_bench.authoring.fem.material import Blemker

R_HEAD = anatomy.HUMERAL_HEAD_RADIUS


@dataclass(frozen=True)
class SheetSpec:
    origin_width: float  # m, across the fibres at the origin line
    insertion_width: float  # m, at the insertion


SHEETS = {
    "ssp": SheetSpec(0.035, 0.020),
    "isp": SheetSpec(0.060, 0.025),
    "dmi": SheetSpec(0.050, 0.020),
    "ld": SheetSpec(0.080, 0.030),
}
RESOLUTION = {"full": (41, 11), "coarse": (21, 6)}  # nodes along the fibres, across
MAX_STRETCH = 1.15  # longest fibre stretch over the joint range (passive force 0.08 F0)
GRID_DEG = np.arange(anatomy.JOINT_RANGE_DEG[0], anatomy.JOINT_RANGE_DEG[1] + 1e-9, 5.0)


def rot_x(theta_deg: float) -> np.ndarray:
    c, s = np.cos(np.radians(theta_deg)), np.sin(np.radians(theta_deg))
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def wrap_path(p: np.ndarray, q: np.ndarray, n: int, radius: float = R_HEAD) -> tuple[np.ndarray, float]:
    """n points equally spaced in arc length along the shortest p -> q path around the sphere (centre 0, radius)
    in the plane through 0, p and q; also returns the length."""
    rp, rq = np.linalg.norm(p), np.linalg.norm(q)
    u = p / rp
    v = q - (q @ u) * u
    v /= np.linalg.norm(v)
    phi_q = np.arctan2(q @ v, q @ u)
    a_p, a_q = np.arccos(radius / rp), np.arccos(radius / rq)
    s = np.linspace(0.0, 1.0, n)
    if a_p + a_q >= phi_q:  # the straight segment clears the sphere
        return p + s[:, None] * (q - p), float(np.linalg.norm(q - p))
    t1 = radius * (np.cos(a_p) * u + np.sin(a_p) * v)
    t2 = radius * (np.cos(phi_q - a_q) * u + np.sin(phi_q - a_q) * v)
    l1, l3 = np.sqrt(rp**2 - radius**2), np.sqrt(rq**2 - radius**2)
    l2 = radius * (phi_q - a_q - a_p)
    total = l1 + l2 + l3
    d = s * total
    out = np.empty((n, 3))
    seg1, seg2 = d <= l1, (d > l1) & (d < l1 + l2)
    seg3 = ~(seg1 | seg2)
    out[seg1] = p + (d[seg1] / l1)[:, None] * (t1 - p)
    ang = a_p + (d[seg2] - l1) / radius
    out[seg2] = radius * (1.0 + 1e-9) * (np.cos(ang)[:, None] * u + np.sin(ang)[:, None] * v)
    out[seg3] = t2 + ((d[seg3] - l1 - l2) / l3)[:, None] * (q - t2)
    return out, float(total)


def _ends(muscle: str, theta_deg: float):
    path = anatomy.PATHS[muscle]
    return np.asarray(path["fixed"][-1], float), rot_x(theta_deg) @ np.asarray(path["insertion"], float)


def free_length(muscle: str, theta_deg: float) -> float:
    p, q = _ends(muscle, theta_deg)
    if anatomy.PATHS[muscle]["wrap_side"] is None:
        return float(np.linalg.norm(q - p))
    return wrap_path(p, q, 2)[1]


def reference_angle(muscle: str) -> float:
    """Grid angle at which the central fibre is at optimal length (see the module docstring)."""
    lengths = np.array([free_length(muscle, t) for t in GRID_DEG])
    target = max(np.sqrt(lengths.min() * lengths.max()), lengths.max() / MAX_STRETCH)
    return float(GRID_DEG[np.argmin(np.abs(lengths - target))])


def grid_triangles(ns: int, nt: int) -> np.ndarray:
    idx = np.arange(ns * nt).reshape(ns, nt)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    return np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])


def build_shell(muscle: str, resolution: str | tuple[int, int] = "full") -> dict:
    """The sheet of `muscle` as a dict of arrays (the content of models/muscles/<muscle>_shell.npz).

    resolution: "full", "coarse" or (nodes along the fibres, nodes across)."""
    if muscle not in anatomy.MUSCLES:
        raise ValueError(f"unknown muscle {muscle!r}; valid names: {', '.join(anatomy.MUSCLES)}")
    ns, nt = RESOLUTION[resolution] if isinstance(resolution, str) else resolution
    spec = SHEETS[muscle]
    theta_ref = reference_angle(muscle)
    p0, q0 = _ends(muscle, theta_ref)
    n_hat = np.cross(p0, q0)
    n_hat /= np.linalg.norm(n_hat)
    wraps = anatomy.PATHS[muscle]["wrap_side"] is not None
    t = np.linspace(-0.5, 0.5, nt)
    nodes = np.empty((ns, nt, 3))
    for j, tj in enumerate(t):
        p, q = p0 + tj * spec.origin_width * n_hat, q0 + tj * spec.insertion_width * n_hat
        nodes[:, j] = wrap_path(p, q, ns)[0] if wraps else p + np.linspace(0, 1, ns)[:, None] * (q - p)
    s = np.linspace(0.0, 1.0, ns)
    st = np.stack(np.meshgrid(s, t, indexing="ij"), axis=-1).reshape(-1, 2)
    nodes = nodes.reshape(-1, 3)
    tri = grid_triangles(ns, nt)
    # fibre = d x / d s in each element (the direction along lines of constant t)
    ds = np.stack([nodes[tri[:, 1]] - nodes[tri[:, 0]], nodes[tri[:, 2]] - nodes[tri[:, 0]]], axis=2)
    dst = np.stack([st[tri[:, 1]] - st[tri[:, 0]], st[tri[:, 2]] - st[tri[:, 0]]], axis=2)
    jac = ds @ np.linalg.inv(dst)
    fibres = jac[:, :, 0] / np.linalg.norm(jac[:, :, 0], axis=1, keepdims=True)
    # width of each row of nodes (polyline across the sheet), interpolated to element centroids
    grid = nodes.reshape(ns, nt, 3)
    row_width = np.linalg.norm(np.diff(grid, axis=1), axis=2).sum(1)
    s_elem = st[tri, 0].mean(1)
    width = np.interp(s_elem, s, row_width)
    pcsa = anatomy.F0[muscle] / Blemker().sigma_max
    idx = np.arange(ns * nt).reshape(ns, nt)
    return {
        "muscle": np.array(muscle),
        "nodes": nodes,
        "triangles": tri.astype(np.int64),
        "fibres": fibres,
        "thickness": pcsa / width,
        "origin_nodes": idx[0].astype(np.int64),
        "insertion_nodes": idx[-1].astype(np.int64),
        "theta_ref_deg": np.array(theta_ref),
        "st": st,
        "resolution": np.array([ns, nt], dtype=np.int64),
    }


def mesh_sha256(shell: dict) -> str:
    """SHA-256 of the mesh after rounding its floats to HASH_QUANTUM (shoulder_bench.authoring.fem): the same on every
    CPU."""
    h = hashlib.sha256()
    for key in ("nodes", "triangles", "fibres", "thickness", "origin_nodes", "insertion_nodes", "theta_ref_deg"):
        a = quantised(shell[key])
        h.update(key.encode() + str(a.shape).encode())
        h.update(a.tobytes())
    return h.hexdigest()


def shell_path(muscle: str, folder: Path | None = None) -> Path:
    from shoulder_bench.model import MODELS_DIR

    return Path(folder or MODELS_DIR / "muscles") / f"{muscle}_shell.npz"


def save_shell(shell: dict, path: Path) -> None:
    from shoulder_bench.muscle import replacing

    with replacing(path) as tmp:
        np.savez(tmp, **shell)


def load_shell(path: Path) -> dict:
    with np.load(path, allow_pickle=False) as z:
        return {k: z[k] for k in z.files}


def force_check(shell: dict) -> float:
    """sigma_max x sum(thickness x width) across the middle strip of elements, N (equals F0 by construction)."""
    ns = int(shell["resolution"][0])
    s = np.linspace(0.0, 1.0, ns)
    i = (ns - 1) // 2
    s_nodes = shell["st"][shell["triangles"], 0]
    strip = np.all((s_nodes > s[i] - 1e-12) & (s_nodes < s[i + 1] + 1e-12), axis=1)
    x = shell["nodes"][shell["triangles"][strip]]
    area = 0.5 * np.linalg.norm(np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]), axis=1)
    grid = shell["nodes"].reshape(ns, -1, 3)
    ds = float(np.linalg.norm(grid[i + 1] - grid[i], axis=1).mean())
    return float(Blemker().sigma_max * np.sum(area * shell["thickness"][strip]) / ds)
