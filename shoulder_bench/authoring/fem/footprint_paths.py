"""Where a footprint sheet runs (`footprint`): a tendon's free part in the MJCF model and MuJoCo's wrapped path of a
fibre over a sphere or cylinder, side site included (the rule of MuJoCo's engine_util_misc `mju_wrap`, written in
numpy for many fibres and any end points; the central fibre's length equals MuJoCo's tendon length less a constant,
tests/test_footprint.py)."""
from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np


@dataclass(frozen=True)
class FreePart:
    """Where a tendon's free part runs in the model: proximal site P, humerus site Q, optional wrap object."""

    tendon: str
    origin_site: int
    insertion_site: int
    wrap: int | None  # geom id of the wrap sphere or cylinder, or None (straight)
    sidesite: int | None  # the wrap's side site, if any
    inside: bool = False  # the side site lies inside the object (MuJoCo's inside wrapping, which no sheet follows)
    # the sites from P on where the path runs on over a second proximal bone in straight segments (dan: scapula, then
    # clavicle; ld1-3: scapula, then thorax): their length changes with the girdle, and each pulls on its bones as
    # MuJoCo's tendon does; () where the path beyond P stays on P's bone (a constant length)
    beyond: tuple[int, ...] = ()


def path_items(m: mujoco.MjModel, tendon: str) -> list[tuple[int, int, float]]:
    """The tendon's path as (mjtWrap type, object id, wrap_prm: a wrap's side site or -1) in model order."""
    t = m.tendon(tendon).id
    span = range(m.tendon_adr[t], m.tendon_adr[t] + m.tendon_num[t])
    return [(int(m.wrap_type[w]), int(m.wrap_objid[w]), float(m.wrap_prm[w])) for w in span]


def free_part(m: mujoco.MjModel, tendon: str) -> FreePart:
    """The tendon's free part: from its last humerus site Q (the sites and wraps before it, on the humerus, have a
    constant length) to the next site P on the proximal bone, with the sphere or cylinder between them, if any; the
    path may be written from either end. Where the path goes on over a second proximal bone (its length beyond P
    changes with the girdle) in straight segments between sites, those sites are `beyond`; refused where it wraps an
    object there, or where the free part wraps more than one object. A wrap whose side site lies inside the object
    (MuJoCo's inside wrapping, which `wrap_geodesic` does not do) is marked `inside`."""
    hum = m.body("humerus").id
    site = int(mujoco.mjtWrap.mjWRAP_SITE)
    items = path_items(m, tendon)

    def body(item):
        return int(m.site_bodyid[item[1]] if item[0] == site else m.geom_bodyid[item[1]])

    if body(items[0]) != hum:
        items = items[::-1]
    if body(items[0]) != hum:
        raise ValueError(f"{tendon}: neither end of its path is on the humerus")
    k = next(i for i, it in enumerate(items) if it[0] == site and body(it) != hum)  # P
    j = max(i for i in range(k) if items[i][0] == site)  # Q
    if any(body(it) != hum for it in items[:j + 1]):
        raise ValueError(f"{tendon}: its path leaves the humerus before its last humerus site")
    beyond = ()
    if len({body(it) for it in items[k:]}) > 1:
        if any(it[0] != site for it in items[k:]):
            raise ValueError(f"{tendon}: its path goes on over a second proximal bone after its first and wraps an "
                             "object there (only straight segments beyond the free part are followed)")
        beyond = tuple(it[1] for it in items[k:])
    wraps = items[j + 1:k]
    if len(wraps) > 1:
        raise ValueError(f"{tendon}: its free part wraps {len(wraps)} objects, not one (no contact for that yet)")
    if not wraps:
        return FreePart(tendon, items[k][1], items[j][1], None, None, beyond=beyond)
    side, inside = int(wraps[0][2]), False
    if side >= 0:
        d = mujoco.MjData(m)
        mujoco.mj_kinematics(m, d)
        inside = bool(np.linalg.norm(d.site_xpos[side] - d.geom_xpos[wraps[0][1]]) < m.geom_size[wraps[0][1], 0])
    return FreePart(tendon, items[k][1], items[j][1], wraps[0][1], side if side >= 0 else None, inside, beyond)


def _segments_cross(a0, a1, b0, b1) -> bool:
    """Whether the 2-D segments a0-a1 and b0-b1 intersect."""
    da, db = a1 - a0, b1 - b0
    det = da[0] * db[1] - da[1] * db[0]
    if abs(det) < 1e-15:
        return False
    w = b0 - a0
    u, v = (w[0] * db[1] - w[1] * db[0]) / det, (w[0] * da[1] - w[1] * da[0]) / det
    return bool(0.0 <= u <= 1.0 and 0.0 <= v <= 1.0)


def wrap_geodesic(p, q, centre, radius: float, n: int, axis=None, side=None) -> tuple[np.ndarray, float]:
    """n points equally spaced along the shortest path from p to q around a sphere (axis None) or an infinite
    cylinder (unit `axis`) of `radius` about `centre`, on the side of the point `side` if given, as MuJoCo wraps:
    in the plane through the centre, p and q (sphere) or in the projection along the axis with the axial
    coordinate linear in the projected arc length (cylinder: a helix); straight where the segment clears the object
    (and, with a side point, passes on its side) or an end lies inside it. Returns (points (n, 3), length)."""
    p, q, c = (np.asarray(v, float) for v in (p, q, centre))
    a = np.zeros(3) if axis is None else np.asarray(axis, float) / np.linalg.norm(axis)
    pp, qq = p - c - ((p - c) @ a) * a, q - c - ((q - c) @ a) * a
    u = pp / np.linalg.norm(pp)
    v = qq - (qq @ u) * u
    v = v / np.linalg.norm(v) if np.linalg.norm(v) > 1e-12 else np.cross(a, u)
    p2, q2 = np.array([pp @ u, pp @ v]), np.array([qq @ u, qq @ v])
    zp, zq = (p - c) @ a, (q - c) @ a
    s = np.linspace(0.0, 1.0, n)
    seg = q2 - p2
    h = np.clip(-(p2 @ seg) / (seg @ seg), 0.0, 1.0)
    closest = p2 + h * seg
    s2 = None if side is None else np.array([(side - c) @ u, (side - c) @ v])
    clears = np.linalg.norm(closest) >= radius
    rp, rq = np.linalg.norm(p2), np.linalg.norm(q2)
    inside = min(rp, rq) < radius  # an end inside the object: MuJoCo does not wrap
    if inside or (clears and (s2 is None or closest @ s2 >= 0.0)):
        return p + s[:, None] * (q - p), float(np.linalg.norm(q - p))
    ap, aq = np.arccos(min(1.0, radius / rp)), np.arccos(min(1.0, radius / rq))
    tq = np.arctan2(q2[1], q2[0])
    side2 = None if s2 is None else radius * s2 / np.linalg.norm(s2)
    candidates = []
    for sign in (1.0, -1.0):  # leave p counter-clockwise, clockwise
        start, end = sign * ap, tq - sign * aq
        sweep = np.mod(sign * (end - start), 2 * np.pi)
        t1, t2 = radius * np.array([np.cos(start), np.sin(start)]), radius * np.array([np.cos(end), np.sin(end)])
        # MuJoCo's choice: the tangent pair whose chord midpoint points to the side site, else the closer pair;
        # a pair whose two straight pieces cross each other is out
        good = (t1 + t2) @ side2 / max(np.linalg.norm(t1 + t2), 1e-15) if side2 is not None else -np.sum((t1 - t2) ** 2)
        crossed = _segments_cross(p2, t1, q2, t2)
        candidates.append((-1e4 if crossed else good, crossed, sign, start, sweep))
    _, crossed, sign, start, sweep = max(candidates, key=lambda x: x[0])
    if crossed:  # MuJoCo does not wrap then
        return p + s[:, None] * (q - p), float(np.linalg.norm(q - p))
    l1, l3 = np.sqrt(max(rp**2 - radius**2, 0.0)), np.sqrt(max(rq**2 - radius**2, 0.0))
    l2 = radius * sweep
    planar = l1 + l2 + l3
    t1 = radius * np.array([np.cos(start), np.sin(start)])
    t2 = radius * np.array([np.cos(start + sign * sweep), np.sin(start + sign * sweep)])
    d = s * planar
    out2 = np.empty((n, 2))
    first, arc = d <= l1, (d > l1) & (d < l1 + l2)
    last = ~(first | arc)
    out2[first] = p2 + (d[first] / max(l1, 1e-15))[:, None] * (t1 - p2)
    ang = start + sign * (d[arc] - l1) / radius
    out2[arc] = radius * (1.0 + 1e-9) * np.stack([np.cos(ang), np.sin(ang)], 1)
    out2[last] = t2 + ((d[last] - l1 - l2) / max(l3, 1e-15))[:, None] * (q2 - t2)
    z = zp + s * (zq - zp)
    pts = c + out2[:, :1] * u + out2[:, 1:] * v + z[:, None] * a
    return pts, float(np.hypot(planar, zq - zp))
