"""The arm the tasks simulate: model v2's locked 1-DOF variant (docs/model_v2.md).

`models/shoulder_v2_task.xml` is `mobl.model_xml(locked_plane_deg=TASK_PLANE_DEG, dynamics=True, actuators=True)`:
the humerus elevates (`shoulder_elv`, the thoracohumeral elevation) in the coronal plane with axial rotation 0, and the
clavicle and scapula follow by the MoBL rhythm (joint equalities, hardened by `harden_couplings` after every
compile). Its state is the whole qpos/qvel (the elevation plus the ten slaved girdle joints); the tasks' angle is the
elevation.

Muscles and actuators: the tasks' muscles are ssp, isp, dmi and ld; each v2 tendon has an actuator (ssp, isp, dmi,
ld1, ld2, ld3), and one ld activation drives the three latissimus bundles (`ACTUATORS`, `muscle.ForceLaw` groups).

`LockedPath` poses a locked variant along its coupling and gives the reduced (1-DOF) quantities the tasks' statics and
the reference controller need: gravity torque, inertia, damping, all as exact functions of the model along the
coupled path.
"""
from __future__ import annotations

import threading

import mujoco
import numpy as np

from shoulder_bench.geometry import compile_model, tendon_jacobian
from shoulder_bench.paths import MODELS_DIR

MODEL_VERSION = "2"  # recorded in every run and policy; bump when the tasks' model or its dynamics change
TASK_PLANE_DEG = 0  # the tasks' plane of elevation: coronal (docs/model_v2.md "The tasks' plane")
MODEL_FILE = MODELS_DIR / "shoulder_v2_task.xml"
TABLE_FOLDER = MODELS_DIR / "muscles_v2"
MODEL_3DOF_FILE = MODELS_DIR / "shoulder_v2.xml"
# Geometries other than the intact shoulder's (a condition that reroutes a tendon, `conditions.Condition.geometry`):
# its tasks' model, its 3-DOF model, the folder of the rerouted tendons' tables (the others keep TABLE_FOLDER's).
# Written by `python -m shoulder_bench.authoring.mobl` (authoring/transfer.py) and the v2 table builders.
GEOMETRIES = {"ld_transfer": {"model": MODELS_DIR / "shoulder_v2_task_ld_transfer.xml",
                              "model_3dof": MODELS_DIR / "shoulder_v2_ld_transfer.xml",
                              "tables": MODELS_DIR / "muscles_v2_ld_transfer", "tendons": ("ld1", "ld2", "ld3")}}
JOINT = "shoulder_elv"  # the driver of the girdle couplings and the tasks' angle
ACTUATORS = {"ssp": ("ssp",), "isp": ("isp",), "dmi": ("dmi",), "ld": ("ld1", "ld2", "ld3")}
MUSCLES = tuple(ACTUATORS)  # the tasks' muscles
FINE_STEP_DEG = 0.1  # grid of the tabled reduced quantities (gravity torque, inertia); linear interpolation
# shoulder_elv's range (MoBL, coordinate_definitions.csv: 0..180.023 deg, rounded; tests check it against the model)
RANGE_DEG = (0.0, 180.0)
# A numerical failure ("crash") is a non-finite state, a MuJoCo instability, or the arm further than this beyond the
# range. The joint limit is a soft constraint at the 50 ms physics step: a free fall from the top of the range (180°)
# overshoots the lower limit to -25.8° (tests/test_arm.py), which is not a failure.
VALID_MARGIN_DEG = 30.0
# A_hat of a joint equality comes from dof_invweight0, which MuJoCo computes at qpos0 from the inverse mass matrix.
# The placeholder girdle bodies make it ~1e8 (modes in which only they move), so R swamps the humerus's
# ~1/0.06 kg m^2 and the couplings go soft (the girdle lags by degrees) or blow up. harden_couplings() overwrites it
# after compiling: it changes only the constraint softness (R), not the inertia, the forces or the reference
# acceleration. MJCF has no attribute for it. A numerical setting without a source (docs/model_v2.md).
COUPLING_INVWEIGHT = 0.01


def harden_couplings(model, invweight: float = COUPLING_INVWEIGHT):
    """Make a compiled `dynamics=True` model's joint equalities (nearly) hard: set every dof's `dof_invweight0`
    (the constraint regularizer's scale) to `invweight`. Call it after every compile; `mj_setConst` undoes it."""
    model.dof_invweight0[:] = invweight
    return model


def polycoef_value(c, x):
    """A MuJoCo joint equality's dependent offset at driver offset `x` (scalar or array): sum c_k x^k, k = 0..4."""
    return sum(c[k] * x ** k for k in range(5))


def polycoef_slope(c, x):
    """Its derivative d(dependent)/d(driver) at `x`: sum k c_k x^(k-1), k = 1..4."""
    return sum(k * c[k] * x ** (k - 1) for k in range(1, 5))


def actuators_of(muscles) -> tuple[str, ...]:
    """The actuators (tendons) of the tasks' `muscles`, in model order."""
    unknown = [m for m in muscles if m not in ACTUATORS]
    if unknown:
        raise ValueError(f"unknown muscle(s) {unknown}; choose from {tuple(ACTUATORS)}")
    return tuple(a for m in ACTUATORS if m in muscles for a in ACTUATORS[m])


def _geometry(geometry: str | None) -> dict:
    if geometry is not None and geometry not in GEOMETRIES:
        raise ValueError(f"unknown geometry {geometry!r}; choose from {sorted(GEOMETRIES)} or None (intact)")
    return {"model": MODEL_FILE, "model_3dof": MODEL_3DOF_FILE, "tables": TABLE_FOLDER, "tendons": ()} \
        if geometry is None else GEOMETRIES[geometry]


def model_file(geometry: str | None = None, dofs: int = 1):
    """The tasks' model file of `geometry` (None: the intact shoulder, `MODEL_FILE`); dofs=3: its 3-DOF model."""
    return _geometry(geometry)["model" if dofs == 1 else "model_3dof"]


def compile_arm(geometry: str | None = None) -> mujoco.MjModel:
    """The task model (of `geometry`, default intact), compiled and with its couplings hardened (thread-safe, as
    `model.compile_model`)."""
    return compile_model(model_file(geometry), prepare=harden_couplings)


class LockedPath:
    """A locked 1-DOF variant posed along its coupled path: the elevation set, the girdle from its polycoefs.

    `model`: a compiled locked variant (default: the tasks' model; `statics_v2.LockedPath(plane_deg)` generates the
    kinematic variant of another plane)."""

    def __init__(self, model: mujoco.MjModel | None = None):
        m = self.m = compile_arm() if model is None else model
        self._lock = threading.Lock()
        self.d, self.hum = mujoco.MjData(m), m.body("humerus").id
        self.q = int(m.joint(JOINT).qposadr[0])
        self.dof = int(m.joint(JOINT).dofadr[0])
        self.couplings = []  # (qpos address, dof address, polycoef) of each slaved joint
        for e in range(m.neq):
            dep, drv = m.joint(int(m.eq_obj1id[e])), m.joint(int(m.eq_obj2id[e]))
            if drv.name != JOINT:
                raise ValueError(f"locked variant: {dep.name} is driven by {drv.name}, not {JOINT}")
            self.couplings.append((int(dep.qposadr[0]), int(dep.dofadr[0]), m.eq_data[e, :5].copy()))
        # the same as arrays, so that `qpos` evaluates every slaved joint at once (the same arithmetic, element-wise)
        self._slaved = np.array([adr for adr, _, _ in self.couplings], dtype=np.int64)
        self._slaved_dof = np.array([dof for _, dof, _ in self.couplings], dtype=np.int64)
        self._coef = np.array([c for _, _, c in self.couplings]).reshape(-1, 5).T  # (5, number of couplings)

    def qpos(self, elevation_rad) -> np.ndarray:
        """(B, nq) positions on the coupled path at elevations (B,) rad."""
        m = self.m
        x = np.atleast_1d(np.asarray(elevation_rad, dtype=float)) - m.qpos0[self.q]
        out = np.tile(m.qpos0, (len(x), 1))
        out[:, self.q] = x + m.qpos0[self.q]
        out[:, self._slaved] = m.qpos0[self._slaved] + polycoef_value(self._coef, x[:, None])
        return out

    def pose(self, elevation_rad: float) -> mujoco.MjData:
        return self._posed_at(self.qpos(elevation_rad)[0])

    def _posed_at(self, qpos: np.ndarray) -> mujoco.MjData:
        """`self.d` posed at `qpos` (kinematics and composite inertias)."""
        m, d = self.m, self.d
        d.qpos[:] = qpos
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        return d

    def com_height(self, elevation_rad: float) -> float:
        """World z (m, superior) of the humerus COM."""
        return float(self.pose(elevation_rad).xipos[self.hum, 2])

    def slopes(self, elevation_rad) -> np.ndarray:
        """S (nv,): dqvel / d(elevation rate) along the couplings (1 on the elevation, each polycoef's derivative);
        at elevations (B,): (B, nv)."""
        m = self.m
        x = np.asarray(elevation_rad, dtype=float) - m.qpos0[self.q]
        s = np.zeros(x.shape + (m.nv,))
        s[..., self.dof] = 1.0
        s[..., self._slaved_dof] = polycoef_slope(self._coef, x[..., None])
        return s

    def gravity_torque(self, elevation_rad: float) -> float:
        """-dPE/dq (N m, + elevates) of the humerus alone: -m g (J_com S)_z, S = dqpos/dq along the couplings."""
        self.pose(elevation_rad)
        return self._posed_gravity(self.slopes(elevation_rad))

    def inertia(self, elevation_rad: float) -> float:
        """Reduced inertia S^T M S (kg m^2) of the whole model along the coupling."""
        self.pose(elevation_rad)
        return self._posed_inertia(self.slopes(elevation_rad))

    def _posed_gravity(self, s: np.ndarray) -> float:
        """`gravity_torque` at the pose `self.d` holds, S = `s`."""
        m = self.m
        jacp = np.zeros((3, m.nv))
        mujoco.mj_jacBodyCom(m, self.d, jacp, None, self.hum)
        return float(m.body_mass[self.hum] * m.opt.gravity[2] * (jacp[2] @ s))

    def _posed_inertia(self, s: np.ndarray) -> float:
        """`inertia` at the pose `self.d` holds, S = `s`."""
        m = self.m
        mujoco.mj_crb(m, self.d)
        full = np.zeros((m.nv, m.nv))
        mujoco.mj_fullM(m, self.d, full)
        return float(s @ full @ s)

    def damping(self, elevation_rad: float = 0.0) -> float:
        """Reduced joint damping S^T B S (N m s/rad)."""
        s = self.slopes(elevation_rad)
        return float(s @ (self.m.dof_damping * s))

    def tendon_geometry(self, angle_deg, tendons) -> tuple[np.ndarray, np.ndarray]:
        """(lengths (K, n) m, total coupled moment arms r = -ten_J S (K, n) m) of `tendons` at `angle_deg`."""
        with self._lock:  # poses share one MjData
            return self._tendon_geometry(angle_deg, tendons)

    def _tendon_geometry(self, angle_deg, tendons):
        tid = [self.m.tendon(t).id for t in tendons]
        angle_deg = np.atleast_1d(angle_deg)
        L, r = np.zeros((len(angle_deg), len(tid))), np.zeros((len(angle_deg), len(tid)))
        for k, q in enumerate(np.radians(angle_deg)):
            d = self.pose(q)
            mujoco.mj_tendon(self.m, d)
            L[k] = d.ten_length[tid]
            r[k] = -(tendon_jacobian(self.m, d)[tid] @ self.slopes(q))
        return L, r


class Arm(LockedPath):
    """The tasks' arm with its reduced quantities tabled on a fine grid over the elevation joint's range (linear
    interpolation; the tables are exact samples of `LockedPath`'s functions)."""

    def __init__(self, geometry: str | None = None):
        super().__init__(compile_arm(geometry))
        self.geometry = geometry
        lo, hi = RANGE_DEG
        self._grid = np.radians(np.arange(lo - VALID_MARGIN_DEG, hi + VALID_MARGIN_DEG + 1e-9, FINE_STEP_DEG))
        self._gravity, self._inertia = self._reduced(self._grid)

    def _reduced(self, grid) -> tuple[np.ndarray, np.ndarray]:
        """`LockedPath.gravity_torque` and `LockedPath.inertia` at every elevation of `grid` (rad), each point posed
        once for both."""
        gravity, inertia = np.empty(len(grid)), np.empty(len(grid))
        for k, (qpos, s) in enumerate(zip(self.qpos(grid), self.slopes(grid))):  # the whole grid's at once
            self._posed_at(qpos)
            gravity[k], inertia[k] = self._posed_gravity(s), self._posed_inertia(s)
        return gravity, inertia

    def gravity_torque(self, elevation_rad):
        """Gravity torque (N m, + elevates) at elevations (rad), array in, array out."""
        return np.interp(elevation_rad, self._grid, self._gravity)

    def inertia(self, elevation_rad):
        return np.interp(elevation_rad, self._grid, self._inertia)

    def moment_arms(self, angle_deg) -> dict[str, np.ndarray]:
        """Total coupled moment arms (m) of every actuator's tendon at `angle_deg`, for `ForceLaw.load(arms=...)`."""
        names = actuators_of(MUSCLES)
        return dict(zip(names, self.tendon_geometry(angle_deg, names)[1].T))

    def load_law(self, muscle_model: str, muscles=tuple(ACTUATORS), condition: str | None = None, **fractions):
        """The tasks' force law of `muscles` (v2 tables, `TABLE_FOLDER`; a rerouted tendon's from its geometry's
        folder), one activation per muscle; `condition` (`shoulder_bench.conditions`, with its fractions
        tear_fraction, weakness_fraction) scales or removes muscles in a new law (a bad or needed-muscle-removing
        condition raises ValueError before any table is read). The condition's geometry must be this arm's
        (`arm_for(condition)` gives that arm)."""
        from shoulder_bench.conditions import factors, geometry
        from shoulder_bench.muscle import ForceLaw

        acts = actuators_of(muscles)
        scale = factors(condition, tuple(m for m in ACTUATORS if m in muscles), **fractions)
        if geometry(condition) != self.geometry:
            raise ValueError(f"condition {condition!r} has geometry {geometry(condition)!r}, this arm "
                             f"{self.geometry!r}: load the law from arm.arm_for(condition)")
        groups = {m: ACTUATORS[m] for m in ACTUATORS if m in muscles}
        own = _geometry(self.geometry)
        by_folder = {}  # folder -> its actuators
        for a in acts:
            by_folder.setdefault(own["tables"] if a in own["tendons"] else TABLE_FOLDER, []).append(a)
        tables = {t.muscle: t for folder, names in by_folder.items()
                  for t in ForceLaw.load(muscle_model, muscles=names, folder=folder, arms=self.moment_arms).tables}
        law = ForceLaw([tables[a] for a in acts], groups)
        return law.scaled(scale) if scale else law


_ARM: dict[str | None, Arm] = {}
_ARM_LOCK = threading.Lock()


def arm(geometry: str | None = None) -> Arm:
    """The tasks' arm of `geometry` (None: the intact shoulder; built once per process each, thread-safe)."""
    _geometry(geometry)
    with _ARM_LOCK:
        if geometry not in _ARM:
            _ARM[geometry] = Arm(geometry)
        return _ARM[geometry]


def arm_for(condition: str | None) -> Arm:
    """The arm whose geometry `condition` has (`conditions.geometry`: the intact one unless it reroutes a tendon)."""
    from shoulder_bench.conditions import geometry

    return arm(geometry(condition))
