"""The muscle force law keyed on each tendon's own length: the full shoulder's (3-DOF) law.

`muscle.ForceLaw` reads every table at one joint angle (v1's abduction, v2's locked elevation). On the 3-DOF
model a pose is three coordinates, but each FEM sheet's force depends on the pose only through its musculotendon
length (`shoulder_bench.authoring.fem.full`), so each table here is F(L, a) on its own uniform length grid, and
the callback reads MuJoCo's `actuator_length` and `actuator_velocity` over the actuator's gear (the tendon's length
and lengthening rate; gear is 1 in the model and a muscle's strength draw under `randomization`).
The arithmetic is `muscle.law_point`, the same inlined function as ForceLaw's, with the moment arm fixed at -1 so
that its force-velocity argument is the tendon's lengthening rate itself.

Table format (`models/muscles_full/<tendon>_fem.npz`, float64):
  length_m (K,)       uniform grid of musculotendon lengths (m)
  activation (J,)     ascending, activation[0] == 0, activation[-1] == 1
  force_N (K, J)      tendon force (pulling, N); column 0 is the passive force
  meta                0-d string: JSON (source, muscle, parent muscle, optimal_fibre_length_m, ...)
Lengths outside the grid take the edge values.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path

import numba
import numpy as np

from shoulder_bench.muscle import (
    VMAX_LOPT_PER_S,
    check_muscle_model,
    law_cell,
    law_point,
    read_table,
    rising_activation,
)

REQUIRED_KEYS = ("length_m", "activation", "force_N", "meta")
REBUILD = "shoulder-bench fem build --full"


def table_path(tendon: str, muscle_model: str, folder: Path | None = None) -> Path:
    from shoulder_bench.full_arm import TABLE_FOLDER

    return Path(folder or TABLE_FOLDER) / f"{tendon}_{muscle_model}.npz"


@dataclass(frozen=True)
class TendonTable:
    muscle: str  # the tendon (actuator) it drives
    length_m: np.ndarray
    activation: np.ndarray
    force_N: np.ndarray
    meta: dict

    @classmethod
    def load(cls, path: Path) -> TendonTable:
        """Read and check a table; errors name the file and the command that rebuilds it."""
        path = Path(path)
        fix = f"rebuild it with `{REBUILD}`"
        arrays, meta = read_table(path, REQUIRED_KEYS, fix)
        table = cls(muscle=meta.get("muscle", path.stem.rsplit("_", 1)[0]), meta=meta, **arrays)
        k, j = len(table.length_m), len(table.activation)
        problems = []
        if table.force_N.shape != (k, j):
            problems.append("array shapes disagree")
        elif not np.all(np.isfinite(table.force_N)):
            problems.append("non-finite values")
        if k < 2 or not np.allclose(np.diff(table.length_m), table.length_m[1] - table.length_m[0]) or \
                table.length_m[1] <= table.length_m[0]:
            problems.append("length grid is not uniform and ascending")
        if not rising_activation(table.activation):
            problems.append("activation grid must rise from 0 to 1")
        if "optimal_fibre_length_m" not in meta:
            problems.append("meta lacks optimal_fibre_length_m (the force-velocity scale)")
        if problems:
            raise ValueError(f"muscle table {path}: {'; '.join(problems)}; {fix}")
        return table


class TendonLaw:
    """Forces of n tendons, each at its own length, vectorised over a batch of states.

    Same attributes as `muscle.ForceLaw` where the callbacks and tasks read them: `actuators` (the tables' tendons),
    `groups` (muscle -> its tendons; one activation drives a group: ld -> ld1-3), `muscles`, `muscle_of`,
    `first_table`. The tables are resampled onto one shared activation-level union (exact: each is piecewise linear
    in activation and the union holds its knots) and stacked as F[length knot, level, tendon]; tendon c's knot k is at
    length x0[c] + k / inv_dx[c]."""

    kind = "length"

    def __init__(self, tables: list[TendonTable], groups: dict[str, tuple[str, ...]] | None = None):
        self.tables = tables
        self.actuators = tuple(t.muscle for t in tables)
        groups = {a: (a,) for a in self.actuators} if groups is None else {g: tuple(v) for g, v in groups.items()}
        flat = [a for v in groups.values() for a in v]
        if sorted(flat) != sorted(self.actuators) or len(set(flat)) != len(flat):
            raise ValueError(f"muscle groups {groups} must name each table {self.actuators} exactly once")
        self.groups, self.muscles = groups, tuple(groups)
        self.muscle_of = np.array([next(k for k, v in enumerate(groups.values()) if a in v) for a in self.actuators])
        self.first_table = [self.actuators.index(v[0]) for v in groups.values()]
        k = len(tables[0].length_m)
        if any(len(t.length_m) != k for t in tables):
            raise ValueError("all tables of a tendon law must have the same number of length knots")
        levels = np.unique(np.concatenate([t.activation for t in tables]))
        force = np.stack([np.stack([np.interp(levels, t.activation, row) for row in t.force_N]) for t in tables],
                         axis=-1)  # (K, J, n)
        self.levels, self._k, self._n = levels, k, len(tables)
        self._flat = np.ascontiguousarray(force.ravel())
        self._arm = -np.ones((k, self._n))  # law_point's FV argument r * velocity * (-1 / vscale) = L' / vscale
        self.x0 = np.array([t.length_m[0] for t in tables])
        self.inv_dx = np.array([1.0 / (t.length_m[1] - t.length_m[0]) for t in tables])
        self._neg_inv_vscale = -1.0 / np.array([VMAX_LOPT_PER_S * float(t.meta["optimal_fibre_length_m"])
                                                for t in tables])
        self.lines = None  # band_lines.BandLines: the tendons that act along their band's line (None: MJCF paths)

    @classmethod
    def load(cls, muscle_model: str = "fem", tendons=None, folder: Path | None = None,
             groups: dict | None = None, line_of_action: str = "mjcf", geometry: str | None = None,
             tendon: str = "rigid") -> TendonLaw:
        """The law of `tendons` (default all of the full shoulder's) from `<folder>/<tendon>_<muscle_model>.npz`
        (default models/muscles_full); a condition's `geometry` (`full_arm.GEOMETRIES`: ld_transfer) reads its
        rerouted tendons from its own folder. line_of_action "band": those of its tendons with a band table
        (`band_lines.BAND_TENDONS`, `<folder>/<tendon>_band.npz`) act along the FEM band's line, the others along
        their MJCF paths; "band_fibres": the same lines, and the band tendons' force their fibres' (`band_lines`: each
        fibre at its own length, `<folder>/<tendon>_fibres.npz`); "mjcf" (default): all along their MJCF paths.
        tendon "compliant": the parent's compliant tendon in series with every table (`tendon_compliance`); "rigid"
        (default): the tables as built, the tendon rigid at its slack length."""
        from shoulder_bench import tendon_compliance
        from shoulder_bench.band_lines import BAND_TENDONS, LINES, BandLines
        from shoulder_bench.full_arm import GEOMETRIES, TENDONS

        if line_of_action not in LINES:
            raise ValueError(f"line_of_action {line_of_action!r}: choose one of {', '.join(LINES)}")
        if tendon not in tendon_compliance.TENDONS:
            raise ValueError(f"tendon {tendon!r}: choose one of {', '.join(tendon_compliance.TENDONS)}")

        check_muscle_model(muscle_model)
        names = tuple(TENDONS if tendons is None else tendons)
        tables = []
        rerouted = () if geometry is None else GEOMETRIES[geometry]["tendons"]
        for t in names:
            p = table_path(t, muscle_model, GEOMETRIES[geometry]["tables"] if t in rerouted else folder)
            table = TendonTable.load(p)
            if table.muscle != t:
                raise ValueError(f"muscle table {p} is for {table.muscle!r}, not {t!r}")
            tables.append(tendon_compliance.compliant_table(table) if tendon == "compliant" else table)
        law = cls(tables, groups)
        if line_of_action in ("band", "band_fibres"):
            law.lines = BandLines.load([t for t in names if t in BAND_TENDONS], folder, line_of_action == "band_fibres")
        return law

    def scaled(self, factors: dict[str, float]) -> TendonLaw:
        """A new law with each muscle's tables scaled by `factors[muscle]` (as `ForceLaw.scaled`)."""
        unknown = [m for m in factors if m not in self.groups]
        if unknown:
            raise ValueError(f"cannot scale muscle(s) {unknown}: the law has {self.muscles}")
        bad = {m: f for m, f in factors.items() if not (math.isfinite(float(f)) and float(f) >= 0.0)}
        if bad:
            raise ValueError(f"muscle force factors must be finite numbers >= 0; got {bad}")
        per = {a: float(f) for m, f in factors.items() for a in self.groups[m]}
        law = TendonLaw([t if per.get(t.muscle, 1.0) == 1.0 else dataclasses.replace(
            t, force_N=t.force_N * per[t.muscle], meta={**t.meta, "force_factor": per[t.muscle]})
            for t in self.tables], self.groups)
        law.lines = self.lines
        return law

    def geometry(self, pose, poses_deg, activation=None) -> tuple[np.ndarray, np.ndarray]:
        """(lengths (P, n) m, moment arms (P, n, 3) m about plane, elevation, rotation) of the law's tendons at
        `poses_deg` (P, 3) on `pose` (a `full_arm.Pose`): the MJCF paths', and where the law has band lines (`lines`)
        their band's lengths and arms, for the tendons whose band has a level table at `activation` per muscle
        ((muscles,) or (P, muscles); None: a = 1): the lengths and arms the muscles act with in MuJoCo."""
        L, r = pose.tendon_geometry(poses_deg, self.actuators)
        if self.lines is not None:
            cols, a = self._band_activation(activation)
            r[:, cols] += self.lines.correction(poses_deg, a)
            L[:, cols] += self.lines.lengthening(poses_deg)[0]
        return L, r

    def lengthening_rates(self, poses_deg, rates_rad_s, mjcf_rates, activation=None) -> np.ndarray:
        """(P, n) m/s: the tendons' lengthening rates as the callbacks read them: the MJCF paths' `mjcf_rates` (P, n)
        (MuJoCo's actuator_velocity at gear 1), and for the band tendons (`lines`) the band's, their rate less the
        MJCF path's at the coordinates' rates `rates_rad_s` (P, 3) along the line at `activation` (as `geometry`)
        added."""
        v = np.array(np.atleast_2d(mjcf_rates), dtype=float)
        if self.lines is not None:
            cols, a = self._band_activation(activation)
            v[:, cols] += self.lines.lengthening(poses_deg, rates_rad_s, a)[1]
        return v

    def _band_activation(self, activation) -> tuple[list[int], np.ndarray | float]:
        """The band tendons' columns and their activations from `activation` per muscle ((muscles,) or (P,
        muscles); None: 1)."""
        cols = [self.actuators.index(t) for t in self.lines.tendons]
        a = 1.0 if activation is None else \
            np.asarray(activation, dtype=float).reshape(-1, len(self.muscles))[:, self.muscle_of[cols]]
        return cols, a

    def kernel_arguments(self) -> tuple:
        """(flat table, arms (K, n) of -1, activation levels, first knot per tendon (m), 1 / knot step per tendon,
        -1 / FV velocity scale per tendon): what `shoulder_bench.native` holds for this law."""
        return self._flat, self._arm, self.levels, self.x0, self.inv_dx, self._neg_inv_vscale

    def _evaluate_all(self, length, velocity, activation) -> np.ndarray:
        """(5, B, n): active force, active per unit activation, passive force, FV factor, gain."""
        length = np.ascontiguousarray(np.broadcast_to(length, (len(activation), self._n)), dtype=np.float64)
        velocity = np.ascontiguousarray(np.broadcast_to(velocity, length.shape), dtype=np.float64)
        activation = np.ascontiguousarray(np.asarray(activation, dtype=np.float64)[:, self.muscle_of])
        out = np.empty((5,) + activation.shape)
        _kernel(self._flat, self._arm, self.levels, self.x0, self.inv_dx, self._neg_inv_vscale, length, velocity,
                activation, out)
        return out

    def _evaluate_fibres(self, length, velocity, activation, departures) -> np.ndarray:
        """(5, B, nt, n): `_evaluate_all` at each of nt fibres' lengths, length (B, n) plus departures ((B or 1, nt,
        n)), at the same rates (B, n) and activations (B, muscles)."""
        act = np.atleast_2d(np.asarray(activation, dtype=float))
        b = len(act)
        d = np.broadcast_to(np.asarray(departures, dtype=float), (b,) + np.shape(departures)[-2:])
        nt = d.shape[1]

        def each(x):  # (b, n), each row nt times
            return np.repeat(np.broadcast_to(np.asarray(x, dtype=float), (b, self._n)), nt, axis=0)

        out = self._evaluate_all(each(length) + d.reshape(b * nt, self._n), each(velocity), np.repeat(act, nt, axis=0))
        return out.reshape(5, b, nt, self._n)

    def gain_bias_one(self, length, velocity, activation, departures=None) -> tuple[np.ndarray, np.ndarray]:
        """One state: tendon lengths (n,), lengthening rates (n,), activations per muscle (m,) -> (gain, bias) per
        tendon, as `ForceLaw.gain_bias_one` (positive; the callbacks negate them). departures (nt, n): each tendon's
        law the mean of nt fibres', each at its length plus its departure (`band_lines.fibre_law`)."""
        if departures is None:
            out = self._evaluate_all(np.asarray(length)[None], np.asarray(velocity)[None], np.asarray(activation)[None])
            return out[4, 0], out[2, 0]
        out = self._evaluate_fibres(np.asarray(length)[None], np.asarray(velocity)[None],
                                    np.asarray(activation)[None], np.asarray(departures)[None])
        return out[4, 0].mean(axis=0), out[2, 0].mean(axis=0)

    def force(self, length, velocity, activation, departures=None) -> np.ndarray:
        """(B, n) tendon forces (N, pulling) at lengths (B, n) m, lengthening rates (B, n) m/s, activations
        (B, muscles); departures ((B or 1, nt, n) m, `departures`): each tendon's force the mean of nt fibres', each at
        its length plus its departure."""
        if departures is None:
            out = self._evaluate_all(length, velocity, activation)
            return out[0] * out[3] + out[2]
        out = self._evaluate_fibres(length, velocity, activation, departures)
        return (out[0] * out[3] + out[2]).mean(axis=1)

    def departures(self, poses_deg) -> np.ndarray | None:
        """(P, nt, n) m: each tendon's fibres' departures from its band's mean fibre at `poses_deg` (P, 3), 0 for the
        tendons without a band, as the callbacks read them; None for a law without fibre tables ("band_fibres")."""
        if self.lines is None or self.lines.fibres is None:
            return None
        got = self.lines.departures(poses_deg)  # (P, bands, nt)
        out = np.zeros((len(got), got.shape[2], self._n))
        out[:, :, [self.actuators.index(t) for t in self.lines.tendons]] = got.transpose(0, 2, 1)
        return out


@numba.njit(cache=True, nogil=True)
def _kernel(flat, arm, levels, x0, inv_dx, neg_inv_vscale, length, velocity, activation, out):
    """The law for a batch, each tendon at its own length: out[0..4] as `muscle._kernel`."""
    nb, n = activation.shape
    kmax = arm.shape[0] - 1.000001
    for b in range(nb):
        for c in range(n):
            i, w = law_cell(length[b, c], x0[c], inv_dx[c], kmax)
            active, per_unit, passive, fv = law_point(flat, arm, levels, n, c, i, w, activation[b, c],
                                                      velocity[b, c], neg_inv_vscale[c])
            out[0, b, c] = active
            out[1, b, c] = per_unit
            out[2, b, c] = passive
            out[3, b, c] = fv
            out[4, b, c] = per_unit * fv
