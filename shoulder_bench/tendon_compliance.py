"""The parent's compliant tendon in series with the full shoulder's FEM sheets: the 3-DOF tasks' `tendon="compliant"`.

The FEM tables (`tendon_law`, `models/muscles_full/<t>_fem.npz`) hold the sheet's force F_r(L, a) with the tendon rigid
at the MoBL-ARMS parent's slack length l_ts (the sheet's axial extent L - l_ts). The parent's tendons stretch: its
`tendon_force_length_curve` (Schutte 1993, models/reference/mobl_arms_parent_curves.csv, the same for all fifteen
muscles) has 0.227 F0 at 1.23 % strain and reaches F0 at 3.3 %. Under a force F the tendon is l_ts eps(F / F0) longer
and the sheet as much shorter, so the two in series hold

    F = F_r(L - l_ts eps(F / F0), a),

which `series_force` solves at every length knot and activation level of a table (`compliant_table`); the law reads
that table as it reads the rigid one (bilinear in length and activation), so the compiled and Python callbacks, the
planners and the band lines need nothing else. Where the equation has several roots (a steep descending limb against
a soft toe region) the one of least tendon stretch is kept: the force reached from the slack tendon.

What it leaves out: the tendon and the fibres share the path's lengthening rate, and the force-velocity factor reads
the whole path's rate as the rigid law does (the fibre's own rate would need a state per muscle, as OpenSim's
equilibrium models integrate). The curve is read linearly between its knots (OpenSim splines them; the knots are 1.5
per mille of strain apart up to 0.227 F0, then one straight segment). The table's interpolation error against the
equation solved exactly between its knots and levels is `interpolation_error` (`benchmarks/tendon_compliance.py`).
"""
from __future__ import annotations

import csv
import dataclasses
from pathlib import Path

import numpy as np

from shoulder_bench.paths import MODELS_DIR

CURVES_FILE = MODELS_DIR / "reference" / "mobl_arms_parent_curves.csv"  # the parent's SimmSpline knots
TENDON_CURVE = "tendon_force_length_curve"
TENDONS = ("rigid", "compliant")  # the option's values
GRID = 400  # force samples per solve over which the least-stretch root is bracketed before bisection
BISECTIONS = 50
REFINE = 4  # the compliant table's length knots per rigid knot interval


def parent_curve(muscle: str, curve: str = "passive_force_length_curve", path: Path | str = CURVES_FILE):
    """The parent's curve of `muscle` (MoBL name, e.g. SUPSP) as knots (x, y), ascending x, repeated x dropped."""
    with open(path, newline="") as f:
        rows = [r for r in csv.DictReader(f) if r["muscle"] == muscle and r["curve"] == curve]
    if not rows:
        raise ValueError(f"{path}: no {curve} for {muscle}")
    rows.sort(key=lambda r: int(r["knot"]))
    x, y = np.array([float(r["x"]) for r in rows]), np.array([float(r["y"]) for r in rows])
    keep = np.r_[True, np.diff(x) > 0]
    return x[keep], y[keep]


def strain_curve(muscle: str) -> tuple[np.ndarray, np.ndarray]:
    """(normalised force, strain) knots of the parent's tendon curve of `muscle` on its rising part (from zero strain
    to the last knot where the force still rises): its inverse, eps(F / F0)."""
    x, y = parent_curve(muscle, TENDON_CURVE)
    start = int(np.flatnonzero(x >= 0.0)[0])
    x, y = x[start:], y[start:]
    stop = 1 + int(np.flatnonzero(np.diff(y) > 0.0)[-1]) + 1
    x, y = x[:stop], y[:stop]
    if y[0] != 0.0 or np.any(np.diff(y) <= 0.0):
        raise ValueError(f"{CURVES_FILE}: {muscle}'s {TENDON_CURVE} does not rise from zero force at zero strain")
    return y, x


def series_force(rigid, length, f0: float, l_ts: float, curve, f_max: float) -> np.ndarray:
    """The force F of the sheet in series with the tendon at musculotendon `length` (any shape, m): the least-stretch
    root of F = rigid(length - l_ts eps(F / f0)), `rigid(x)` the sheet's force (same shape as x) with the tendon
    rigid, `curve` = `strain_curve`'s (force / F0, strain) knots, `f_max` an upper bound of the rigid force (N)."""
    length = np.asarray(length, dtype=float)
    fn, eps = curve

    def gap(force):
        return force - rigid(length[..., None] - l_ts * np.interp(force / f0, fn, eps))

    grid = np.linspace(0.0, 1.01 * f_max + 1.0, GRID + 1)
    g = gap(np.broadcast_to(grid, length.shape + grid.shape))
    first = np.argmax(g >= 0.0, axis=-1)  # g(0) = -rigid(length) <= 0, g(top) > 0
    hi = grid[np.maximum(first, 1)]
    lo = np.where(first == 0, 0.0, grid[np.maximum(first - 1, 0)])
    hi = np.where(first == 0, 0.0, hi)
    for _ in range(BISECTIONS):
        mid = 0.5 * (lo + hi)
        up = gap(mid[..., None])[..., 0] >= 0.0
        lo, hi = np.where(up, lo, mid), np.where(up, mid, hi)
    return 0.5 * (lo + hi)


def _rigid_reader(table, a: float):
    """x -> the rigid table's force at sheet lengths x and activation a (the law's bilinear read, edges held)."""
    column = np.array([np.interp(a, table.activation, row) for row in table.force_N])
    return lambda x: np.interp(x, table.length_m, column)


def compliant_table(table, refine: int = REFINE):
    """A `tendon_law.TendonTable` with the parent's compliant tendon in series: its force the equilibrium
    `series_force` at every level and at the knots of a length grid `refine` times finer than the table's (the rigid
    read's kinks at the table's knots move by the tendon's stretch, between the knots); meta records the tendon."""
    f0, l_ts = float(table.meta["F0_N"]), float(table.meta["tendon_slack_length_m"])
    curve = strain_curve(table.meta["parent_muscle"])
    top = float(table.force_N.max())
    length = np.linspace(table.length_m[0], table.length_m[-1], (len(table.length_m) - 1) * refine + 1)
    force = np.stack([series_force(_rigid_reader(table, a), length, f0, l_ts, curve, top)
                      for a in table.activation], axis=1)
    meta = {**table.meta, "tendon": "compliant: the parent's tendon_force_length_curve in series "
                                    "(shoulder_bench.tendon_compliance)",
            "tendon_strain_at_F0": float(np.interp(1.0, *curve))}
    return dataclasses.replace(table, length_m=length, force_N=force, meta=meta)


def stretch(table, force_N) -> np.ndarray:
    """The tendon's stretch beyond its slack length (m) at `force_N`: l_ts eps(F / F0)."""
    fn, eps = strain_curve(table.meta["parent_muscle"])
    return float(table.meta["tendon_slack_length_m"]) * np.interp(np.asarray(force_N) / float(table.meta["F0_N"]),
                                                                  fn, eps)


def read(table, length, a) -> np.ndarray:
    """`table`'s force at `length` (K,) and activation `a` by the law's bilinear read (edges held)."""
    return _rigid_reader(table, a)(np.asarray(length, dtype=float))


def interpolation_error(table, compliant) -> dict:
    """How far `compliant` (`compliant_table(table)`) read between its knots and levels is from the equilibrium
    solved there exactly: at every length between two knots and every activation between two levels (the cells'
    centres) and at the knots between levels and the levels between knots. {"max_N", "max_F0", "at": (length m,
    activation)}."""
    f0, l_ts = float(table.meta["F0_N"]), float(table.meta["tendon_slack_length_m"])
    curve, top = strain_curve(table.meta["parent_muscle"]), float(table.force_N.max())
    mid_x = 0.5 * (compliant.length_m[1:] + compliant.length_m[:-1])
    mid_a = 0.5 * (compliant.activation[1:] + compliant.activation[:-1])
    worst = (0.0, None)
    for xs, acts in ((mid_x, compliant.activation), (mid_x, mid_a), (compliant.length_m, mid_a)):
        for a in acts:
            exact = series_force(_rigid_reader(table, a), xs, f0, l_ts, curve, top)
            err = np.abs(read(compliant, xs, a) - exact)
            k = int(np.argmax(err))
            if err[k] > worst[0]:
                worst = (float(err[k]), (float(xs[k]), float(a)))
    return {"max_N": worst[0], "max_F0": worst[0] / f0, "at": worst[1]}
