"""Landmarks of the right shoulder: one source for the MJCF, the bone meshes and the muscle shells.

Frame: the glenohumeral (GH) joint centre is the origin; x points anterior, y lateral (towards the right arm),
z superior. Metres. At abduction 0 the humerus hangs along -z; abduction rotates it about +x, so the elbow moves
towards +y. Humerus points are in the humerus body frame (equal to the world frame at 0 deg).

Provenance (see models/README.md): insertions are MoBL-ARMS (Holzbaur et al. 2005) humerus points with the axes
renamed (MoBL x, y, z = anterior, superior, lateral). Origins and via points start from the MoBL scapula points moved
to the GH frame and were then fitted (least squares, `scripts` in docs/model.md) so that the straight-line-with-wrapping
moment arms fall in the bands of ../shared/reference/shoulder_parameters.md; the latissimus dorsi thorax origin and
its scapular via point are placed by hand (MoBL thorax points need a frame chain we do not model).
"""
from __future__ import annotations

# the muscles and their optimal fibre lengths are defined with the force law that needs them at run time
from shoulder_bench.muscle import MUSCLES, OPTIMAL_FIBRE_LENGTH  # noqa: F401

MODEL_VERSION = "1"  # this (v1) model's version; the tasks run model v2 (shoulder_bench.arm.MODEL_VERSION)
MUSCLE_NAMES = {"ssp": "supraspinatus", "isp": "infraspinatus", "dmi": "deltoid, middle part", "ld": "latissimus dorsi"}

# Maximum isometric force, N (MoBL-ARMS; ld = LAT1 + LAT2 + LAT3).
F0 = {"ssp": 499.2, "isp": 1075.8, "dmi": 1103.5, "ld": 797.0}

HUMERAL_HEAD_RADIUS = 0.024
HUMERUS_LENGTH = 0.30
HUMERUS_MASS = 2.0  # kg (MoBL 1.998, Seth 2015 2.052)
HUMERUS_COM = (0.0, 0.0, -0.12)  # 0.11-0.14 m distal to the head centre
HUMERUS_INERTIA = (0.0129, 0.0122, 0.0024)  # kg m^2 about the COM; x = abduction axis, z = shaft (MoBL)

JOINT_RANGE_DEG = (-10.0, 160.0)  # hinge limits; 0 = arm hanging beside the trunk

# Muscle paths: origin (and via) sites fixed to scapula/thorax, an optional wrap over the humeral head with a side
# site that selects the side the path passes on, and the insertion on the humerus. Side sites were chosen on a 0.25 deg
# scan so that the path never flips sides (tests/test_model.py checks continuity); ld wraps under the head so that
# above ~110 deg its line rests on the head like the FEM sheet instead of cutting through it.
PATHS = {
    "ssp": {"fixed": [(-0.0344, -0.0675, 0.0189), (-0.0267, -0.0128, 0.0171)],
            "wrap_side": (0.01, 0.0, 0.05), "insertion": (0.00256, 0.02593, 0.01063), "bone": "scapula"},
    "isp": {"fixed": [(-0.070, -0.070, -0.040), (-0.0719, -0.0102, -0.0129)],
            "wrap_side": (-0.06, 0.01, 0.02), "insertion": (-0.00887, 0.02448, 0.00484), "bone": "scapula"},
    "dmi": {"fixed": [(-0.0012, -0.0028, 0.0337), (0.0095, 0.0298, 0.0383)],
            "wrap_side": (0.0, 0.06, 0.03), "insertion": (0.00461, 0.0056, -0.13611), "bone": "scapula"},
    "ld": {"fixed": [(-0.080, -0.160, -0.250), (-0.050, -0.060, -0.130)],
           "wrap_side": (-0.02, -0.02, -0.06), "insertion": (0.0105, -0.00653, -0.03415), "bone": "thorax"},
}

# Bone placement (GH frame). Scapula: glenoid just medial of the head, blade running medially and posteriorly.
GLENOID_CENTRE = (-0.004, -0.027, 0.0)
SCAPULA = {
    "superior_angle": (-0.060, -0.100, 0.045),
    "inferior_angle": (-0.055, -0.075, -0.135),
    "medial_spine_root": (-0.068, -0.110, 0.010),
    "acromion_tip": (0.010, 0.032, 0.040),
    "coracoid_tip": (0.035, -0.010, 0.020),
}
CLAVICLE = {"sternal_end": (0.060, -0.150, 0.010), "acromial_end": (0.000, 0.010, 0.045)}
THORAX = {"centre": (0.0, -0.19, -0.13), "radii": (0.10, 0.13, 0.20)}  # ellipsoidal rib-cage section
