"""Extract the shoulder muscles' parameters from a local copy of the MoBL-ARMS parent file (MoBL_ARMS_J.osim).

Usage (from the repository root; the .osim is not part of this repository):

    C=610b95cf0c4484f1acecd31187736b0113dcfb73   # stanfordnmbl/osim-rl
    git --git-dir=<osim-rl clone>/.git show $C:osim/models/MoBL_ARMS_J.osim > /tmp/MoBL_ARMS_J.osim
    md5sum /tmp/MoBL_ARMS_J.osim   # d6b9866c4f721f481e7d9e0bdae51093
    python models/reference/scripts/extract_parent_muscles.py /tmp/MoBL_ARMS_J.osim \
        --out models/reference/mobl_arms_parent_muscles.csv --curves models/reference/mobl_arms_parent_curves.csv \
        --paths models/reference/mobl_arms_parent_paths.csv

`--paths` also writes each muscle's geometry path: its path points in order (PathPoint, or MovingPathPoint /
ConditionalPathPoint with the location the file spells, which MuJoCo cannot move) and the wrap objects of its
PathWrapSet (type, body, translation, xyz_body_rotation, size, quadrant, wrap method and range), one row per item.

`--curves` also writes each muscle's three SimmSpline curves (tendon_force_length_curve, active_force_length_curve,
passive_force_length_curve: normalised length or strain -> normalised force), one row per knot, x and y as the file
spells them.

Standard library only (xml.etree). Each value is written exactly as the file spells it (no float reformatting).
The muscle class is the XML element's tag (e.g. Schutte1993Muscle_Deprecated). A muscle element that lacks one of
the four properties is an error (the file's <defaults> hold no Schutte1993 muscle to inherit from), as is a muscle
that appears twice or not at all.
"""
from __future__ import annotations

import argparse
import csv
import hashlib
import sys
import xml.etree.ElementTree as ET

MUSCLES = ("SUPSP", "INFSP", "DELT1", "DELT2", "DELT3", "SUBSC", "TMIN", "TMAJ",
           "PECM1", "PECM2", "PECM3", "LAT1", "LAT2", "LAT3", "CORB")
PROPERTIES = (("max_isometric_force", "max_isometric_force_N"),
              ("optimal_fiber_length", "optimal_fiber_length_m"),
              ("tendon_slack_length", "tendon_slack_length_m"),
              ("pennation_angle_at_optimal", "pennation_angle_rad"))
COLUMNS = ("muscle",) + tuple(c for _, c in PROPERTIES) + ("class",)


def extract(path: str) -> list[dict]:
    root = ET.parse(path).getroot()
    force_sets = root.findall("./Model/ForceSet/objects")
    if len(force_sets) != 1:
        raise SystemExit(f"{path}: expected one Model/ForceSet/objects, found {len(force_sets)}")
    found: dict[str, ET.Element] = {}
    for el in force_sets[0]:
        name = el.get("name")
        if name in MUSCLES:
            if name in found:
                raise SystemExit(f"{path}: muscle {name} appears twice")
            found[name] = el
    missing = [m for m in MUSCLES if m not in found]
    if missing:
        raise SystemExit(f"{path}: muscles not found: {missing}")
    rows = []
    for m in MUSCLES:
        el = found[m]
        row = {"muscle": m, "class": el.tag}
        for prop, col in PROPERTIES:
            child = el.find(prop)  # direct child only: nested curves have their own elements
            if child is None or child.text is None:
                raise SystemExit(f"{path}: {m} has no <{prop}>")
            text = child.text.strip()
            float(text)  # must parse as a number
            row[col] = text
        rows.append(row)
    return rows


CURVE_COLUMNS = ("muscle", "curve", "knot", "x", "y")


def extract_curves(path: str) -> list[dict]:
    """Each muscle's SimmSpline curves, one row per knot (values as spelled in the file)."""
    root = ET.parse(path).getroot()
    rows = []
    for el in root.findall("./Model/ForceSet/objects/*"):
        if el.get("name") not in MUSCLES:
            continue
        for spline in el.findall("SimmSpline"):
            xs, ys = spline.find("x").text.split(), spline.find("y").text.split()
            if len(xs) != len(ys):
                raise SystemExit(f"{path}: {el.get('name')} {spline.get('name')}: {len(xs)} x but {len(ys)} y")
            rows += [{"muscle": el.get("name"), "curve": spline.get("name"), "knot": k, "x": x, "y": y}
                     for k, (x, y) in enumerate(zip(xs, ys))]
    return rows


PATH_COLUMNS = ("muscle", "seq", "record", "name", "type", "body", "x", "y", "z", "rot_x", "rot_y", "rot_z", "size",
                "quadrant", "method", "range")
WRAP_SIZE = {"WrapSphere": ("radius",), "WrapEllipsoid": ("dimensions",), "WrapCylinder": ("radius", "length"),
             "WrapTorus": ("inner_radius", "outer_radius")}


def _text(el: ET.Element, tag: str, where: str) -> str:
    child = el.find(tag)
    if child is None or child.text is None:
        raise SystemExit(f"{where}: no <{tag}>")
    return " ".join(child.text.split())


def extract_paths(path: str) -> list[dict]:
    """Each muscle's path points and wrap objects in path order: points first (seq 0..), then its PathWrapSet's
    wraps in the file's order (seq continues); values as spelled, whitespace collapsed."""
    root = ET.parse(path).getroot()
    wraps: dict[str, tuple[str, ET.Element]] = {}
    for body in root.iter("Body"):
        for w in body.findall("WrapObjectSet/objects/*"):
            if w.get("name") in wraps:
                raise SystemExit(f"{path}: wrap object {w.get('name')} appears twice")
            wraps[w.get("name")] = (body.get("name"), w)
    rows = []
    for el in root.findall("./Model/ForceSet/objects/*"):
        m = el.get("name")
        if m not in MUSCLES:
            continue
        gp = el.find("GeometryPath")
        if gp is None:
            raise SystemExit(f"{path}: {m} has no GeometryPath")
        seq = 0
        for pt in gp.findall("PathPointSet/objects/*"):
            x, y, z = _text(pt, "location", f"{m} {pt.tag}").split()
            rows.append({"muscle": m, "seq": seq, "record": "path_point", "name": pt.get("name"), "type": pt.tag,
                         "body": _text(pt, "body", f"{m} {pt.tag}"), "x": x, "y": y, "z": z})
            seq += 1
        for pw in gp.findall("PathWrapSet/objects/PathWrap"):
            name = _text(pw, "wrap_object", f"{m} PathWrap")
            if name not in wraps:
                raise SystemExit(f"{path}: {m} wraps over unknown object {name}")
            body, w = wraps[name]
            if w.tag not in WRAP_SIZE:
                raise SystemExit(f"{path}: wrap {name}: unknown type {w.tag}")
            x, y, z = _text(w, "translation", name).split()
            rx, ry, rz = _text(w, "xyz_body_rotation", name).split()
            rows.append({"muscle": m, "seq": seq, "record": "wrap", "name": name, "type": w.tag, "body": body,
                         "x": x, "y": y, "z": z, "rot_x": rx, "rot_y": ry, "rot_z": rz,
                         "size": " ".join(_text(w, t, name) for t in WRAP_SIZE[w.tag]),
                         "quadrant": _text(w, "quadrant", name), "method": _text(pw, "method", name),
                         "range": _text(pw, "range", name)})
            seq += 1
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("osim", help="local copy of MoBL_ARMS_J.osim")
    ap.add_argument("--out", help="CSV to write (default: stdout)")
    ap.add_argument("--curves", help="also write the muscles' force-length curves to this CSV")
    ap.add_argument("--paths", help="also write the muscles' path points and wrap objects to this CSV")
    args = ap.parse_args(argv)
    with open(args.osim, "rb") as f:
        md5 = hashlib.md5(f.read()).hexdigest()
    rows = extract(args.osim)
    out = open(args.out, "w", newline="") if args.out else sys.stdout
    try:
        w = csv.DictWriter(out, fieldnames=COLUMNS, lineterminator="\n")
        w.writeheader()
        w.writerows(rows)
    finally:
        if args.out:
            out.close()
    if args.curves:
        curves = extract_curves(args.osim)
        with open(args.curves, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=CURVE_COLUMNS, lineterminator="\n")
            w.writeheader()
            w.writerows(curves)
    if args.paths:
        with open(args.paths, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=PATH_COLUMNS, lineterminator="\n")
            w.writeheader()
            w.writerows(extract_paths(args.osim))
    print(f"{args.osim}: md5 {md5}, {len(rows)} muscles", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
