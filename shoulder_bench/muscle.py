"""The muscle force law: tabled isometric force F(angle, activation), a force-velocity factor, passive force.

One implementation, written for arrays: the MuJoCo callback calls it with a batch of one, the batched simulator with
the whole batch. Tables live in `models/muscles/<muscle>_<model>.npz` (model "fem": from the thin-shell FEM, the
default; "hill": a Hill-type law fitted to the reference F0 and the MJCF moment arms, see
`shoulder_bench.authoring.hill`).

Table format (all arrays float64):
  angle_deg (K,)      uniform grid of abduction angles
  activation (J,)     ascending, activation[0] == 0, activation[-1] == 1
  force_N (K, J)      tendon force (pulling, N) at (angle, activation); column 0 is the passive force
  torque_Nm (K, J)    the joint torque the source model gives (positive elevates)
  moment_arm_m (K,)   the MJCF tendon moment arm the table was made for (positive elevates)
  meta                0-d string: JSON with the source ("fem"/"hill"), muscle, constants, grid, code version

Interpolation is bilinear (linear in angle on the uniform grid, linear in activation between levels); angles
outside the grid take the edge values. The force-velocity factor multiplies the active part only; it is MuJoCo's
piecewise-quadratic muscle curve (mju_muscleGainVelocity) with fvmax = 1.2 on the tendon velocity normalised by
vmax = 10 optimal fibre lengths per second (shortening lowers force to zero at vmax, lengthening raises it to 1.2).
"""
from __future__ import annotations

import contextlib
import dataclasses
import json
import math
import os
import threading
from dataclasses import dataclass
from pathlib import Path

import numba
import numpy as np

from shoulder_bench.paths import MODELS_DIR

FV_MAX = 1.2
VMAX_LOPT_PER_S = 10.0
MUSCLE_MODELS = ("fem", "hill")


# np.load parses each .npy header with ast.literal_eval, which on CPython 3.11 is not safe from several threads at once
# ("AST constructor recursion depth mismatch", seen once in tests/test_model.py's 8-thread test): tables are read
# one at a time
NPZ_LOCK = threading.Lock()


def check_muscle_model(muscle_model: str) -> str:
    """`muscle_model` if it is one of MUSCLE_MODELS, else a ValueError naming them."""
    if muscle_model not in MUSCLE_MODELS:
        raise ValueError(f"unknown muscle model {muscle_model!r}; choose one of {', '.join(MUSCLE_MODELS)}")
    return muscle_model


# Model v1's muscles (the shipped v1 tables, models/muscles) and their optimal fibre lengths (m; MoBL-ARMS SUPSP,
# INFSP, DELT2, LAT2), the force-velocity scale; anatomy re-exports them.
MUSCLES = ("ssp", "isp", "dmi", "ld")
OPTIMAL_FIBRE_LENGTH = {"ssp": 0.0682, "isp": 0.0755, "dmi": 0.1078, "ld": 0.2317}
REQUIRED_KEYS = ("angle_deg", "activation", "force_N", "torque_Nm", "moment_arm_m", "meta")


def table_path(muscle: str, muscle_model: str, folder: Path | None = None) -> Path:
    return Path(folder or MODELS_DIR / "muscles") / f"{muscle}_{muscle_model}.npz"


REBUILD = {"fem": "shoulder-bench fem build", "hill": "python -m shoulder_bench.authoring.hill"}


@contextlib.contextmanager
def replacing(path: Path):
    """Write `path` atomically: yields a temporary path beside it (same suffix) that replaces `path` (os.replace)
    when the block succeeds and is removed when it fails, so a failure never leaves a half-written file."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.stem}.tmp{path.suffix}")
    try:
        yield tmp
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


@dataclass(frozen=True)
class MuscleTable:
    muscle: str
    angle_deg: np.ndarray
    activation: np.ndarray
    force_N: np.ndarray
    torque_Nm: np.ndarray
    moment_arm_m: np.ndarray
    meta: dict

    @classmethod
    def load(cls, path: Path) -> MuscleTable:
        """Read and check a table; errors name the file and the command that rebuilds it."""
        path = Path(path)
        model = path.stem.rsplit("_", 1)[-1]
        fix = f"rebuild it with `{REBUILD.get(model, 'shoulder-bench fem build')}`"
        arrays, meta = read_table(path, REQUIRED_KEYS, fix)
        table = cls(muscle=meta.get("muscle", path.stem.rsplit("_", 1)[0]), meta=meta, **arrays)
        table._check(path, fix)
        return table

    def _check(self, path: Path, fix: str) -> None:
        k, j = len(self.angle_deg), len(self.activation)
        problems = []
        if self.force_N.shape != (k, j) or self.torque_Nm.shape != (k, j) or self.moment_arm_m.shape != (k,):
            problems.append("array shapes disagree")
        elif not all(np.all(np.isfinite(a)) for a in (self.force_N, self.torque_Nm, self.moment_arm_m)):
            problems.append("non-finite values")
        if k < 2 or not np.allclose(np.diff(self.angle_deg), self.angle_deg[1] - self.angle_deg[0]):
            problems.append("angle grid is not uniform")
        if not rising_activation(self.activation):
            problems.append("activation grid must rise from 0 to 1")
        if problems:
            raise ValueError(f"muscle table {path}: {'; '.join(problems)}; {fix}")

    def check_against_model(self, moment_arm_m: np.ndarray, path: Path) -> None:
        """The table must have been made for this MJCF: same tendon moment arms at its grid angles."""
        err = np.max(np.abs(moment_arm_m - self.moment_arm_m))
        if err > 1e-6:
            model, name = self.meta.get("model", "fem"), self.meta.get("model_file", MODEL_NAME)
            raise ValueError(
                f"muscle table {path} does not match the model {name}: its tendon moment arms differ by up "
                f"to {err * 1000:.3f} mm (the MJCF changed since the table was built); rebuild it with "
                f"`{REBUILD.get(model, REBUILD['fem'])}`")


MODEL_NAME = "models/shoulder.xml"


def rising_activation(activation: np.ndarray) -> bool:
    """Whether a table's activation levels rise strictly from 0 to 1 (at least two): what every force table needs."""
    a = np.asarray(activation)
    return len(a) >= 2 and a[0] == 0 and a[-1] == 1 and bool(np.all(np.diff(a) > 0))


def read_table(path: Path, keys: tuple[str, ...], fix: str) -> tuple[dict, dict]:
    """(float arrays of `keys` but "meta", the parsed meta JSON) of a table file; FileNotFoundError or ValueError
    naming the file and `fix` (what rebuilds it). The force tables' one reader (v1/v2 and the full shoulder's)."""
    if not path.exists():
        raise FileNotFoundError(f"muscle table {path} is missing; {fix}")
    try:
        with NPZ_LOCK, np.load(path, allow_pickle=False) as z:
            missing = [k for k in keys if k not in z.files]
            if missing:
                raise ValueError(f"lacks {missing}")
            arrays = {k: np.asarray(z[k], dtype=float) for k in keys if k != "meta"}
            meta = json.loads(str(z["meta"]))
    except Exception as exc:  # zip, pickle, JSON or key errors all mean the same thing to a user
        raise ValueError(f"muscle table {path} is unreadable or corrupt ({exc}); {fix}") from exc
    return arrays, meta


class ForceLaw:
    """Forces of n muscles, vectorised over a batch of states.

    The tables are stacked into one array F[angle, activation level, muscle] on the union of the muscles' activation
    levels (exact: each table is piecewise linear in activation and the union contains its knots), so one evaluation
    is a few array operations whatever the number of muscles.

    Muscles and actuators: each table drives one actuator (`actuators`, the tables' names, e.g. v2's tendons ssp, isp,
    dmi, ld1, ld2, ld3). `groups` (muscle -> its tables, in table order) lets one activation drive several tables (v2's
    ld = ld1 + ld2 + ld3): activations are per muscle (`muscles`, in `groups` order); forces, gains, moment arms are
    per actuator; `torque` is per muscle (the sum of its tables). Without groups every table is its own muscle.
    """

    def __init__(self, tables: list[MuscleTable], groups: dict[str, tuple[str, ...]] | None = None):
        self.tables = tables
        self.actuators = tuple(t.muscle for t in tables)
        groups = {a: (a,) for a in self.actuators} if groups is None else {g: tuple(v) for g, v in groups.items()}
        flat = [a for v in groups.values() for a in v]
        if sorted(flat) != sorted(self.actuators) or len(set(flat)) != len(flat):
            raise ValueError(f"muscle groups {groups} must name each table {self.actuators} exactly once")
        self.groups = groups
        self.muscles = tuple(groups)
        # the muscle (index into `muscles`) of each table / actuator column
        self.muscle_of = np.array([next(k for k, v in enumerate(groups.values()) if a in v) for a in self.actuators])
        self._sum = np.zeros((len(tables), len(groups)))  # per-actuator -> per-muscle sums
        self._sum[np.arange(len(tables)), self.muscle_of] = 1.0
        self.first_table = [self.actuators.index(v[0]) for v in groups.values()]  # where each muscle's ctrl is read
        self._grouped = len(groups) != len(tables)
        grid = tables[0].angle_deg
        for t in tables:
            if t.angle_deg.shape != grid.shape or not np.allclose(t.angle_deg, grid, rtol=0.0, atol=1e-9):
                raise ValueError("all muscle tables of a law must share one angle grid")
        levels = np.unique(np.concatenate([t.activation for t in tables]))
        force = np.stack([np.stack([np.interp(levels, t.activation, row) for row in t.force_N]) for t in tables],
                         axis=-1)  # (K, J, n)
        self.levels = levels
        self._n = len(tables)
        self._k, self._j = force.shape[0], force.shape[1]
        self._flat = np.ascontiguousarray(force.ravel())
        self._a0 = np.radians(grid[0])
        self._inv_da = 1.0 / np.radians(grid[1] - grid[0])
        self._arm = np.ascontiguousarray(np.stack([t.moment_arm_m for t in tables], axis=1))  # (K, n)
        self._one_state = np.zeros(2)
        self._one_act = np.zeros((1, self._n))  # per actuator (activations expanded from the muscles')
        self._one_out = np.zeros((5, 1, self._n))
        self._neg_inv_vscale = -1.0 / np.array([VMAX_LOPT_PER_S * _optimal_fibre_length(t) for t in tables])

    @classmethod
    def load(cls, muscle_model: str = "fem", muscles=MUSCLES, folder: Path | None = None,
             arms=None, groups: dict | None = None) -> ForceLaw:
        """The law of `muscles` from `<folder>/<muscle>_<muscle_model>.npz`, each table checked against the model's
        moment arms on its angle grid.

        folder: default the shipped v1 tables (then only MUSCLES); with a folder any muscle with a table
        there (v2's tendons). arms: the model's moment arms (m) on the tables' grid, a dict muscle -> (K,) or a
        callable angle_deg (K,) -> such a dict; default v1's MJCF (`geometry.moment_arms`). groups: as `ForceLaw`
        (then `muscles` are the tables to load, in actuator order)."""
        check_muscle_model(muscle_model)
        muscles = tuple(muscles)
        if folder is None:
            unknown = [m for m in muscles if m not in MUSCLES]
            if unknown:
                raise ValueError(f"unknown muscle(s) {unknown}; choose from {MUSCLES} (or give the folder "
                                 "of their tables)")
        paths = [table_path(m, muscle_model, folder) for m in muscles]
        tables = [MuscleTable.load(p) for p in paths]
        for m, t, p in zip(muscles, tables, paths):
            if t.muscle != m:
                raise ValueError(f"muscle table {p} is for {t.muscle!r}, not {m!r}")
        grid = tables[0].angle_deg
        if arms is None:
            arms = _model_moment_arms(grid)
        elif callable(arms):
            arms = arms(grid)
        for m, t, p in zip(muscles, tables, paths):
            if m not in arms:
                raise ValueError(f"no model moment arm given for {m!r} (arms has {sorted(arms)})")
            t.check_against_model(np.asarray(arms[m], dtype=float), p)
        return cls(tables, groups)

    def scaled(self, factors: dict[str, float]) -> ForceLaw:
        """A new law with each muscle's tables (all of a group's: ld1-3 for ld) scaled by `factors[muscle]`: the
        whole tabled force (active and passive) and torque; moment arms and force-velocity unchanged. This law is
        not changed. Factors: finite numbers >= 0 (0 removes the muscle); muscles not named keep factor 1."""
        unknown = [m for m in factors if m not in self.groups]
        if unknown:
            raise ValueError(f"cannot scale muscle(s) {unknown}: the law has {self.muscles}")
        bad = {m: f for m, f in factors.items() if not (math.isfinite(float(f)) and float(f) >= 0.0)}
        if bad:
            raise ValueError(f"muscle force factors must be finite numbers >= 0; got {bad}")
        per_table = {a: float(f) for m, f in factors.items() for a in self.groups[m]}
        tables = [t if per_table.get(t.muscle, 1.0) == 1.0 else dataclasses.replace(
            t, force_N=t.force_N * per_table[t.muscle], torque_Nm=t.torque_Nm * per_table[t.muscle],
            meta={**t.meta, "force_factor": per_table[t.muscle]}) for t in self.tables]
        return ForceLaw(tables, self.groups)

    def _evaluate_all(self, angle, velocity, activation) -> np.ndarray:
        """(5, B, n): active force, active per unit activation, passive force, force-velocity factor, gain."""
        angle = np.ascontiguousarray(angle, dtype=np.float64)
        velocity = np.ascontiguousarray(velocity, dtype=np.float64)
        activation = np.ascontiguousarray(np.asarray(activation, dtype=np.float64)[:, self.muscle_of])
        out = np.empty((5,) + activation.shape)
        _kernel(self._flat, self._arm, self.levels, self._a0, self._inv_da, self._neg_inv_vscale,
                angle, velocity, activation, out)
        return out

    def _evaluate(self, angle, velocity, activation):
        """(active, per-unit active, passive, force-velocity factor), each (B, n), from one kernel pass."""
        out = self._evaluate_all(angle, velocity, activation)
        return out[0], out[1], out[2], out[3]

    def gain_bias_one(self, angle: float, velocity: float, activation: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The callback's entry: one state, activations per muscle; returns (gain, bias) per actuator, views of a
        reused buffer."""
        self._one_state[0] = angle
        self._one_state[1] = velocity
        self._one_act[0] = np.asarray(activation)[self.muscle_of]
        out = self._one_out
        _kernel(self._flat, self._arm, self.levels, self._a0, self._inv_da, self._neg_inv_vscale,
                self._one_state[:1], self._one_state[1:], self._one_act, out)
        return out[4, 0], out[2, 0]

    def kernel_arguments(self) -> tuple:
        """(flat table, moment arms (K, n), activation levels, first grid angle (rad), 1 / grid step (1/rad),
        -1 / FV velocity scale per actuator): what the law's arithmetic (`law_point`) reads; the compiled callback
        (`shoulder_bench.native`) holds them."""
        return self._flat, self._arm, self.levels, self._a0, self._inv_da, self._neg_inv_vscale

    def moment_arm(self, angle: np.ndarray) -> np.ndarray:
        """(B, n) tendon moment arms (m) interpolated from the tables at angles (rad)."""
        x = np.clip((np.asarray(angle, dtype=float) - self._a0) * self._inv_da, 0.0, self._k - 1.000001)
        i = x.astype(np.int64)
        w = (x - i)[:, None]
        return self._arm[i] + (self._arm[i + 1] - self._arm[i]) * w

    def force_velocity(self, angle: np.ndarray, velocity: np.ndarray) -> np.ndarray:
        """(B, n) force-velocity factor from the joint angular velocity (rad/s) through the moment arms."""
        return self._evaluate(angle, velocity, np.zeros((len(angle), len(self.muscles))))[3]

    def force(self, angle: np.ndarray, velocity: np.ndarray, activation: np.ndarray) -> np.ndarray:
        """(B, actuators) tendon forces (N, pulling) for angles (B,) rad, velocities (B,) rad/s, activations
        (B, muscles)."""
        active, _, passive, fv = self._evaluate(angle, velocity, activation)
        return active * fv + passive

    def gain_bias(self, angle: np.ndarray, velocity: np.ndarray, activation: np.ndarray):
        """Split `force` as MuJoCo's `gain * activation + bias`: gain = active force per unit activation."""
        out = self._evaluate_all(angle, velocity, activation)
        return out[4], out[2]

    def torque(self, angle: np.ndarray, velocity: np.ndarray, activation: np.ndarray) -> np.ndarray:
        """(B, muscles) joint torques (N m, positive elevates), using the tabled moment arms; a muscle's is the sum of
        its tables'."""
        per_actuator = self.force(angle, velocity, activation) * self.moment_arm(angle)
        return per_actuator @ self._sum if self._grouped else per_actuator


def _optimal_fibre_length(t: MuscleTable) -> float:
    """The table's own `optimal_fibre_length_m` (v2's tables record it); v1's tables, which do not, take
    OPTIMAL_FIBRE_LENGTH."""
    if "optimal_fibre_length_m" in t.meta:
        return float(t.meta["optimal_fibre_length_m"])
    return OPTIMAL_FIBRE_LENGTH[t.muscle]


@numba.njit(inline="always")
def law_cell(angle, a0, inv_da, kmax):
    """The angle's grid cell and the weight within it: (i, w), angles beyond the grid at its edges."""
    x = min(max((angle - a0) * inv_da, 0.0), kmax)
    i = int(x)
    return i, x - i


@numba.njit(inline="always")
def law_point(flat, arm, levels, n, c, i, w, activation, velocity, neg_inv_vscale):
    """The law for column `c` of a law with `n` columns at grid cell (i, w): (active force, active force per unit
    activation, passive force, FV factor). The one implementation of the arithmetic: the batch kernel (`_kernel`) and
    the compiled MuJoCo callback (`shoulder_bench.native`) both inline it."""
    nj = levels.shape[0]
    stride = nj * n
    a = min(max(activation, 0.0), 1.0)
    j = 0
    while j < nj - 2 and levels[j + 1] <= a:
        j += 1
    u = (a - levels[j]) / (levels[j + 1] - levels[j])
    p0 = flat[i * stride + c]
    passive = p0 + (flat[(i + 1) * stride + c] - p0) * w
    k = i * stride + j * n + c
    lo = flat[k] + (flat[k + stride] - flat[k]) * w
    hi = flat[k + n] + (flat[k + n + stride] - flat[k + n]) * w
    active = lo + (hi - lo) * u - passive
    # On the first level cell the law is linear in activation from the passive force: there the force per unit
    # activation is the cell's slope (also at zero activation); elsewhere active force / activation.
    per_unit = (hi - passive) / levels[1] if j == 0 else active / a
    r = arm[i, c] + (arm[i + 1, c] - arm[i, c]) * w
    v = r * velocity * neg_inv_vscale  # tendon lengthening rate in units of vmax
    if v <= 0.0:
        s = max(v + 1.0, 0.0)
        fv = s * s
    else:
        s = max(FV_MAX - 1.0 - v, 0.0)
        fv = FV_MAX - s * s / (FV_MAX - 1.0)
    return active, per_unit, passive, fv


@numba.njit(cache=True, nogil=True)
def _kernel(flat, arm, levels, a0, inv_da, neg_inv_vscale, angle, velocity, activation, out):
    """The law for a batch: out[0..4] = active force, active force per unit activation, passive force, FV factor, and
    MuJoCo's gain (active per unit activation x FV).

    Compiled (numba) because it runs at every physics step, often for one state, where numpy's per-call overhead
    (~1 us per operation) would cost more than the physics; one kernel serves the callback and the batch alike.
    """
    nb, n = activation.shape
    kmax = arm.shape[0] - 1.000001
    for b in range(nb):
        i, w = law_cell(angle[b], a0, inv_da, kmax)
        for c in range(n):
            active, per_unit, passive, fv = law_point(flat, arm, levels, n, c, i, w, activation[b, c], velocity[b],
                                                      neg_inv_vscale[c])
            out[0, b, c] = active
            out[1, b, c] = per_unit
            out[2, b, c] = passive
            out[3, b, c] = fv
            out[4, b, c] = per_unit * fv


_ARM_CACHE: dict[tuple, dict[str, np.ndarray]] = {}


def _model_moment_arms(angle_deg: np.ndarray) -> dict[str, np.ndarray]:
    from shoulder_bench.geometry import moment_arms

    key = tuple(np.round(angle_deg, 9))
    if key not in _ARM_CACHE:
        _ARM_CACHE[key] = moment_arms(angle_deg)
    return _ARM_CACHE[key]
