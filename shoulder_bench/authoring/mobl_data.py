"""Reads the MoBL-ARMS shoulder (MyoArm's MuJoCo conversion) from the reference CSVs, for the v2 model.

The files are the package's copies in `models/reference/` of ../shared/reference/moment_arms (identical bytes; the
shared README documents how they were extracted from MyoHub/myo_sim @ 2cef885 and the OpenSim files):

- `muscle_parameters.csv`: `body_frame` rows (each body's pose in its parent), `path_point` rows (MuJoCo sites) and
  `wrap` rows (MuJoCo spheres/cylinders with their side sites) of model `myoarm`; the `mobl_opensim` clavicle
  `body_frame` row gives MoBL's sternoclavicular (SC) joint location in the thorax frame;
- `coordinate_definitions.csv`: hinge axes (in the child body's frame), order and ranges of the `myoarm` coordinates;
- `girdle_coupling.csv`: the `myoarm` joint-equality polynomials (dependent = c0 + c1 x + ... + c4 x^4, x = driver);
- `humerus_inertia.csv`: the `myoarm` humerus mass, COM and inertia tensor (MyoArm = the MoBL-ARMS parent's);
- `mobl_arms_parent_paths.csv`: the MoBL-ARMS parent's own path points and wrap objects (ours, extracted from its
  .osim, models/reference/README.md), for the muscles in `PATH_SOURCE` (ssp: the parent's SUPSP, whose one wrap
  object is an "ellipsoid" with three equal semi-axes, i.e. a sphere, so MuJoCo wraps it exactly).

Only the standard library is used (csv; gzip for a `.gz` file), plus a rotation for the MyoArm clavicle variant.
"""
from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

from shoulder_bench.authoring.references import REFERENCE_DIR, open_table

SOURCE = "myoarm"  # MyoArm's rows (MoBL-ARMS converted to MuJoCo; its spheres/cylinders stand in for ellipsoids)
CHAIN = ("thorax", "clavicle", "clavphant", "scapula", "scapphant", "humphant", "humphant1", "humerus")
# our tendon -> MyoArm muscle. LAT1-3 stay three bundles (ld1-3): each has its own thorax origin and scapular via
# point and wraps differently (LAT2's second wrap has no side site), so one line cannot reproduce them.
MUSCLES = {"ssp": "SUPSP", "isp": "INFSP", "dmi": "DELT2", "ld1": "LAT1", "ld2": "LAT2", "ld3": "LAT3"}
# Whose path each tendon takes (default MyoArm's). ssp takes the parent's: the reference README calls the parent's
# SUPSP clean (section 6.4) and our ssp follows it (references.FOLLOWS); MyoArm moved its scapular via point P2 by
# 27 mm (to the infraspinatus side) and its wrap sphere, so its SUPSP turns into a depressor above 64 deg where the
# parent's still elevates. The parent's SUPSP is three fixed points and one sphere: MuJoCo reproduces its moment arms
# over the whole 3-DOF grid within 0.07 mm (tests/test_mobl.py). isp, dmi and LAT1-3 keep MyoArm's: the parent's wrap
# INFSP over an ellipsoid (not a sphere) and moves DELT2's and LAT1-3's points with shoulder_elv, which fixed MuJoCo
# sites cannot.
# The full shoulder (issue 12, `models/shoulder_full.xml`, docs/model_full.md): the four plus nine MoBL-ARMS muscles.
# The parent's path is taken only where MuJoCo represents it exactly (`parent_path`); it refuses all nine
# (PARENT_REFUSED). Where it is refused, the tendon takes, of the two derived models' paths MuJoCo represents exactly
# (MyoArm's spheres and cylinders with side sites; the OpenSim file's fixed points, `opensim_path`), the one whose
# moment arms in our model are closer to the parent's over the reference grid (all three coordinates, both girdle
# modes; by RMSE and by median |difference|, which agree for every tendon; tests/test_mobl_full.py checks it).
# That is MyoArm's for all but pec1: MyoArm's PECM1 replaces the parent's two moving points by fixed sites and an
# elevator from 20-30 deg up in the coronal plane, where the parent and the OpenSim file adduct (docs/model_full.md).
PATH_SOURCE = {"ssp": "mobl_arms", "pec1": "mobl_opensim"}
FULL_MUSCLES = {**MUSCLES, "dan": "DELT1", "dpo": "DELT3", "ssc": "SUBSC", "tmi": "TMIN", "tma": "TMAJ",
                "pec1": "PECM1", "pec2": "PECM2", "pec3": "PECM3", "cor": "CORB"}
MUSCLE_SETS = {"v2": MUSCLES, "full": FULL_MUSCLES}
# Why the parent's own path of each added muscle is not representable (mobl_arms_parent_paths.csv): the item
# `parent_path` refuses first, and what else the path has that MuJoCo cannot do exactly.
PARENT_REFUSED = {
    "dan": "delt2hum is a finite cylinder; DELT1hh a true ellipsoid (0.03 0.1 0.05 m) on quadrant z",
    "dpo": "Delt3 is a WrapTorus; delt3hum a true ellipsoid on quadrant x",
    "ssc": "SUBSCAP is a true ellipsoid (0.02 0.017 0.028 m)",
    "tmi": "its wrap TMIN is a true ellipsoid on quadrant x; TMINhum a finite cylinder on quadrant x",
    "tma": "TMAJ_LAThum and LAT_TMAJhh are finite cylinders on quadrants -x / -y, LAT_TMAJ2hh a sphere on -z",
    "pec1": "two MovingPathPoints (the 'default' points move with shoulder_elv); the Thorax wrap a true ellipsoid",
    "pec2": "two MovingPathPoints; the Thorax wrap a true ellipsoid; PEC12hum a finite cylinder on quadrant x",
    "pec3": "two MovingPathPoints; the Thorax wrap a true ellipsoid; PEC3hum a finite cylinder on quadrant -x",
    "cor": "CORBhum is a finite (0.1 m) cylinder wrapped on quadrant x only, which MuJoCo's infinite cylinder with "
           "a side site does not reproduce exactly (and the parent's CORB has wrap artefacts, README 6.4)",
}
PARENT_PATHS_FILE = "mobl_arms_parent_paths.csv"


@dataclass(frozen=True)
class Body:
    name: str
    parent: str
    pos: tuple
    quat: tuple  # w x y z, in the parent frame


@dataclass(frozen=True)
class Joint:
    name: str
    body: str
    axis: tuple  # in the body's frame
    range_deg: tuple


@dataclass(frozen=True)
class Coupling:
    name: str
    dependent: str
    driver: str
    polycoef: tuple  # c0..c4, radians


@dataclass(frozen=True)
class Site:
    name: str
    body: str
    pos: tuple


@dataclass(frozen=True)
class Wrap:
    name: str
    body: str
    kind: str  # sphere | cylinder
    pos: tuple
    quat: tuple
    size: tuple  # sphere: (radius,); cylinder: (radius, half-length)
    side: Site | None


@dataclass(frozen=True)
class Inertial:
    mass: float
    com: tuple
    full: tuple  # Ixx Iyy Izz Ixy Ixz Iyz about the COM, kg m^2, humerus frame


def _rows(name: str, folder: Path | None = None) -> list[dict]:
    return list(csv.DictReader(open_table(Path(folder or REFERENCE_DIR) / name)))


def _vec(row: dict, *keys: str) -> tuple:
    return tuple(float(row[k]) for k in keys)


def body_frames(folder: Path | None = None) -> dict[str, Body]:
    """MyoArm's body frames of the shoulder chain (`body_frame` rows of muscle_parameters.csv)."""
    out = {}
    for r in _rows("muscle_parameters.csv", folder):
        if r["model"] == SOURCE and r["record"] == "body_frame" and r["name"] in CHAIN:
            if r["orient_convention"] != "quat_wxyz":
                raise ValueError(f"body {r['name']}: orientation {r['orient_convention']!r}, expected quat_wxyz")
            out[r["name"]] = Body(r["name"], r["body"], _vec(r, "x_m", "y_m", "z_m"), _vec(r, "o1", "o2", "o3", "o4"))
    missing = set(CHAIN) - set(out)
    if missing:
        raise ValueError(f"muscle_parameters.csv has no {SOURCE} body_frame row for {sorted(missing)}")
    return out


def mobl_sc_location(folder: Path | None = None) -> tuple:
    """MoBL's SC joint in the thorax frame: the `mobl_opensim` clavicle `body_frame` row (no rotation)."""
    for r in _rows("muscle_parameters.csv", folder):
        if r["model"] == "mobl_opensim" and r["record"] == "body_frame" and r["name"] == "clavicle":
            if r["body"] != "thorax" or any(float(r[k]) != 0.0 for k in ("o1", "o2", "o3")):
                raise ValueError(f"the mobl_opensim clavicle frame is not a pure offset in the thorax: {r}")
            return _vec(r, "x_m", "y_m", "z_m")
    raise ValueError("muscle_parameters.csv has no mobl_opensim clavicle body_frame row")


def _quat_conj_rotate(q: tuple, v: tuple) -> tuple:
    """R(q)^T v for a unit quaternion q = (w, x, y, z)."""
    w, x, y, z = q
    n = math.sqrt(w * w + x * x + y * y + z * z)
    w, x, y, z = w / n, -x / n, -y / n, -z / n
    # v' = q v q*, written out
    tx, ty, tz = 2 * (y * v[2] - z * v[1]), 2 * (z * v[0] - x * v[2]), 2 * (x * v[1] - y * v[0])
    return (v[0] + w * tx + y * tz - z * ty, v[1] + w * ty + z * tx - x * tz, v[2] + w * tz + x * ty - y * tx)


def myoarm_sc_location(folder: Path | None = None) -> tuple:
    """MyoArm's clavicle position expressed in its thorax frame, (25.5, 6.9, -6.3) mm (README section 6.2).

    In MyoArm the clavicle and the thorax are siblings in `full_body` with the same orientation; this is only for
    reproducing MyoArm exactly (the reconstruction test), not the shipped model."""
    b = body_frames(folder)
    th, cl = b["thorax"], b["clavicle"]
    d = tuple(c - t for c, t in zip(cl.pos, th.pos))
    return _quat_conj_rotate(th.quat, d)


def check_clavicle_parallel(folder: Path | None = None, tol: float = 1e-7) -> None:
    """The clavicle frame is parallel to the thorax frame in MyoArm (same quat in full_body); we rely on it."""
    b = body_frames(folder)
    if any(abs(a - c) > tol for a, c in zip(b["thorax"].quat, b["clavicle"].quat)):
        raise ValueError("MyoArm's clavicle frame is not parallel to its thorax frame")


def joints(folder: Path | None = None) -> list[Joint]:
    """MyoArm's shoulder-chain hinges in file order (= MuJoCo's order of application within a body)."""
    out = []
    for r in _rows("coordinate_definitions.csv", folder):
        if r["model"] == SOURCE and r["body"] in CHAIN:
            axis = tuple(float(x) for x in r["axis_in_parent_offset_frame"].split())
            out.append(Joint(r["coordinate"], r["body"], axis,
                             (float(r["range_min_deg"]), float(r["range_max_deg"]))))
    return out


def couplings(folder: Path | None = None) -> list[Coupling]:
    """MyoArm's joint equality constraints (girdle rhythm and shoulder1_r2 = -elv_angle)."""
    out = []
    for r in _rows("girdle_coupling.csv", folder):
        if r["model"] == SOURCE:
            out.append(Coupling(r["constraint"], r["dependent_coordinate"], r["driver_coordinate"],
                                _vec(r, "c0", "c1", "c2", "c3", "c4")))
    return out


def humerus_inertial(folder: Path | None = None) -> Inertial:
    for r in _rows("humerus_inertia.csv", folder):
        if r["model"] == SOURCE and r["body"] == "humerus":
            return Inertial(float(r["mass_kg"]), _vec(r, "com_x_m", "com_y_m", "com_z_m"),
                            _vec(r, "Ixx", "Iyy", "Izz", "Ixy", "Ixz", "Iyz"))
    raise ValueError("humerus_inertia.csv has no myoarm humerus row")


def muscle_paths(folder: Path | None = None, source: str = "v2", muscles: str = "v2") -> dict[str, list]:
    """Each of our tendons' path: Site and Wrap items in path order. `source="v2"`: the path source in PATH_SOURCE
    (the parent's, `parent_path`, or the OpenSim file's, `opensim_path`) for the tendons listed there, MyoArm's
    (`seq` order) for the others; `source="myoarm"`: MyoArm's for all; `source="mobl_opensim"`: the OpenSim file's
    for every tendon whose muscle it has (all but ld1-3), MyoArm's for the others (both for the tests and the
    path-source rule). `muscles`: "v2" (MUSCLES, the four) or "full" (FULL_MUSCLES)."""
    if source not in ("v2", "myoarm", "mobl_opensim"):
        raise ValueError(f"source must be 'v2', 'myoarm' or 'mobl_opensim', not {source!r}")
    if muscles not in MUSCLE_SETS:
        raise ValueError(f"muscles must be one of {sorted(MUSCLE_SETS)}, not {muscles!r}")
    all_rows = _rows("muscle_parameters.csv", folder)
    rows = [r for r in all_rows if r["model"] == SOURCE]
    opensim = {r["muscle"] for r in all_rows if r["model"] == "mobl_opensim" and r["record"] == "path_point"}
    out = {}
    for ours, theirs in MUSCLE_SETS[muscles].items():
        if source == "v2":
            chosen = PATH_SOURCE.get(ours)
        else:
            chosen = "mobl_opensim" if source == "mobl_opensim" and theirs in opensim else None
        if chosen == "mobl_arms":
            out[ours] = parent_path(theirs, folder)
            continue
        if chosen == "mobl_opensim":
            out[ours] = opensim_path(theirs, folder)
            continue
        items = []
        for r in sorted((r for r in rows if r["muscle"] == theirs and r["record"] in ("path_point", "wrap")),
                        key=lambda r: int(r["seq"])):
            pos = _vec(r, "x_m", "y_m", "z_m")
            if r["record"] == "path_point":
                items.append(Site(r["name"], r["body"], pos))
                continue
            if r["wrap_type"] not in ("sphere", "cylinder") or r["orient_convention"] != "quat_wxyz":
                raise ValueError(f"{theirs} wrap {r['name']}: {r['wrap_type']} / {r['orient_convention']}")
            size = (float(r["size1_m"]),) if r["wrap_type"] == "sphere" else _vec(r, "size1_m", "size2_m")
            side = None
            if r["side_spec"].startswith("sidesite:"):
                side = Site(r["side_spec"].split(":", 1)[1], r["side_body"],
                            _vec(r, "side_x_m", "side_y_m", "side_z_m"))
            elif r["side_spec"] != "none":
                raise ValueError(f"{theirs} wrap {r['name']}: side {r['side_spec']!r}")
            items.append(Wrap(r["name"], r["body"], r["wrap_type"], pos, _vec(r, "o1", "o2", "o3", "o4"), size, side))
        if not items or not isinstance(items[0], Site) or not isinstance(items[-1], Site):
            raise ValueError(f"{theirs}: a path must start and end at a site")
        out[ours] = items
    return out


def parent_path(muscle: str, folder: Path | None = None) -> list:
    """The parent's path of `muscle` (its name, e.g. SUPSP) as Site and Wrap items, from PARENT_PATHS_FILE.

    Only what MuJoCo represents exactly is accepted: fixed PathPoints, and wrap spheres (WrapSphere, or a
    WrapEllipsoid with three equal semi-axes) over all quadrants (no side site; MuJoCo then wraps on the side of the
    shorter path, as OpenSim's "all" does). A wrap object is placed in the one path segment that joins its body to
    another body (OpenSim's range -1 -1 tries every segment; on a bone-to-bone path the contact is on that
    segment). Anything else is an error naming the item."""
    rows = sorted((r for r in _rows(PARENT_PATHS_FILE, folder) if r["muscle"] == muscle), key=lambda r: int(r["seq"]))
    if not rows:
        raise ValueError(f"{PARENT_PATHS_FILE}: no path of {muscle}")
    sites, wraps = [], []
    for r in rows:
        pos = tuple(float(r[k]) for k in ("x", "y", "z"))
        name = f"{muscle}_{r['name']}"
        if r["record"] == "path_point":
            if r["type"] != "PathPoint":
                raise ValueError(f"{muscle} {r['name']}: a {r['type']} moves with a coordinate; MuJoCo sites cannot")
            sites.append(Site(name, r["body"], pos))
            continue
        size = [float(v) for v in r["size"].split()]
        if r["type"] not in ("WrapSphere", "WrapEllipsoid") or max(size) != min(size):
            raise ValueError(f"{muscle} wrap {r['name']}: {r['type']} of size {r['size']} is not a sphere")
        if r["quadrant"] != "all" or r["range"].split() != ["-1", "-1"]:
            raise ValueError(f"{muscle} wrap {r['name']}: quadrant {r['quadrant']!r}, range {r['range']!r}")
        wraps.append(Wrap(f"{muscle}_wrap_{r['name']}", r["body"], "sphere", pos, (1.0, 0.0, 0.0, 0.0),
                          (size[0],), None))
    items = list(sites)
    for w in wraps:
        seg = [k for k in range(len(sites) - 1) if sites[k].body != sites[k + 1].body
               and w.body in (sites[k].body, sites[k + 1].body)]
        if len(seg) != 1:
            raise ValueError(f"{muscle} wrap {w.name}: {len(seg)} segments join {w.body} to another body, need 1")
        items.insert(items.index(sites[seg[0]]) + 1, w)
    return items


def opensim_path(muscle: str, folder: Path | None = None) -> list[Site]:
    """The OpenSim file's path of `muscle` (its name, e.g. PECM1): its fixed PathPoints in path order, as Sites
    (`mobl_opensim` rows of muscle_parameters.csv). The file's muscles do not wrap (reference README 6.1: every
    PathWrapSet is empty), so MuJoCo represents the path exactly; a wrap row naming an object is an error. Body
    frames: the file's chain is MoBL's, the one the v2 model is built on (its SC location is the shipped clavicle's;
    the other frames agree with MyoArm's to 0.04 mm), so the points are taken in their bodies as they are."""
    rows = [r for r in _rows("muscle_parameters.csv", folder) if r["model"] == "mobl_opensim" and r["muscle"] == muscle]
    wraps = [r["name"] for r in rows if r["record"] == "wrap" and r["name"] != "(none)"]
    if wraps:
        raise ValueError(f"mobl_opensim {muscle} wraps over {wraps}; only fixed points are taken")
    points = sorted((r for r in rows if r["record"] == "path_point"), key=lambda r: int(r["seq"]))
    if len(points) < 2:
        raise ValueError(f"muscle_parameters.csv: no mobl_opensim path of {muscle}")
    return [Site(f"{muscle}_osim_{r['name']}", r["body"], _vec(r, "x_m", "y_m", "z_m")) for r in points]


def thorax_ellipsoid(folder: Path | None = None) -> tuple[tuple, tuple, tuple]:
    """MoBL's `Thorax` wrap ellipsoid (an unused `body_wrap_object` of the OpenSim file): position and semi-axes in
    the thorax frame, OpenSim body-fixed XYZ rotation (rad). The v2 model draws it as the rib cage (visual only)."""
    for r in _rows("muscle_parameters.csv", folder):
        if r["model"] == "mobl_opensim" and r["record"] == "body_wrap_object" and r["name"] == "Thorax":
            return (_vec(r, "x_m", "y_m", "z_m"), _vec(r, "o1", "o2", "o3"),
                    _vec(r, "size1_m", "size2_m", "size3_m"))
    raise ValueError("muscle_parameters.csv has no mobl_opensim Thorax body_wrap_object row")
