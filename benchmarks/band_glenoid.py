"""Where a taut band touches the humeral head against where the glenoid is: do isp's and ssc's bands, where they roll
over the head, pass between the head and the glenoid? (docs/fem.md "Where isp's and ssc's bands roll")

    .venv/bin/python benchmarks/band_glenoid.py [--tendon T] [--line COORD A B START STOP STEP] [--at P E R ...]
        [--scapula scapula.vtp] [--glenoid]                                                  (a second a pose)

The glenoid's axis: from the head's centre towards the trigonum spinae, the line glenoid version is measured against
(Friedman RJ, Hawthorne KB, Genez BM. The use of computerized tomography in the measurement of glenoid version. J Bone
Joint Surg Am 1992;74(7):1032), in 3-D: by that method the glenoid face lies within a few degrees of normal to it in the
axial plane (version -0.5 +- 3 deg over 65 scapulae, Orthop J Sports Med 2022, doi:10.1177/23259671221083589); its
tilt (inclination, 8.4 deg on average over 19 donors by 3-D CT, BMC Musculoskelet Disord 2021,
doi:10.1186/s12891-021-04660-4) is not taken, small beside the glenoid's 37-53 deg of arc. The trigonum
spinae stands in as the most medial vertex of the MoBL-ARMS parent's scapula surface (scapula.vtp of osim-rl 3.0.11,
in the scapula body's frame; `--scapula PATH` recomputes it and prints how far the surface lies from the joint centre
along the axis: `pip download osim-rl==3.0.11 --no-deps` as models/reference/scripts/humeral_head.py says): a proxy,
not a landmark the mesh labels. The glenoid's size on the head: 39 mm high and 29 mm wide (Iannotti JP et al. The
normal glenohumeral relationships. J Bone Joint Surg Am 1992;74(4):491, 140 shoulders), i.e. about 53 deg and 37 deg
of arc from its centre on the 24.3 mm head sphere.

Each pose: the band solved as its table solves it (`FootprintSheet`, the table's contact surface, rest="pose", the
ramp at a = 1), its moment arms and the MJCF path's (plane, elevation, rotation; mm), its tension, and of its nodes
touching the head sphere (within 1 mm) the least angle from the glenoid axis (deg, from the head's centre) and how
many lie inside the glenoid's outline (`glenoid_contact`): there the band lies between the head and the glenoid.
Last, where the band's origin line lies against the glenoid axis. With --glenoid the band has the glenoid as a second
contact (`footprint_glenoid.GlenoidSheet`, a study option). With --scapula, each pose also counts the band's nodes
inside the parent's scapula surface (`inside_bone`: its generalised winding number above 1/2, Jacobson, Kavan and
Sorkine-Hornung 2013, ACM TOG 32(4):33, which needs no closed mesh; the parent's is not closed) and the rows (from the
origin, 0) and fibres they lie on, and the deepest one's distance to the surface: where the band passes through the
bone the solve leaves open.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import trimesh

from shoulder_bench.authoring.fem import bands
from shoulder_bench.authoring.fem.footprint import HUMERAL_HEAD, FootprintSheet
from shoulder_bench.authoring.fem.footprint_glenoid import HALF_ARCS_DEG, MEDIAL_VERTEX_M, GlenoidSheet, glenoid_axis
from shoulder_bench.authoring.fem.solver import NoConvergence

TOUCH_M = 0.001


def scapula_vertices(path: str) -> np.ndarray:
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "models" / "reference" / "scripts"))
    from humeral_head import vertices

    return vertices(path)


def scapula_triangles(path: str) -> np.ndarray:
    """The surface's triangles (T, 3, 3), in the scapula body's frame (m)."""
    x = scapula_vertices(path)  # puts models/reference/scripts on the path
    from humeral_cap import triangles

    return triangles(path, x)


def inside_bone(tri: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Whether each point (P, 3) lies inside the surface `tri`: its generalised winding number (the triangles' signed
    solid angles at the point over 4 pi; van Oosterom and Strackee's formula) above 1/2 in magnitude."""
    out = np.empty(len(points), bool)
    for i, q in enumerate(points):
        a, b, c = (tri[:, k] - q for k in range(3))
        la, lb, lc = (np.linalg.norm(v, axis=1) for v in (a, b, c))
        den = (la * lb * lc + np.einsum("ij,ij->i", a, b) * lc + np.einsum("ij,ij->i", b, c) * la
               + np.einsum("ij,ij->i", c, a) * lb)
        out[i] = abs(2.0 * np.arctan2(np.einsum("ij,ij->i", a, np.cross(b, c)), den).sum()) > 2.0 * np.pi
    return out


def glenoid_face(x: np.ndarray, joint: np.ndarray, axis: np.ndarray) -> list[tuple[int, float, float]]:
    """The scapula surface's vertices nearer than 45 mm to the joint centre, in rings of 15 deg round the glenoid axis
    (0-15, 15-30, 30-45, 45-60): (count, nearest, farthest distance from the joint centre in mm) per ring."""
    rel = x - joint
    dist = np.linalg.norm(rel, axis=1)
    angle = np.degrees(np.arccos(np.clip(rel @ axis / dist, -1.0, 1.0)))
    out = []
    for lo in (0, 15, 30, 45):
        d = dist[(angle >= lo) & (angle < lo + 15) & (dist < 0.045)] * 1e3
        out.append((len(d), float(d.min()) if len(d) else float("nan"), float(d.max()) if len(d) else float("nan")))
    return out


def glenoid_contact(sheet: FootprintSheet, nodes: np.ndarray, axis_scapula: np.ndarray, arcs) -> tuple[float, int, int]:
    """The band's nodes touching the head sphere (within TOUCH_M) against the glenoid: their least angle from its
    axis (deg), how many lie inside its outline (an ellipse of half-arcs `arcs`, deg, its height along the scapula
    frame's y made normal to the axis: the glenoid's long axis taken as the scapula's vertical), and how many touch."""
    humerus, scapula = sheet.m.body("humerus").id, sheet.m.body("scapula").id
    centre = sheet.d.xpos[humerus] + sheet.d.xmat[humerus].reshape(3, 3) @ np.asarray(HUMERAL_HEAD["centre_m"])
    rot = sheet.d.xmat[scapula].reshape(3, 3)
    axis = rot @ axis_scapula
    high = rot[:, 1] - (rot[:, 1] @ axis) * axis
    high /= np.linalg.norm(high)
    wide = np.cross(axis, high)
    rel = nodes.reshape(-1, 3) - centre
    dist = np.linalg.norm(rel, axis=1)
    u = rel[dist < HUMERAL_HEAD["radius_m"] + TOUCH_M]
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    if not len(u):
        return float("nan"), 0, 0
    along = u @ axis
    angle = np.degrees(np.arccos(np.clip(along, -1.0, 1.0)))
    t_high, t_wide = np.degrees(np.arctan2(u @ high, along)), np.degrees(np.arctan2(u @ wide, along))
    inside = (along > 0) & ((t_high / arcs[0]) ** 2 + (t_wide / arcs[1]) ** 2 < 1.0)
    return float(angle.min()), int(inside.sum()), len(u)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tendon", default="ssc", choices=bands.FOOTPRINT_TENDONS)
    ap.add_argument("--line", nargs=6, default=["plane", "100", "-30", "0", "90", "7.5"],
                    metavar=("COORD", "A", "B", "START", "STOP", "STEP"),
                    help="vary COORD (plane, elevation or rotation) from START to STOP by STEP, the other two at A, B "
                         "(in plane, elevation, rotation order); default: plane 0-90 at elevation 100, rotation -30")
    ap.add_argument("--at", nargs=3, type=float, action="append", metavar=("P", "E", "R"), help="poses instead")
    ap.add_argument("--scapula", help="scapula.vtp to take the medial vertex from (default: its stored value)")
    ap.add_argument("--glenoid", action="store_true",
                    help="solve the band with the glenoid as a second contact (footprint_glenoid.GlenoidSheet)")
    args = ap.parse_args(argv)
    kind = GlenoidSheet if args.glenoid else FootprintSheet
    sheet = kind(args.tendon, "full", surface=bands.surface(args.tendon), rest="pose")
    joint = sheet.m.body("scapphant").pos  # the glenohumeral joint centre in the scapula frame
    mesh = scapula_vertices(args.scapula) if args.scapula else None
    bone = scapula_triangles(args.scapula) if args.scapula else None
    medial = mesh[np.argmin(mesh[:, 2])] if mesh is not None else np.asarray(MEDIAL_VERTEX_M)
    axis = glenoid_axis(sheet.m, medial)
    if mesh is not None:
        rings = "; ".join(f"{15 * k}-{15 * k + 15} deg: {n} vertices, {lo:.1f}-{hi:.1f} mm"
                          for k, (n, lo, hi) in enumerate(glenoid_face(mesh, joint, axis)))
        print(f"the scapula surface within 45 mm of the joint centre, round the glenoid axis: {rings} from the joint "
              f"centre (the head sphere's radius {HUMERAL_HEAD['radius_m'] * 1e3:.1f} mm)")
    arcs = HALF_ARCS_DEG
    print(f"glenoid axis (scapula frame, towards the medial vertex {np.round(medial * 1e3, 1).tolist()} mm): "
          f"{np.round(axis, 3).tolist()}; the glenoid reaches {arcs[0]:.0f} deg (height) and {arcs[1]:.0f} deg (width) "
          "from its centre on the head")
    if args.at:
        poses = [tuple(p) for p in args.at]
    else:
        coord, a, b = args.line[0], float(args.line[1]), float(args.line[2])
        index = ("plane", "elevation", "rotation").index(coord)
        poses = []
        for v in np.arange(float(args.line[3]), float(args.line[4]) + 1e-9, float(args.line[5])):
            fixed = [a, b]
            fixed.insert(index, float(v))
            poses.append(tuple(fixed))
    also = " and the glenoid" if args.glenoid else ""
    print(f"{args.tendon} on {bands.SURFACE_TEXT[bands.surface(args.tendon)]}{also}; pose (deg) | band arms (mm) | "
          "MJCF arms (mm) | tension (N) | nodes on the head: least angle from the glenoid axis (deg), inside its "
          "outline / all")
    for pose in poses:
        try:
            sol = sheet.solve(pose)
        except NoConvergence:
            print(f"{list(pose)} | no equilibrium")
            continue
        least, inside, touching = glenoid_contact(sheet, sol["nodes"], axis, arcs)
        print(f"{list(pose)} | {np.round(sol['moment_arm_m'] * 1e3, 1).tolist()} | "
              f"{np.round(sheet.mjcf_moment_arm(pose) * 1e3, 1).tolist()} | {sol['tension_N']:.0f} | "
              f"{least:.0f}, {inside} / {touching}{'' if bone is None else in_bone(sheet, sol['nodes'], bone)}")
    angle, dist = origin_line(sheet, joint, axis)
    print(f"its origin line (the nodes fixed to the proximal bone): {np.round(angle, 0).tolist()} deg from the glenoid "
          f"axis, {np.round(dist, 1).tolist()} mm from the joint centre")
    if bone is not None:
        local = in_scapula_frame(sheet, sheet.boundary()["origin"])
        print(f"  against the scapula surface: {int(inside_bone(bone, local).sum())} of {len(local)} inside; "
              f"{np.round(surface_distance(bone, local) * 1e3, 1).tolist()} mm from it")


def in_scapula_frame(sheet: FootprintSheet, points: np.ndarray) -> np.ndarray:
    """(N, 3) `points` (world, m) in the scapula body's frame at the sheet's current pose."""
    scapula = sheet.m.body("scapula").id
    return (np.reshape(points, (-1, 3)) - sheet.d.xpos[scapula]) @ sheet.d.xmat[scapula].reshape(3, 3)


def surface_distance(tri: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Each point's distance to the surface `tri`'s nearest point (m)."""
    return np.array([np.linalg.norm(trimesh.triangles.closest_point(tri, np.repeat(q[None], len(tri), 0)) - q,
                                    axis=1).min() for q in points])


def in_bone(sheet: FootprintSheet, nodes: np.ndarray, tri: np.ndarray) -> str:
    """' | inside the scapula: N nodes, rows R0-R1, fibres F0-F1, at most D mm deep' for the solved band's nodes (rows
    from the origin; the depth: the distance to the surface's nearest point)."""
    local = in_scapula_frame(sheet, nodes)
    inside = np.flatnonzero(inside_bone(tri, local))
    if not len(inside):
        return " | inside the scapula: 0 nodes"
    rows, fibres = np.divmod(inside, sheet.nt)  # nodes: (ns nt, 3), fibre fastest
    depth = surface_distance(tri, local[inside]).max()
    return (f" | inside the scapula: {len(inside)} nodes, rows {rows.min()}-{rows.max()} of {sheet.ns}, fibres "
            f"{fibres.min()}-{fibres.max()} of {sheet.nt}, at most {depth * 1e3:.1f} mm deep")


def origin_line(sheet: FootprintSheet, joint: np.ndarray, axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The origin nodes' angles from the glenoid axis (deg) and distances from the joint centre (mm), in the scapula
    frame (they are fixed to the scapula: the same at every pose)."""
    local = in_scapula_frame(sheet, sheet.boundary()["origin"]) - joint
    dist = np.linalg.norm(local, axis=1)
    return np.degrees(np.arccos(np.clip(local @ axis / dist, -1.0, 1.0))), dist * 1e3


if __name__ == "__main__":
    main()
