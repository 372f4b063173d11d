"""The footprint sheets' line of action in MuJoCo (issue 12 §2): the band tables' corrections to the MJCF tendons'
moment arms, applied at every RK4 stage. How the tables are made: `shoulder_bench.authoring.fem.bands`, docs/fem.md
"Taut bands".

A tendon t with a band table pulls with its FEM force F_t(L_MT, a) (`tendon_law.TendonLaw`) along its MJCF path,
which MuJoCo's tendon transmission applies (generalised force F_t r_MJCF(q) about plane, elevation and rotation), and
here in addition with F_t c_t(q) about the three coordinates: c_t the taut band's moment arms less the MJCF's, tabled on
the tasks' pose grid and read trilinearly (poses beyond the grid at its edges). Together: F_t (r_MJCF + c_t), the
band's line of action. The tendons without a table (ssc, the deltoids, ld, pec2/pec3, cor) keep their MJCF paths.

Why a passive-force callback: a MuJoCo actuator acts along its transmission only (here the MJCF tendon), and no
transmission has a pose-dependent direction of its own; `mjcb_passive` is MuJoCo's hook for generalised forces added
at each evaluation, called after the tendon lengths and velocities are known and before the accelerations, at every
RK4 stage. `shoulder_bench.native.passive` is the compiled (GIL-free) callback, `model._passive` the Python one; both
read F from the same law arithmetic as the actuator callbacks and c from `band_point` below.

Table format (`models/muscles_full/<tendon>_band.npz`, written by `shoulder-bench fem build --bands`):
  plane_deg (P,), elevation_deg (E,), rotation_deg (R,)   the grid, uniform and ascending (the tasks' pose grid or
                                                           one nesting it, `fem.bands.REFINE`)
  moment_arm_m (P, E, R, 3)                                the band's moment arms about plane, elevation, rotation
  mjcf_moment_arm_m (P, E, R, 3)                           the MJCF tendon's at the same poses
  meta                                                     0-d JSON string (tendon, input_hash, ...)
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numba
import numpy as np

from shoulder_bench.muscle import law_cell

BAND_TENDONS = ("ssp", "isp", "tmi", "tma", "pec1")  # the tendons whose footprint sheet is resolved (fem.bands)
LINES = ("mjcf", "band")  # the 3-DOF tasks' `line_of_action` option
AXES = ("plane_deg", "elevation_deg", "rotation_deg")
REBUILD = "shoulder-bench fem build --bands"


def table_path(tendon: str, folder: Path | None = None) -> Path:
    from shoulder_bench.full_arm import TABLE_FOLDER

    return Path(folder or TABLE_FOLDER) / f"{tendon}_band.npz"


def read_table(path: Path) -> tuple[dict, dict]:
    """(arrays, meta) of a band table; ValueError naming the file and the command that rebuilds it."""
    path = Path(path)
    try:
        with np.load(path, allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
        meta = json.loads(str(arrays.pop("meta")))
    except (OSError, ValueError, KeyError) as exc:
        raise ValueError(f"{path}: not a band table ({exc}); rebuild it with `{REBUILD}`") from exc
    problems = [k for k in (*AXES, "moment_arm_m", "mjcf_moment_arm_m") if k not in arrays]
    if not problems:
        shape = tuple(len(arrays[k]) for k in AXES) + (3,)
        if arrays["moment_arm_m"].shape != shape or arrays["mjcf_moment_arm_m"].shape != shape:
            problems.append(f"arm arrays are not {shape}")
        for k in AXES:
            step = np.diff(arrays[k])
            if len(arrays[k]) < 2 or not np.allclose(step, step[0]) or step[0] <= 0:
                problems.append(f"{k} is not uniform and ascending")
        if not np.all(np.isfinite(arrays["moment_arm_m"] - arrays["mjcf_moment_arm_m"])):
            problems.append("non-finite arms")
    if problems:
        raise ValueError(f"{path}: not a band table ({'; '.join(problems)}); rebuild it with `{REBUILD}`")
    return arrays, meta


class BandLines:
    """The band corrections of `tendons` on one grid: `correction(poses_deg)` (P, n, 3) m. `load` reads the tables."""

    def __init__(self, tendons, axes_deg, correction: np.ndarray):
        self.tendons = tuple(tendons)
        self.axes_deg = [np.asarray(a, dtype=float) for a in axes_deg]
        shape = tuple(len(a) for a in self.axes_deg)
        self.table = np.ascontiguousarray(correction, dtype=np.float64)  # (n, P, E, R, 3)
        if self.table.shape != (len(self.tendons), *shape, 3):
            raise ValueError(f"band corrections of shape {self.table.shape}, expected {(len(self.tendons), *shape, 3)}")
        # per coordinate: the grid's first pose (rad) and 1 / step (1/rad), as `law_cell` reads them
        self.grid = np.concatenate([[np.radians(a[0]) for a in self.axes_deg],
                                    [1.0 / np.radians(a[1] - a[0]) for a in self.axes_deg]])
        self.shape = np.array(shape, dtype=np.int64)

    @classmethod
    def load(cls, tendons=BAND_TENDONS, folder: Path | None = None) -> BandLines:
        """The tables `<folder>/<tendon>_band.npz` (default models/muscles_full), read on the coarsest grid that
        nests all of theirs (per coordinate the same range, its number of steps the least common multiple of theirs):
        each resampled there linearly along each coordinate in turn, which leaves its trilinear reading exactly as it
        was (a trilinear function restricted to a sub-cell is trilinear). Tables over different ranges are refused."""
        tendons = tuple(tendons)
        unknown = [t for t in tendons if t not in BAND_TENDONS]
        if unknown:
            raise ValueError(f"no band table for {unknown}; tendons with one: {', '.join(BAND_TENDONS)}")
        tables = [read_table(table_path(t, folder))[0] for t in tendons]
        axes = [np.linspace(tables[0][k][0], tables[0][k][-1], math.lcm(*(len(a[k]) - 1 for a in tables)) + 1)
                for k in AXES]
        for t, a in zip(tendons, tables):
            if not all(_nests(ax, a[k]) for k, ax in zip(AXES, axes)):
                raise ValueError(f"{table_path(t, folder)}: its pose grid spans other ranges than "
                                 f"{', '.join(tendons)}'s; rebuild the tables with `{REBUILD}`")
        return cls(tendons, axes, np.stack([_resample(a["moment_arm_m"] - a["mjcf_moment_arm_m"], [a[k] for k in AXES],
                                                      axes) for a in tables]))

    def correction(self, poses_deg) -> np.ndarray:
        """(P, n, 3) m: each tendon's band moment arms less its MJCF ones at `poses_deg` (P, 3), trilinear between the
        grid's poses (beyond the grid: its edges), as the callbacks read them."""
        q = np.radians(np.atleast_2d(np.asarray(poses_deg, dtype=float)))
        out = np.empty((len(q), len(self.tendons), 3))
        _corrections(self.table, self.grid, self.shape, q, out)
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
def band_point(table, b, k, i0, w0, i1, w1, i2, w2):
    """Tendon b's correction about coordinate k at a cell (`band_cells`): trilinear in the cell's 8 corners. The one
    implementation: `BandLines.correction` and the compiled passive callback both inline it."""
    out = 0.0
    for d0 in range(2):
        u0 = w0 if d0 else 1.0 - w0
        for d1 in range(2):
            u1 = w1 if d1 else 1.0 - w1
            for d2 in range(2):
                u2 = w2 if d2 else 1.0 - w2
                out += u0 * u1 * u2 * table[b, i0 + d0, i1 + d1, i2 + d2, k]
    return out


@numba.njit(cache=True, nogil=True)
def _corrections(table, grid, shape, q, out):
    for p in range(q.shape[0]):
        i0, w0, i1, w1, i2, w2 = band_cells(q[p, 0], q[p, 1], q[p, 2], grid, shape)
        for b in range(table.shape[0]):
            for k in range(3):
                out[p, b, k] = band_point(table, b, k, i0, w0, i1, w1, i2, w2)
