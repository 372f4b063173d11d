"""Where the humerus' tendon insertions lie against the humeral head's articular cap, and how far the greater
tuberosity stands out of the head sphere: the geometry behind docs/fem.md "What remains of §2" (why the subscapularis'
band cannot press on the humeral head, and what a greater tuberosity would add for the middle deltoid's).

    python models/reference/scripts/humeral_cap.py /tmp/osim-rl-3.0.11/osim/models/Geometry/humerus.vtp \
        [--band isp --at 0 110 60 --at 0 120 60]

(humerus.vtp as `humeral_head.py` fetches it.) The head sphere is footprint.HUMERAL_HEAD (fitted by humeral_head.py).
Its articular part, a spherical cap, is placed from published proximal-humerus geometry, not fitted (the parent's mesh
has 309 vertices and no anatomical neck to fit): its pole along the head axis, at the inclination (the angle between
the head axis and the shaft axis, distally) and the retroversion (the head axis' angle behind the transepicondylar
axis, about the shaft) of each source; its edge, the anatomical neck, at the arc each source gives. The shaft axis
runs from the elbow (the mid-point of the mesh's most medial and most lateral distal vertices, the epicondyles) to the
head's centre. Sources:
- Iannotti JP, Gabriel JP, Schneck SL, Evans BG, Misra S. The normal glenohumeral relationships. J Bone Joint Surg Am
  1992;74(4):491 (140 shoulders): radius of curvature 24 mm, head thickness (the cap's height) 19 mm, so an arc of
  2 arccos((24 - 19) / 24) = 156 deg.
- Roberts SN, Foley AP, Swallow HM, Wallace WA, Coughlan DP. The geometry of the humeral head and the design of
  prostheses. J Bone Joint Surg Br 1991;73(4):647 (29 humeri): retroversion 21.4 deg.
- Zhang Y, et al. Study on geometry and morphology of proximal humerus in Northern Chinese population based on 3-D CT.
  J Orthop Surg Res 2023;18:1 (doi:10.1186/s13018-023-03504-2; 80 humeri): inclination 137.7 deg, coronal arc 151.8 deg.
- A 3-D study of 559 cadaveric humeri pairs (Three-dimensional measurement of humeral retroversion on a large academic
  cadaveric database): retroversion 39.9 deg (males), neck angle 137.7 deg; the upper end of the usual 25-35 deg.
Prints, for each tendon insertion site on the MJCF humerus, its distance outside the head sphere and its angle from
the pole under each geometry (inside the cap: less than half the arc), where the lesser tuberosity lies (the proximal
humerus' most anterior vertex: against the pole, the cap's edge and the subscapularis' MJCF site;
footprint.INSERTION_M), and the proximal humerus' most lateral vertices' distances outside the sphere (the greater
tuberosity). With --band TENDON and --at poses: that tendon's taut
band on the head sphere at each pose (`FootprintSheet(..., rest="pose").solve`: the ramp to a = 1, isp's table's rule;
dan's and dpo's tables keep the least-energy equilibrium, `bands.LEAST_ENERGY`), its moment arms and where it touches
the sphere (nodes within 0.1 mm of it), as angles from the pole: how much of the contact lies beyond the anatomical
neck, and where the parent's bone mesh lies along the rays from the head's centre through those nodes.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import mujoco
import numpy as np
from humeral_head import vertices

from shoulder_bench.authoring.fem import bands
from shoulder_bench.authoring.fem.footprint import HUMERAL_HEAD, FootprintSheet

ROOT = Path(__file__).resolve().parents[3]

# (label, inclination deg, retroversion deg, arc deg)
GEOMETRIES = (("Iannotti arc, Roberts retroversion, 3-D CT inclination", 137.7, 21.4, 156.0),
              ("3-D CT arc and inclination, Roberts retroversion", 137.7, 21.4, 151.8),
              ("3-D CT arc and inclination, 559-humeri retroversion", 137.7, 39.9, 151.8))
INSERTIONS = {"ssp": "SUPSP_SUPSP-P1", "isp": "INFSP_INFSP-P1", "ssc": "SUBSC_SUBSC-P1", "tmi": "TMIN_TMIN-P1",
              "dmi": "DELT2_DELT2-P1", "dan": "DELT1_DELT1-P1", "dpo": "DELT3_DELT3-P3"}


def frame(x: np.ndarray, centre: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(shaft axis towards the head, medial unit vector across it along the epicondyles, posterior unit vector)."""
    distal = x[x[:, 1] < x[:, 1].min() + 0.04]
    lateral, medial = distal[np.argmax(distal[:, 2])], distal[np.argmin(distal[:, 2])]
    shaft = centre - (lateral + medial) / 2
    shaft /= np.linalg.norm(shaft)
    across = medial - lateral
    across -= (across @ shaft) * shaft
    across /= np.linalg.norm(across)
    posterior = np.cross(shaft, across)
    return shaft, across, posterior if posterior[0] < 0 else -posterior  # the humerus frame's x is anterior


def pole_of(shaft, medial, posterior, inclination: float, retroversion: float) -> np.ndarray:
    """The head axis (unit, humerus frame) at `inclination` and `retroversion` (deg)."""
    up, back = np.radians(inclination - 90.0), np.radians(retroversion)
    return np.sin(up) * shaft + np.cos(up) * (np.cos(back) * medial + np.sin(back) * posterior)


def triangles(path: str, x: np.ndarray) -> np.ndarray:
    """The mesh's triangles (T, 3, 3): the <Polys> of the ASCII VTK PolyData file at `path` over its vertices `x`
    (`vertices(path)`)."""
    polys = open(path).read().split("<Polys>")[1]
    ids = {name: np.array(polys.split(f'Name="{name}"')[1].split(">", 1)[1].split("<")[0].split(), int)
           for name in ("connectivity", "offsets")}
    if not np.all(np.diff(np.r_[0, ids["offsets"]]) == 3):
        raise SystemExit(f"{path}: not a triangle mesh")
    return x[ids["connectivity"].reshape(-1, 3)]


def bone_along(tri: np.ndarray, origin: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """Distance from `origin` to the first mesh triangle along each unit direction (Moller-Trumbore; NaN: none).
    Written out because trimesh's ray queries need rtree, which the project does not install."""
    v0, e1, e2 = tri[:, 0], tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    out = np.full(len(directions), np.nan)
    for k, d in enumerate(directions):
        p = np.cross(d, e2)
        det = (e1 * p).sum(1)
        inv = np.divide(1.0, det, out=np.zeros_like(det), where=np.abs(det) > 1e-14)
        tv = origin - v0
        q = np.cross(tv, e1)
        u, w, t = (tv * p).sum(1) * inv, (q @ d) * inv, (e2 * q).sum(1) * inv
        hit = (inv != 0) & (u >= 0) & (w >= 0) & (u + w <= 1) & (t > 0)
        if hit.any():
            out[k] = t[hit].min()
    return out


def band_contact(tendon: str, poses, axes, tri: np.ndarray) -> None:
    """Print `tendon`'s band at each pose: moment arms, its contact with the head sphere against each pole, and how
    far the parent's bone surface lies from the sphere along the rays through the touching nodes (`tri`)."""
    if bands.surface(tendon) != "head":
        raise SystemExit(f"--band {tendon}: its band presses on {bands.SURFACE_TEXT[bands.surface(tendon)]}, not the "
                         f"head sphere (bands.SURFACE: {', '.join(bands.SURFACE)})")
    c, radius = np.asarray(HUMERAL_HEAD["centre_m"]), HUMERAL_HEAD["radius_m"]
    sheet = FootprintSheet(tendon, "full", surface="head", rest="pose")
    for pose in poses:
        sol = sheet.solve(pose)
        b = sheet.bodies["head"]  # the humerus, posed by the solve
        pos, rot = sheet.d.xpos[b], sheet.d.xmat[b].reshape(3, 3)
        local = (sol["nodes"].reshape(-1, 3) - pos) @ rot - c  # humerus frame, from the head's centre
        r = np.linalg.norm(local, axis=1)
        touching = r - radius < 1e-4
        print(f"{tendon} band at {list(pose)} deg: moment arms (plane, elevation, rotation) "
              f"{np.round(np.asarray(sol['moment_arm_m']) * 1e3, 1).tolist()} mm, tension {sol['tension_N']:.0f} N, "
              f"{touching.sum()} of {len(r)} nodes on the sphere")
        rays = local[touching] / r[touching, None]
        bone = (bone_along(tri, c, rays) - radius) * 1e3  # mm; negative: the bone lies inside the sphere
        for label, pole, arc in axes:
            angle = np.degrees(np.arccos(rays @ pole))
            beyond = angle > arc / 2
            print(f"  {label}: their angles from the pole {angle.min():.0f}-{angle.max():.0f} deg, "
                  f"{beyond.sum()} beyond the cap's edge at {arc / 2:.1f} deg; the bone mesh along their rays, from "
                  f"the sphere: {_span(bone[~beyond])} mm on the cap, {_span(bone[beyond])} mm beyond it")


def _span(values: np.ndarray) -> str:
    values = values[np.isfinite(values)]
    return f"{values.min():+.1f} to {values.max():+.1f} (median {np.median(values):+.1f})" if len(values) else "none"


def main(path: str, tendon: str | None = None, poses=()) -> None:
    x = vertices(path)
    c, radius = np.asarray(HUMERAL_HEAD["centre_m"]), HUMERAL_HEAD["radius_m"]
    shaft, medial, posterior = frame(x, c)
    if tendon is not None:
        band_contact(tendon, poses, [(label, pole_of(shaft, medial, posterior, i, r), arc)
                                     for label, i, r, arc in GEOMETRIES], triangles(path, x))
        return
    m = mujoco.MjModel.from_xml_path(str(ROOT / "models" / "shoulder_full_task.xml"))
    sites = {t: m.site_pos[m.site(s).id] - c for t, s in INSERTIONS.items()}
    print(f"head sphere: radius {radius * 1e3:.2f} mm; shaft axis {np.round(shaft, 3).tolist()} (humerus frame)")
    print("insertion site: outside the sphere (mm) " + " ".join(f"{t} {(np.linalg.norm(v) - radius) * 1e3:+.1f}"
                                                               for t, v in sites.items()))
    for label, inclination, retroversion, arc in GEOMETRIES:
        pole = pole_of(shaft, medial, posterior, inclination, retroversion)
        angle = {t: np.degrees(np.arccos(v @ pole / np.linalg.norm(v))) for t, v in sites.items()}
        inside = [t for t, a in angle.items() if a < arc / 2 and np.linalg.norm(sites[t]) < radius]
        print(f"{label} (inclination {inclination}, retroversion {retroversion}, arc {arc} deg): pole "
              f"{np.round(pole, 3).tolist()}; angle from the pole (deg) "
              + " ".join(f"{t} {a:.0f}" for t, a in angle.items())
              + f"; inside the sphere and within the cap: {', '.join(inside) or 'none'}")
    v = x - c
    proximal = x[np.linalg.norm(v, axis=1) < 0.035]
    lesser = proximal[np.argmax(proximal[:, 0])] - c  # the humerus frame's x is anterior
    u = lesser / np.linalg.norm(lesser)
    poles = [np.degrees(np.arccos(u @ pole_of(shaft, medial, posterior, i, r))) for _, i, r, _ in GEOMETRIES]
    beyond = [np.radians(a - arc / 2) * radius * 1e3 for a, (_, _, _, arc) in zip(poles, GEOMETRIES)]
    to_site = np.degrees(np.arccos(u @ sites["ssc"] / np.linalg.norm(sites["ssc"])))
    print(f"the lesser tuberosity (the most anterior vertex within 35 mm of the head's centre): "
          f"{np.round(lesser + c, 6).tolist()} m (humerus frame), {(np.linalg.norm(lesser) - radius) * 1e3:+.1f} mm "
          f"outside the sphere; from the pole {', '.join(f'{a:.0f}' for a in poles)} deg under the geometries above, "
          f"beyond the cap's edge by {', '.join(f'{b:.1f}' for b in beyond)} mm along the sphere; {to_site:.0f} deg "
          f"({np.radians(to_site) * radius * 1e3:.1f} mm along the sphere) from the ssc site")
    lateral = proximal[np.argsort(-proximal[:, 2])[:6]]
    print("the 6 most lateral vertices within 35 mm of the head's centre (the greater tuberosity): outside the sphere "
          f"(mm) {', '.join(f'{(np.linalg.norm(p - c) - radius) * 1e3:+.1f}' for p in lateral)}; lateral coordinate "
          f"(mm) {', '.join(f'{p[2] * 1e3:.1f}' for p in lateral)}; the sphere's lateral extreme "
          f"{(c[2] + radius) * 1e3:.1f} mm")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("humerus", help="the parent's humerus.vtp")
    parser.add_argument("--band", default=None, help="a tendon whose band presses on the head sphere (e.g. isp)")
    parser.add_argument("--at", nargs=3, type=float, action="append", default=[], metavar=("PLANE", "ELV", "ROT"),
                        help="a pose (deg) for --band; repeatable")
    args = parser.parse_args()
    if (args.band is None) != (not args.at):
        parser.error("--band and --at go together")
    main(args.humerus, args.band, args.at)
