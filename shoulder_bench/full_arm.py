"""The full shoulder (issue 12, docs/model_full.md): thirteen muscles on the 3-DOF glenohumeral joint.

`models/shoulder_full_task.xml` is `mobl.model_xml(muscles="full", dynamics=True, actuators=True, scene=True)`:
the three MoBL glenohumeral coordinates are free (plane of elevation `elv_angle`, elevation `shoulder_elv`, axial
rotation `shoulder_rot`), the clavicle and scapula follow the elevation by the MoBL rhythm and `shoulder1_r2`
follows the plane (joint equalities, hardened by `arm.harden_couplings` after every compile). One user actuator per
tendon (15), one activation per muscle (13; ld drives ld1-3, `ACTUATORS`).

`Pose` poses the model on its couplings from the three coordinates and gives the tendon lengths and the moment arms
about each coordinate, `r_k = -ten_J S_k` with S (nv, 3) the coupling slopes: the quantities the force tables
(`shoulder_bench.authoring.fem.full`) and their checks are made of.
"""
from __future__ import annotations

import threading

import mujoco
import numpy as np

from shoulder_bench.arm import harden_couplings, polycoef_slope, polycoef_value
from shoulder_bench.geometry import compile_model, tendon_jacobian
from shoulder_bench.paths import MODELS_DIR

MODEL_FILE = MODELS_DIR / "shoulder_full_task.xml"
TABLE_FOLDER = MODELS_DIR / "muscles_full"
# A condition's geometry (`conditions.Condition.geometry`, as `arm.GEOMETRIES` for the 1-DOF arm): its task model and
# the folder of its rerouted tendons' tables (the other tendons keep TABLE_FOLDER's)
GEOMETRIES = {"ld_transfer": {"model": MODELS_DIR / "shoulder_full_task_ld_transfer.xml",
                              "tables": MODELS_DIR / "muscles_full_ld_transfer", "tendons": ("ld1", "ld2", "ld3")}}
COORDINATES = ("elv_angle", "shoulder_elv", "shoulder_rot")  # plane of elevation, elevation, axial rotation
COORDINATE_LABELS = {"elv_angle": "plane", "shoulder_elv": "elevation", "shoulder_rot": "rotation"}
ACTUATORS = {"ssp": ("ssp",), "isp": ("isp",), "dmi": ("dmi",), "ld": ("ld1", "ld2", "ld3"), "dan": ("dan",),
             "dpo": ("dpo",), "ssc": ("ssc",), "tmi": ("tmi",), "tma": ("tma",), "pec1": ("pec1",),
             "pec2": ("pec2",), "pec3": ("pec3",), "cor": ("cor",)}
MUSCLES = tuple(ACTUATORS)
TENDONS = tuple(t for v in ACTUATORS.values() for t in v)
# The pose space the tables cover (and the 3-DOF tasks stay inside): planes from coronal (0) to sagittal (90),
# elevation 0-140 deg, rotation -45 (external) to 60 (internal) deg, inside each coordinate's MoBL range
# (coordinate_definitions.csv). Not the whole MoBL box: its corners are not jointly reachable poses, and there the
# paths stretch fibres far past any physiological length (MyoArm's INFSP path to 2.07 l_opt at plane 120,
# elevation 140, rotation 15; DELT1 to 2.18) where the sheet solve does not converge (docs/fem.md "Full shoulder").
POSE_RANGE_DEG = {"elv_angle": (0.0, 90.0), "shoulder_elv": (0.0, 140.0), "shoulder_rot": (-45.0, 60.0)}
POSE_STEP_DEG = {"elv_angle": 15.0, "shoulder_elv": 10.0, "shoulder_rot": 15.0}


def pose_grid(step_deg: dict | None = None) -> np.ndarray:
    """(P, 3) poses (deg: plane, elevation, rotation) on the grid over POSE_RANGE_DEG, every `step_deg`."""
    step = {**POSE_STEP_DEG, **(step_deg or {})}
    axes = [np.arange(lo, hi + 1e-9, step[c]) for c, (lo, hi) in POSE_RANGE_DEG.items()]
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)


def angular_distance_deg(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(B,) the angle (deg) of the rotation between orientations a and b (B, 3, 3): the 3-DOF tasks' tracking
    error."""
    c = (np.einsum("bij,bij->b", a, b) - 1.0) / 2.0  # trace(a^T b) = 1 + 2 cos(angle)
    return np.degrees(np.arccos(np.clip(c, -1.0, 1.0)))


def model_file(geometry: str | None = None):
    """The full shoulder's task model file of `geometry` (None: intact, MODEL_FILE)."""
    if geometry is not None and geometry not in GEOMETRIES:
        raise ValueError(f"unknown geometry {geometry!r}; choose from {sorted(GEOMETRIES)} or None (intact)")
    return MODEL_FILE if geometry is None else GEOMETRIES[geometry]["model"]


def compile_full(geometry: str | None = None) -> mujoco.MjModel:
    """The full shoulder's task model (of `geometry`, default intact), compiled, couplings hardened (thread-safe, as
    `model.compile_model`)."""
    return compile_model(model_file(geometry), prepare=harden_couplings)


class Pose:
    """The full shoulder posed on its couplings from (plane, elevation, rotation). `model`: a compiled 3-DOF model
    (default the task model)."""

    def __init__(self, model: mujoco.MjModel | None = None):
        m = self.m = compile_full() if model is None else model
        self.d = mujoco.MjData(m)
        self._lock = threading.Lock()
        self.qadr = np.array([int(m.joint(c).qposadr[0]) for c in COORDINATES])
        self.dadr = np.array([int(m.joint(c).dofadr[0]) for c in COORDINATES])
        self.couplings = []  # (qpos address, dof address, driver's index in COORDINATES, polycoef)
        for e in range(m.neq):
            dep, drv = m.joint(int(m.eq_obj1id[e])), m.joint(int(m.eq_obj2id[e]))
            if drv.name not in COORDINATES:
                raise ValueError(f"{dep.name} is driven by {drv.name}, not one of {COORDINATES}")
            self.couplings.append((int(dep.qposadr[0]), int(dep.dofadr[0]), COORDINATES.index(drv.name),
                                   m.eq_data[e, :5].copy()))

    def qpos(self, pose_deg) -> np.ndarray:
        """(B, nq) positions on the couplings at poses (B, 3) deg."""
        m = self.m
        u = np.radians(np.atleast_2d(np.asarray(pose_deg, dtype=float)))
        out = np.tile(m.qpos0, (len(u), 1))
        x = u - m.qpos0[self.qadr]
        out[:, self.qadr] = u
        for adr, _, k, c in self.couplings:
            out[:, adr] = m.qpos0[adr] + polycoef_value(c, x[:, k])
        return out

    def slopes(self, pose_deg) -> np.ndarray:
        """S (nv, 3): dqvel / d(coordinate rates) on the couplings at one pose (deg)."""
        m = self.m
        x = np.radians(np.asarray(pose_deg, dtype=float)) - m.qpos0[self.qadr]
        s = np.zeros((m.nv, 3))
        s[self.dadr, np.arange(3)] = 1.0
        for _, dof, k, c in self.couplings:
            s[dof, k] = polycoef_slope(c, x[k])
        return s

    def orientation(self, qpos: np.ndarray) -> np.ndarray:
        """(B, 3, 3) the humerus's orientation in the thorax frame at positions qpos (B, nq)."""
        qpos = np.atleast_2d(qpos)
        hum, tho = self.m.body("humerus").id, self.m.body("thorax").id
        out = np.zeros((len(qpos), 3, 3))
        with self._lock:
            for k in range(len(qpos)):
                self.d.qpos[:] = qpos[k]
                mujoco.mj_kinematics(self.m, self.d)
                out[k] = self.d.xmat[tho].reshape(3, 3).T @ self.d.xmat[hum].reshape(3, 3)
        return out

    def tendon_geometry(self, pose_deg, tendons=TENDONS) -> tuple[np.ndarray, np.ndarray]:
        """(lengths (P, n) m, moment arms (P, n, 3) m about plane, elevation, rotation: r = -ten_J S) of `tendons`
        at poses (P, 3) deg."""
        poses = np.atleast_2d(pose_deg)
        tid = [self.m.tendon(t).id for t in tendons]
        qpos = self.qpos(poses)
        L, r = np.zeros((len(poses), len(tid))), np.zeros((len(poses), len(tid), 3))
        with self._lock:  # the poses share one MjData
            for k in range(len(poses)):
                self.d.qpos[:] = qpos[k]
                mujoco.mj_kinematics(self.m, self.d)
                mujoco.mj_comPos(self.m, self.d)
                mujoco.mj_tendon(self.m, self.d)
                L[k] = self.d.ten_length[tid]
                r[k] = -(tendon_jacobian(self.m, self.d)[tid] @ self.slopes(poses[k]))
        return L, r
