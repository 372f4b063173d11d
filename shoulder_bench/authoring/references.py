"""Reference moment arms of three MoBL-ARMS models, the muscle mapping, and which reference each muscle follows.

The tables (`models/reference/`, see its README.md) are copies of ../shared/reference/moment_arms: the MoBL-ARMS parent
file (`mobl_arms`), MyoArm (`myoarm`) and the OpenSim BaselineModel file (`mobl_opensim`), each moment arm
r = -dL/dq in mm about `shoulder_elv` (elevation, + elevates), `shoulder_rot` (axial rotation, + INTERNAL rotation) or
`elv_angle` (plane of elevation, + moves the plane anteriorly) over plane of elevation {-30, 0, 30, 60, 90} deg
(0 = coronal, 30 ~ scapular), elevation 0-150 deg every 10 deg, rotation {-45, 0, 30} deg, girdle `fixed` (scapula at
rest) or `coupled` (MoBL's linear rhythm). They are outputs of computer models, not cadaver data.

A muscle of ours that stands for several reference bundles (ld: LAT1-3 in the parent and MyoArm) gets the
F0-weighted mean of the bundles' moment arms, sum(F0_i r_i) / sum(F0_i), with each reference's own F0: the moment arm
of the bundles' summed force when all are equally activated (and equally far along their force-length curves).
"""
from __future__ import annotations

import csv
import functools
import gzip
import io
from pathlib import Path

import numpy as np

from shoulder_bench.model import MODELS_DIR

REFERENCE_DIR = MODELS_DIR / "reference"
REFERENCES = ("mobl_arms", "myoarm", "mobl_opensim")  # the parent first
LABELS = {"mobl_arms": "MoBL-ARMS parent", "myoarm": "MyoArm", "mobl_opensim": "OpenSim file"}
SHORT = {"mobl_arms": "parent", "myoarm": "MyoArm", "mobl_opensim": "OpenSim"}
FILES = {"mobl_arms": "moment_arms_mobl_arms_parent.csv.gz", "myoarm": "moment_arms_myoarm.csv.gz",
         "mobl_opensim": "moment_arms_mobl_opensim.csv.gz"}
PARAMETERS = "muscle_parameters.csv"  # MyoArm and OpenSim parameters (the shared folder's file, unchanged)
PARENT_MUSCLES = "mobl_arms_parent_muscles.csv"  # the parent's muscle parameters, extracted from its .osim file
COORDINATES = ("shoulder_elv", "shoulder_rot", "elv_angle")
DOF_LABELS = {"shoulder_elv": "elevation", "shoulder_rot": "rotation", "elv_angle": "plane"}
PLANES = {"coronal": 0, "scapular": 30}
GIRDLES = ("coupled", "fixed")
COLUMNS = ("model", "muscle", "coordinate", "plane_of_elevation_deg", "elevation_deg", "axial_rotation_deg",
           "girdle", "moment_arm_mm")

# our muscle -> the reference model's muscle(s)
MUSCLE_MAP = {
    "ssp": {"mobl_arms": ("SUPSP",), "myoarm": ("SUPSP",), "mobl_opensim": ("SUPSP",)},
    "isp": {"mobl_arms": ("INFSP",), "myoarm": ("INFSP",), "mobl_opensim": ("INFSP",)},
    "dmi": {"mobl_arms": ("DELT2",), "myoarm": ("DELT2",), "mobl_opensim": ("DELT2",)},
    "ld": {"mobl_arms": ("LAT1", "LAT2", "LAT3"), "myoarm": ("LAT1", "LAT2", "LAT3"), "mobl_opensim": ("LAT",)},
    # the full shoulder's added muscles (issue 12, docs/model_full.md): one bundle each, the same name in all three
    **{m: dict.fromkeys(REFERENCES, (b,)) for m, b in (("dan", "DELT1"), ("dpo", "DELT3"), ("ssc", "SUBSC"),
                                                         ("tmi", "TMIN"), ("tma", "TMAJ"), ("pec1", "PECM1"),
                                                         ("pec2", "PECM2"), ("pec3", "PECM3"), ("cor", "CORB"))},
}
FULL_MUSCLES = tuple(MUSCLE_MAP)  # the full shoulder's thirteen muscles (ld of three bundles): 15 tendons

# The v2 model's tendons (models/shoulder_v2.xml) per muscle of ours, each with the parent's bundle it reconstructs.
# v2 has no forces yet, so ld's three bundles are combined as the references' LAT1-3 are, weighted by the parent's F0
# (mobl_arms_parent_muscles.csv; the F0s anatomy.F0 uses): `ReferenceTables.v2_weights`.
V2_TENDONS = {"ssp": {"ssp": "SUPSP"}, "isp": {"isp": "INFSP"}, "dmi": {"dmi": "DELT2"},
              "ld": {"ld1": "LAT1", "ld2": "LAT2", "ld3": "LAT3"}}
# The full shoulder's tendons (models/shoulder_full.xml): v2's and one per added muscle, named as the muscle.
FULL_TENDONS = {**V2_TENDONS, **{m: {m: MUSCLE_MAP[m]["mobl_arms"][0]} for m in FULL_MUSCLES if m not in V2_TENDONS}}
V2_F0_FROM = "mobl_arms"

# The reference each muscle follows (the peak-torque target uses its peak moment arm), from the findings of the
# reference README (models/reference/README.md, sections 6.1-6.4), not from which one our model is closest to.
FOLLOWS = {
    "ssp": ("mobl_arms", "the parent; the reference README calls its SUPSP clean (no point disagrees with OpenSim's "
                         "computeMomentArm, section 6.4), and neither derived model reproduces it above 60 deg"),
    "isp": ("myoarm", "the parent's INFSP is one of its wrap problems (501 points disagree with computeMomentArm by "
                      "> 0.5 mm, section 6.4); MyoArm wraps INFSP over the head as the parent means to, the OpenSim "
                      "file wraps nothing (section 6.1)"),
    "dmi": ("myoarm", "the parent's DELT2 moving path point makes it large near the side (33.4 mm at 0 deg, fixed "
                      "coronal; section 6.4), against the literature (small near the side); MyoArm wraps DELT2 over "
                      "the head, the OpenSim file's DELT2 is an unwrapped polyline (section 6.1)"),
    "ld": ("myoarm", "v2's LAT1-3 are MyoArm's paths (the reconstruction, docs/model_v2.md) with the clavicle at "
                     "MoBL's SC location, which corrects MyoArm's 37 mm girdle offset (section 6.2) and so changes "
                     "only the coupled shoulder_elv arms; the parent's LAT1-3 carry most of its path-length jumps and "
                     "unchecked moving points (section 6.4); the OpenSim file's one LAT line, followed while v2's ld "
                     "was one line, is not v2's path"),
}

# References left out of a muscle's envelope and of its "within 5 mm of one of them" check, and why: we follow one
# reference against another only where the reference README documents an artefact of that curve.
ENVELOPE_EXCLUDED = {
    "isp": {"mobl_arms": "the parent's INFSP wrap disagrees with its own computeMomentArm at 501 points (README 6.4)"},
    "dmi": {"mobl_arms": "the parent's DELT2 moving point: large near the side, uncheckable (README 6.4)"},
    "ld": {"mobl_arms": "the parent's LAT1-3: path-length jumps and unchecked moving points (README 6.4)"},
    # the full shoulder's added muscles (docs/model_full.md, "References left out"); the parent stays in for DELT1,
    # DELT3, SUBSC and CORB (README 6.4: SUBSC clean; MyoArm tracks the parent for those four; CORB's wrap slide is at
    # 140 deg elevation, outside 0-120) and for PECM2-3 (below)
    "tmi": {"mobl_arms": "the parent's TMIN disagrees with its own computeMomentArm at 947 points and has path-length "
                         "jumps (README 6.4)"},
    "tma": {"mobl_arms": "the parent's TMAJ disagrees with its own computeMomentArm at 229 points and has path-length "
                         "jumps (README 6.4)"},
    "pec1": {"mobl_arms": "the parent's PECM1: path-length jumps and unchecked moving points (README 6.4)"},
    # PECM2 and PECM3: moving points too, so unchecked by computeMomentArm, but README 6.4 documents no artefact of
    # their curves (no jumps listed): the parent stays in (docs/model_full.md, "References left out")
}


class ReferenceTables:
    """All moment arms of the three references, keyed by (model, muscle, coordinate, plane, elevation, rotation,
    girdle) with the angles in whole degrees; F0 per (model, muscle)."""

    def __init__(self, values: dict, f0: dict, folder: Path):
        self.values, self.f0, self.folder = values, f0, Path(folder)

    @classmethod
    def load(cls, folder: Path | str | None = None) -> ReferenceTables:
        folder = Path(folder or REFERENCE_DIR)
        values = {}
        for model in REFERENCES:
            values.update(_read_moment_arms(folder / FILES[model], model))
        return cls(values, _read_f0(folder), folder)

    def raw_curve(self, model: str, muscle: str, coordinate: str, plane: int, girdle: str, elevations,
                  rotation: int = 0) -> np.ndarray:
        """One reference muscle's moment arms (mm) at the given elevations (degrees on the tables' grid)."""
        out = []
        for e in np.asarray(elevations, dtype=float):
            key = (model, muscle, coordinate, int(plane), int(round(e)), int(rotation), girdle)
            if abs(e - round(e)) > 1e-9 or key not in self.values:
                raise KeyError(f"reference {LABELS.get(model, model)} has no moment arm for {muscle} about "
                               f"{coordinate} at plane {plane} deg, elevation {e:g} deg, rotation {rotation} deg, "
                               f"girdle {girdle} (tables in {self.folder}; grid: planes -30..90 every 30, elevation "
                               f"0..150 every 10, rotation -45/0/30)")
            out.append(self.values[key])
        return np.array(out)

    def curve(self, model: str, muscle: str, coordinate: str, plane: int, girdle: str, elevations,
              rotation: int = 0) -> np.ndarray:
        """The moment arm (mm) of our muscle in reference `model`: its bundles' F0-weighted mean."""
        bundles = MUSCLE_MAP[muscle][model]
        arms = np.stack([self.raw_curve(model, b, coordinate, plane, girdle, elevations, rotation) for b in bundles])
        if len(bundles) == 1:
            return arms[0]
        w = np.array([self.f0[(model, b)] for b in bundles])
        return w @ arms / w.sum()

    def v2_weights(self, muscle: str) -> dict[str, float]:
        """{tendon: weight} that make our muscle from the v2 (or full) model's tendons: the parent's F0 of the bundle
        each tendon reconstructs, normalised (ld: LAT1-3 290.5 / 317.5 / 189 N); 1 for a single tendon."""
        f0 = {t: self.f0[(V2_F0_FROM, b)] for t, b in FULL_TENDONS[muscle].items()}
        total = sum(f0.values())
        return {t: f / total for t, f in f0.items()}

    def peak(self, model: str, muscle: str, coordinate: str, plane: int, girdle: str, elevations,
             rotation: int = 0) -> tuple[float, float]:
        """(signed moment arm of largest magnitude, mm; its elevation, deg) of the curve over `elevations`."""
        r = self.curve(model, muscle, coordinate, plane, girdle, elevations, rotation)
        k = int(np.argmax(np.abs(r)))
        return float(r[k]), float(np.asarray(elevations, dtype=float)[k])


def open_table(path: Path) -> io.StringIO:
    """A reference table's text (`path`, or `path.gz` beside it, decompressed); FileNotFoundError naming it."""
    path = Path(path)
    if not path.exists() and path.with_name(path.name + ".gz").exists():
        path = path.with_name(path.name + ".gz")
    if not path.exists():
        raise FileNotFoundError(f"reference table {path} is missing; it ships with the package (models/reference/, "
                                f"copied from ../shared/reference/moment_arms): reinstall or restore it")
    raw = path.read_bytes()
    if path.suffix == ".gz":
        raw = gzip.decompress(raw)
    return io.StringIO(raw.decode("utf-8"))


def _read_moment_arms(path: Path, model: str) -> dict:
    values = {}
    reader = csv.DictReader(open_table(path))
    if tuple(reader.fieldnames or ()) != COLUMNS:
        raise ValueError(f"reference table {path}: columns {reader.fieldnames}, expected {list(COLUMNS)}")
    for line, row in enumerate(reader, start=2):
        try:
            if row["model"] != model:
                raise ValueError(f"model {row['model']!r}, expected {model!r}")
            key = (model, row["muscle"], row["coordinate"], int(row["plane_of_elevation_deg"]),
                   int(row["elevation_deg"]), int(row["axial_rotation_deg"]), row["girdle"])
            values[key] = float(row["moment_arm_mm"])
        except (ValueError, TypeError) as exc:
            raise ValueError(f"reference table {path}, line {line}: {exc}") from exc
    return values


def _read_f0(folder: Path) -> dict:
    f0 = {}
    for row in csv.DictReader(open_table(folder / PARAMETERS)):
        if row["record"] == "max_isometric_force":
            f0[(row["model"], row["muscle"])] = float(row["value"])
    for row in csv.DictReader(open_table(folder / PARENT_MUSCLES)):
        f0[("mobl_arms", row["muscle"])] = float(row["max_isometric_force_N"])
    missing = [(m, b) for mus in MUSCLE_MAP.values() for m, bs in mus.items() for b in bs if (m, b) not in f0]
    if missing:
        raise ValueError(f"reference parameters in {folder} lack F0 for {missing}")
    return f0


@functools.lru_cache(maxsize=2)
def load(folder: str | None = None) -> ReferenceTables:
    """The reference tables (cached per folder)."""
    return ReferenceTables.load(folder)
