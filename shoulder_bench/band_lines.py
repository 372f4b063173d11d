"""The footprint sheets' line of action in MuJoCo (issue 12 §2): the band tables' corrections to the MJCF tendons'
moment arms, applied at every RK4 stage. How the tables are made: `shoulder_bench.authoring.fem.bands`, docs/fem.md
"Taut bands".

A tendon t with a band table pulls with its FEM force F_t (`tendon_law.TendonLaw`; at the band's length, below)
along its MJCF path, which MuJoCo's tendon transmission applies (generalised force F_t r_MJCF(q) about plane, elevation
and rotation), and here in addition with F_t c_t(q) about the three coordinates: c_t the taut band's moment arms less
the MJCF's, tabled on the tasks' pose grid and read trilinearly (poses beyond the grid at its edges). Together: F_t
(r_MJCF + c_t), the band's line of action. The tendons without a table (dmi, cor) keep their MJCF paths.

Why a passive-force callback: a MuJoCo actuator acts along its transmission only (here the MJCF tendon), and no
transmission has a pose-dependent direction of its own; `mjcb_passive` is MuJoCo's hook for generalised forces added
at each evaluation, called after the tendon lengths and velocities are known and before the accelerations, at every
RK4 stage. `shoulder_bench.native.passive` is the compiled (GIL-free) callback, the only one (a Python passive
callback would make every model compile fail: `model.install_callbacks`); it reads F from the same law arithmetic as
the actuator callbacks and c from `band_point` below, as `BandLines.correction` does.

The force's length is the band's own (`band_length`): a cable on frictionless surfaces has arms r = -dL/dq, and the
band's are nearly the gradient of a length (`benchmarks/band_potential.py`: their least-squares potential over the
grid misses them by 0.001-0.075 mm RMS along the grid's edges), so F_t is read at L_MT(q) + D_t(q), D_t = L_band -
L_MJCF that potential of -c_t at a = 1, zero at LENGTH_ANCHOR_DEG (the footprint sheets' reference pose, where the
band's length is taken to be the MJCF path's), and at the lengthening rate -(r_MJCF + c_t) . qdot along the line the
force acts on. Not exactly a gradient: the band is made stress-free anew at each pose, its load shared among fibres
differently from pose to pose, so a constant activation does some work round a closed path of poses, keyed on either
length (docs/fem.md "The band's own length").

Below a = 1 the band's line moves (docs/fem.md "The activation"); for the tendons with a level table
(`<tendon>_band_levels.npz`, `fem.band_levels`) the correction is c_t(q) + (r_band(q, a) - r_band(q, 1)), the second
term tabled on the tasks' grid at a few activation levels and read trilinearly in the pose and linearly in a (below
the lowest level: that level's; a = the actuator's ctrl, at which its force is computed). The other tendons'
correction does not depend on a.

With line_of_action="band_fibres" the force is also the band's fibres', not one length's: F_t = mean_i F(L_MT(q) +
D_t(q) + d_ti(q), a, v), d_ti fibre i's length change less the band's mean fibre's (`<tendon>_fibres.npz`,
`fem.band_fibres`, on the tasks' grid, read trilinearly; `fibre_law` below is the one implementation the compiled
callbacks inline, `TendonLaw.gain_bias_one` the Python one's).

Table format (`models/muscles_full/<tendon>_band.npz`, written by `shoulder-bench fem build --bands`):
  plane_deg (P,), elevation_deg (E,), rotation_deg (R,)   the grid, uniform and ascending (the tasks' pose grid or
                                                           one nesting it, `fem.bands.REFINE`)
  moment_arm_m (P, E, R, 3)                                the band's moment arms about plane, elevation, rotation
  mjcf_moment_arm_m (P, E, R, 3)                           the MJCF tendon's at the same poses
  meta                                                     0-d JSON string (tendon, input_hash, ...)
Level table (`<tendon>_band_levels.npz`): the same axes (the tasks' grid), activation (L,) descending from 1.0 in
equal steps, moment_arm_m (L, P, E, R, 3) the band's arms at each level, meta (band_table_hash: the input hash of the
band table it goes with).
"""
from __future__ import annotations

import hashlib
import json
import math
from pathlib import Path

import numba
import numpy as np

from shoulder_bench.muscle import law_cell, law_point

# the tendons whose footprint sheet is resolved (fem.bands)
BAND_TENDONS = ("ssp", "isp", "ssc", "tmi", "tma", "pec1", "pec2", "pec3", "dpo", "dan", "ld1", "ld2", "ld3")
LINES = ("mjcf", "band", "band_fibres")  # the 3-DOF tasks' `line_of_action` option
AXES = ("plane_deg", "elevation_deg", "rotation_deg")
REBUILD = "shoulder-bench fem build --bands"
# where a band's length is taken to be its MJCF path's (`band_length`): the footprint sheets' reference pose
# (`authoring.fem.footprint.REFERENCE_POSE_DEG`), deg
LENGTH_ANCHOR_DEG = (30.0, 45.0, 0.0)


def table_path(tendon: str, folder: Path | None = None) -> Path:
    from shoulder_bench.full_arm import TABLE_FOLDER

    return Path(folder or TABLE_FOLDER) / f"{tendon}_band.npz"


def levels_path(tendon: str, folder: Path | None = None) -> Path:
    return table_path(tendon, folder).with_name(f"{tendon}_band_levels.npz")


def fibres_path(tendon: str, folder: Path | None = None) -> Path:
    return table_path(tendon, folder).with_name(f"{tendon}_fibres.npz")


def read_fibres(path: Path, tendon: str) -> tuple[dict, dict]:
    """A fibre table's arrays (the axes, departure_m (P, E, R, nt)) and meta; errors name the file and the command
    that builds it."""
    fix = f"build it with `shoulder-bench fem build --fibres --tendon {tendon}`"
    try:
        with np.load(path) as z:
            arrays = {k: z[k] for k in (*AXES, "departure_m")}
            meta = json.loads(str(z["meta"]))
    except FileNotFoundError:
        raise ValueError(f"no fibre table {path}: {fix}") from None
    except (OSError, KeyError, ValueError) as exc:
        raise ValueError(f"unreadable fibre table {path} ({exc}): {fix}") from None
    if meta.get("tendon") != tendon:
        raise ValueError(f"fibre table {path} is for {meta.get('tendon')!r}, not {tendon!r}: {fix}")
    return arrays, meta


def read_levels(path: Path, band_meta: dict) -> tuple[dict, dict]:
    """(arrays, meta) of a level table made for the band table whose meta is `band_meta`; ValueError naming the file
    and the command that rebuilds it."""
    arrays, meta = read_table(path, LEVEL_ARRAYS)
    levels, shape = arrays["activation"], tuple(len(arrays[k]) for k in AXES)
    step = np.diff(levels)
    if not (len(levels) >= 2 and levels[0] == 1.0 and levels[-1] > 0 and np.allclose(step, step[0]) and step[0] < 0
            and arrays["moment_arm_m"].shape == (len(levels), *shape, 3)):
        raise ValueError(f"{path}: not a level table (activation {levels.tolist()}, arms "
                         f"{arrays['moment_arm_m'].shape}); rebuild it with `{REBUILD}`")
    if meta.get("band_table_hash") != band_meta.get("input_hash"):
        raise ValueError(f"{path}: made for another band table than {table_path(meta.get('tendon', '?'), path.parent)}"
                         f"; rebuild both with `{REBUILD}`")
    return arrays, meta


LEVEL_ARRAYS = ("activation", "moment_arm_m")


def read_table(path: Path, arrays_named=("moment_arm_m", "mjcf_moment_arm_m")) -> tuple[dict, dict]:
    """(arrays, meta) of a band table; ValueError naming the file and the command that rebuilds it."""
    path = Path(path)
    try:
        with np.load(path, allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
        meta = json.loads(str(arrays.pop("meta")))
    except (OSError, ValueError, KeyError) as exc:
        raise ValueError(f"{path}: not a band table ({exc}); rebuild it with `{REBUILD}`") from exc
    problems = [k for k in (*AXES, *arrays_named) if k not in arrays]
    if not problems:
        shape = tuple(len(arrays[k]) for k in AXES) + (3,)
        if "mjcf_moment_arm_m" in arrays_named and (arrays["moment_arm_m"].shape != shape
                                                   or arrays["mjcf_moment_arm_m"].shape != shape):
            problems.append(f"arm arrays are not {shape}")
        for k in AXES:
            step = np.diff(arrays[k])
            if len(arrays[k]) < 2 or not np.allclose(step, step[0]) or step[0] <= 0:
                problems.append(f"{k} is not uniform and ascending")
        if not np.all(np.isfinite(arrays["moment_arm_m"])) or not np.all(np.isfinite(arrays.get("mjcf_moment_arm_m",
                                                                                              0.0))):
            problems.append("non-finite arms")
    if problems:
        raise ValueError(f"{path}: not a band table ({'; '.join(problems)}); rebuild it with `{REBUILD}`")
    return arrays, meta


def integrate_arms(arms: np.ndarray, steps_rad) -> tuple[np.ndarray, np.ndarray]:
    """(L (P, E, R), zero at the grid's first pose; edge residuals (edges,)): the least-squares length whose
    differences along the grid's edges are -h_k (r_k,i + r_k,j) / 2 (the trapezoid rule), for moment arms `arms`
    (P, E, R, 3) on a uniform grid with steps `steps_rad` (3,) about plane, elevation and rotation; r = -dL/dq."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.linalg import spsolve

    shape = arms.shape[:3]
    index = np.arange(int(np.prod(shape))).reshape(shape)
    cols, rhs = [], []
    for k in range(3):
        lo, hi = (np.take(index, range(o, shape[k] - 1 + o), axis=k).ravel() for o in (0, 1))
        r_lo, r_hi = (np.take(arms[..., k], range(o, shape[k] - 1 + o), axis=k).ravel() for o in (0, 1))
        cols.append((hi, lo))
        rhs.append(-steps_rad[k] * (r_lo + r_hi) / 2.0)
    hi, lo = (np.concatenate([c[j] for c in cols]) for j in (0, 1))
    n = len(hi)
    a = coo_matrix((np.r_[np.ones(n), -np.ones(n)], (np.r_[np.arange(n), np.arange(n)], np.r_[hi, lo])),
                   shape=(n, index.size)).tocsc()
    b = np.concatenate(rhs)
    free = a[:, 1:]  # the first pose's length fixed at 0
    x = np.r_[0.0, spsolve((free.T @ free).tocsc(), free.T @ b)]
    return x.reshape(shape), a @ x - b


def band_length(correction: np.ndarray, axes_deg) -> np.ndarray:
    """D = L_band - L_MJCF (P, E, R) m on a band table's grid `axes_deg`, from its correction c = r_band - r_MJCF
    (P, E, R, 3) m at a = 1: the least-squares potential of -c (`integrate_arms`), zero at LENGTH_ANCHOR_DEG (read
    trilinearly). Solved once per correction and grid in a process (read-only; `_LENGTHS`)."""
    axes = [np.asarray(a, dtype=float) for a in axes_deg]
    key = hashlib.sha256(b"".join(np.ascontiguousarray(x, dtype=float).tobytes() for x in (correction, *axes)))
    d = _LENGTHS.get(key.hexdigest())
    if d is None:
        d, _ = integrate_arms(correction, [np.radians(a[1] - a[0]) for a in axes])
        d = d - float(_resample(d[..., None], axes, [np.array([v]) for v in LENGTH_ANCHOR_DEG]).ravel()[0])
        d.flags.writeable = False
        d = _LENGTHS.setdefault(key.hexdigest(), d)
    return d


_LENGTHS: dict[str, np.ndarray] = {}  # band_length's solutions, by the digest of their correction and grid


def grid_constants(axes_deg, levels) -> tuple[np.ndarray, np.ndarray]:
    """(grid (8,), shape (4,)) as the callbacks read a table: per coordinate its first pose (rad) and 1 / step
    (1/rad), as `law_cell` reads them, then the same for the activation levels; (planes, elevations, rotations,
    levels)."""
    da = levels[1] - levels[0] if len(levels) > 1 else 1.0
    grid = np.concatenate([[np.radians(a[0]) for a in axes_deg], [1.0 / np.radians(a[1] - a[0]) for a in axes_deg],
                           [levels[0], 1.0 / da]])
    return grid, np.array([len(a) for a in axes_deg] + [len(levels)], dtype=np.int64)


class BandLines:
    """The band corrections of `tendons` on one grid and at activation `levels` (ascending, equal steps, ending at 1;
    (1.0,) when none depends on it), and their band lengths (`lengths`, (n, P, E, R) m: `band_length` on that grid):
    `correction(poses_deg, activation)` (P, n, 3) m, `lengthening(...)`. `load` reads the tables."""

    def __init__(self, tendons, axes_deg, correction: np.ndarray, lengths: np.ndarray, levels=(1.0,)):
        self.tendons = tuple(tendons)
        self.axes_deg = [np.asarray(a, dtype=float) for a in axes_deg]
        self.levels = np.asarray(levels, dtype=float)
        shape = (len(self.levels),) + tuple(len(a) for a in self.axes_deg)
        self.table = np.ascontiguousarray(correction, dtype=np.float64)  # (n, L, P, E, R, 3)
        if self.table.shape != (len(self.tendons), *shape, 3):
            raise ValueError(f"band corrections of shape {self.table.shape}, expected {(len(self.tendons), *shape, 3)}")
        self.grid, self.shape = grid_constants(self.axes_deg, self.levels)
        # (n, P, E, R) m: each tendon's band length less its MJCF path's (`band_length`)
        self.lengths = np.ascontiguousarray(lengths, dtype=np.float64)
        if self.lengths.shape != self.table.shape[:1] + self.table.shape[2:5]:
            raise ValueError(f"band lengths of shape {self.lengths.shape}, expected {self.table.shape[:1] + shape[1:]}")
        self.fibres = None  # (n, 1, P, E, R, nt) m: each band's fibres' departures from its mean fibre ("band_fibres")
        self.fibre_grid, self.fibre_shape = None, None  # on the fibre tables' own grid (`grid_constants`)

    @classmethod
    def load(cls, tendons=BAND_TENDONS, folder: Path | None = None, fibres: bool = False) -> BandLines:
        """The tables `<folder>/<tendon>_band.npz` (default models/muscles_full), read on the coarsest grid that
        nests all of theirs (per coordinate the same range, its number of steps the least common multiple of theirs):
        each resampled there linearly along each coordinate in turn, which leaves its trilinear reading exactly as it
        was (a trilinear function restricted to a sub-cell is trilinear). Tables over different ranges are refused.
        With the level tables beside them (`levels_path`; all at the same levels): each level's correction is the
        band table's plus that level's arms less its a = 1 arms, read the same way. fibres: also each band's fibre
        table (`fibres_path`), all on one grid (the tasks', which the tables' grid nests), kept and read on it (the
        same values to rounding as on the nesting grid, which holds 55 times as many poses)."""
        tendons = tuple(tendons)
        unknown = [t for t in tendons if t not in BAND_TENDONS]
        if unknown:
            raise ValueError(f"no band table for {unknown}; tendons with one: {', '.join(BAND_TENDONS)}")
        tables = [read_table(table_path(t, folder)) for t in tendons]
        levels = {t: read_levels(levels_path(t, folder), meta)[0] for t, (_, meta) in zip(tendons, tables)
                  if levels_path(t, folder).exists()}
        found = {tuple(a["activation"].tolist()) for a in levels.values()}
        if len(found) > 1:
            raise ValueError(f"level tables at different activation levels ({sorted(found)}); rebuild them with "
                             f"`{REBUILD}`")
        descending = np.array(found.pop() if found else (1.0,))
        grids = [a for a, _ in tables] + list(levels.values())
        axes = [np.linspace(grids[0][k][0], grids[0][k][-1], math.lcm(*(len(a[k]) - 1 for a in grids)) + 1)
                for k in AXES]
        for t, a in [(t, a) for t, (a, _) in zip(tendons, tables)] + list(levels.items()):
            if not all(_nests(ax, a[k]) for k, ax in zip(AXES, axes)):
                raise ValueError(f"{table_path(t, folder)}: its pose grid spans other ranges than "
                                 f"{', '.join(tendons)}'s; rebuild the tables with `{REBUILD}`")
        out, lengths = [], []
        for t, (a, _) in zip(tendons, tables):
            own = [a[k] for k in AXES]
            correction = a["moment_arm_m"] - a["mjcf_moment_arm_m"]
            lengths.append(_resample(band_length(correction, own)[..., None], own, axes)[..., 0])
            c = _resample(correction, own, axes)
            at = [np.zeros_like(c)] * len(descending)  # each level's arms less the a = 1 arms
            if t in levels:
                lv = levels[t]
                at = [_resample(arms - lv["moment_arm_m"][0], [lv[k] for k in AXES], axes)
                      for arms in lv["moment_arm_m"]]
            out.append(np.stack([c + d for d in at[::-1]]))  # ascending in activation
        lines = cls(tendons, axes, np.stack(out), np.stack(lengths), descending[::-1])
        if fibres:
            read = [read_fibres(fibres_path(t, folder), t)[0] for t in tendons]
            own = [read[0][k] for k in AXES]
            if len({f["departure_m"].shape for f in read}) != 1 or \
                    not all(np.allclose(f[k], a) for f in read for k, a in zip(AXES, own)) or \
                    not all(_nests(ax, a) for ax, a in zip(axes, own)):
                raise ValueError(f"fibre tables of {', '.join(tendons)} on other grids or with other fibre counts than "
                                 "each other's or the band tables'; rebuild them with `shoulder-bench fem build "
                                 "--fibres`")
            lines.fibres = np.ascontiguousarray(np.stack([f["departure_m"] for f in read])[:, None], dtype=np.float64)
            lines.fibre_grid, lines.fibre_shape = grid_constants(own, (1.0,))
        return lines

    def correction(self, poses_deg, activation=1.0) -> np.ndarray:
        """(P, n, 3) m: each tendon's band moment arms less its MJCF ones at `poses_deg` (P, 3) and `activation` (a
        number, or per pose and tendon (P, n); clipped to [0, 1]), trilinear between the grid's poses (beyond the
        grid: its edges) and linear between the levels (below the lowest: its values), as the callbacks read them."""
        q = np.radians(np.atleast_2d(np.asarray(poses_deg, dtype=float)))
        a = np.ascontiguousarray(np.broadcast_to(np.clip(activation, 0.0, 1.0), (len(q), len(self.tendons))),
                                 dtype=np.float64)
        out = np.empty((len(q), len(self.tendons), 3))
        _corrections(self.table, self.grid, self.shape, q, a, out)
        return out

    def lengthening(self, poses_deg, rates_rad_s=None, activation=1.0) -> tuple[np.ndarray, np.ndarray]:
        """((P, n) m, (P, n) m/s): each tendon's band length less its MJCF path's at `poses_deg` (P, 3), and its
        lengthening rate less the MJCF path's, -c . qdot at the coordinates' rates `rates_rad_s` (P, 3) (None: at
        rest) along the line at `activation` (as `correction` takes it), as the callbacks read them."""
        q = np.radians(np.atleast_2d(np.asarray(poses_deg, dtype=float)))
        v = np.zeros_like(q) if rates_rad_s is None else np.atleast_2d(np.asarray(rates_rad_s, dtype=float))
        a = np.ascontiguousarray(np.broadcast_to(np.clip(activation, 0.0, 1.0), (len(q), len(self.tendons))),
                                 dtype=np.float64)
        dl, dv = np.empty((len(q), len(self.tendons))), np.empty((len(q), len(self.tendons)))
        _lengthenings(self.lengths[:, None, ..., None], self.table, self.grid, self.shape, q,
                      np.ascontiguousarray(v), a, dl, dv)
        return dl, dv

    def departures(self, poses_deg) -> np.ndarray:
        """(P, n, nt) m: each tendon's band's fibres' departures from its mean fibre at `poses_deg` (P, 3), read as
        the callbacks read them (`fibre_law`). Only for lines loaded with fibres."""
        if self.fibres is None:
            raise ValueError("these band lines have no fibre tables (BandLines.load(..., fibres=True))")
        q = np.radians(np.atleast_2d(np.asarray(poses_deg, dtype=float)))
        out = np.empty((len(q), len(self.tendons), self.fibres.shape[-1]))
        _departures(self.fibres, self.fibre_grid, self.fibre_shape, q, out)
        return out


def _nests(fine: np.ndarray, coarse: np.ndarray) -> bool:
    """Whether the grid values `fine` hold every one of `coarse`'s and span the same range."""
    return bool(np.isclose(fine[0], coarse[0]) and np.isclose(fine[-1], coarse[-1])
                and np.isclose(fine[:, None], coarse[None]).any(axis=0).all())


def _resample(values: np.ndarray, axes_from, axes_to) -> np.ndarray:
    """`values` (P, E, R, 3) on the grid `axes_from` read on `axes_to`, linearly along each coordinate in turn."""
    for k, (a, b) in enumerate(zip(axes_from, axes_to)):
        values = np.apply_along_axis(lambda v, a=a, b=b: np.interp(b, a, v), k, values)
    return values


@numba.njit(inline="always")
def band_cells(q0, q1, q2, grid, shape):
    """The pose's grid cell and weights per coordinate (q in rad), as `law_cell` finds a length's."""
    i0, w0 = law_cell(q0, grid[0], grid[3], shape[0] - 1.000001)
    i1, w1 = law_cell(q1, grid[1], grid[4], shape[1] - 1.000001)
    i2, w2 = law_cell(q2, grid[2], grid[5], shape[2] - 1.000001)
    return i0, w0, i1, w1, i2, w2


@numba.njit(inline="always")
def band_level(a, grid, shape):
    """The activation's level cell and weight (a in [0, 1]; one level: that one). At the top level the weight is 1
    exactly, so that a = 1 reads the band table's correction as it is."""
    if shape[3] == 1:
        return 0, 0.0
    x = min(max((a - grid[6]) * grid[7], 0.0), shape[3] - 1.0)
    j = min(int(x), shape[3] - 2)
    return j, x - j


@numba.njit(inline="always")
def band_point(table, b, k, j, wj, i0, w0, i1, w1, i2, w2):
    """Tendon b's correction about coordinate k at a cell (`band_cells`) and level cell (`band_level`): trilinear in
    the cell's 8 corners, linear between the two levels. The one implementation: `BandLines.correction` and the
    compiled passive callback both inline it."""
    out = 0.0
    for dj in range(2 if wj != 0.0 else 1):
        uj = wj if dj else 1.0 - wj
        for d0 in range(2):
            u0 = w0 if d0 else 1.0 - w0
            for d1 in range(2):
                u1 = w1 if d1 else 1.0 - w1
                for d2 in range(2):
                    u2 = w2 if d2 else 1.0 - w2
                    out += uj * u0 * u1 * u2 * table[b, j + dj, i0 + d0, i1 + d1, i2 + d2, k]
    return out


@numba.njit(cache=True, nogil=True)
def _corrections(table, grid, shape, q, a, out):
    for p in range(q.shape[0]):
        i0, w0, i1, w1, i2, w2 = band_cells(q[p, 0], q[p, 1], q[p, 2], grid, shape)
        for b in range(table.shape[0]):
            j, wj = band_level(a[p, b], grid, shape)
            for k in range(3):
                out[p, b, k] = band_point(table, b, k, j, wj, i0, w0, i1, w1, i2, w2)


@numba.njit(inline="always")
def band_lengthening(lengths, table, b, a, q0, q1, q2, v0, v1, v2, grid, shape):
    """Tendon b's band length less its MJCF path's at pose (q0, q1, q2) rad (`lengths`, (n, 1, P, E, R, 1): one
    level, one component, read trilinearly by `band_point`) and its lengthening rate less the MJCF path's at the
    coordinates' rates (v0, v1, v2) rad/s along the line at activation a: -(c_0 v0 + c_1 v1 + c_2 v2). The one
    implementation: `BandLines.lengthening` and the compiled actuator callbacks both inline it."""
    i0, w0, i1, w1, i2, w2 = band_cells(q0, q1, q2, grid, shape)
    dl = band_point(lengths, b, 0, 0, 0.0, i0, w0, i1, w1, i2, w2)
    j, wj = band_level(a, grid, shape)
    dv = -(v0 * band_point(table, b, 0, j, wj, i0, w0, i1, w1, i2, w2)
           + v1 * band_point(table, b, 1, j, wj, i0, w0, i1, w1, i2, w2)
           + v2 * band_point(table, b, 2, j, wj, i0, w0, i1, w1, i2, w2))
    return dl, dv


@numba.njit(cache=True, nogil=True)
def _lengthenings(lengths, table, grid, shape, q, v, a, dl, dv):
    for p in range(q.shape[0]):
        for b in range(table.shape[0]):
            dl[p, b], dv[p, b] = band_lengthening(lengths, table, b, a[p, b], q[p, 0], q[p, 1], q[p, 2], v[p, 0],
                                                  v[p, 1], v[p, 2], grid, shape)


@numba.njit(cache=True, nogil=True)
def _departures(fibres, grid, shape, q, out):
    for p in range(q.shape[0]):
        i0, w0, i1, w1, i2, w2 = band_cells(q[p, 0], q[p, 1], q[p, 2], grid, shape)
        for b in range(fibres.shape[0]):
            for k in range(fibres.shape[5]):
                out[p, b, k] = band_point(fibres, b, k, 0, 0.0, i0, w0, i1, w1, i2, w2)


@numba.njit(inline="always")
def fibre_law(fibres, b, q0, q1, q2, grid, shape, flat, arm, levels, n, c, length, x0, inv_dx, kmax, a, velocity,
              neg_inv_vscale):
    """Column c's law (`muscle.law_point`: per unit activation, passive, FV factor) as the mean of band b's fibres,
    each at `length` (the band's) plus its departure (`fibres`, (n, 1, P, E, R, nt), trilinear at the pose (q0, q1,
    q2) rad by `band_point`), at the band's lengthening rate `velocity`. The one implementation the compiled
    callbacks inline; `TendonLaw.gain_bias_one` does the same arithmetic with the departures `BandLines.departures`
    reads."""
    i0, w0, i1, w1, i2, w2 = band_cells(q0, q1, q2, grid, shape)
    nt = fibres.shape[5]
    per_unit, passive, fv = 0.0, 0.0, 1.0
    for k in range(nt):
        i, w = law_cell(length + band_point(fibres, b, k, 0, 0.0, i0, w0, i1, w1, i2, w2), x0, inv_dx, kmax)
        _, pu, ps, fv = law_point(flat, arm, levels, n, c, i, w, a, velocity, neg_inv_vscale)
        per_unit += pu
        passive += ps
    return per_unit / nt, passive / nt, fv
