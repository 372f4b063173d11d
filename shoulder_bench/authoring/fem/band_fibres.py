"""The taut band's fibres at their own lengths (issue 12 §2, the force from the footprint sheets: a first step).

The length-keyed law reads one musculotendon length per tendon; with band lines, the band's (`band_lines`: L_MJCF(q)
+ D(q), D the potential of the band's arms, which follows the band's mean fibre within 0.03-0.65 mm RMS). Across a
band's width its fibres' lengths change from pose to pose by different amounts (`benchmarks/band_potential.py`: their
changes differ by 0.08-0.19 l_opt at the median pose, up to 0.53), so fibres side by side sit at different points of
the force-length curve, which one length cannot see. This module tables that spread:

    departure_i(q) = (l_i(q) - l_i(q_anchor)) - mean_j (l_j(q) - l_j(q_anchor))

l_i the length of fibre i of the solved taut band at a = 1 (`footprint_compare.fibre_lengths`: the polyline along it
from the origin line to the insertion line), q_anchor = band_lines.LENGTH_ANCHOR_DEG, where the band's length is taken
to be the MJCF path's and here its fibres to be equally long (no source gives their lengths there either). The grid:
the tasks' (full_arm.POSE_STEP_DEG; it nests every band table's); the poses solved as the band tables solve them
(`bands.solve_poses`: the ramp from rest, or LEAST_ENERGY's rule), read trilinearly (beyond the grid: its edges); an
unsolved pose takes the mean of its solved neighbours' (`bands.neighbours_mean`). `verify` re-solves held-out poses
(the grid's cell centres) against the table.

The force from the fibres (`fibre_force`): the band's nt fibres as nt parallel strips of the tendon's length-keyed
FEM sheet, each at its own length L + departure_i and the band's lengthening rate: F = mean_i F(L + departure_i, a,
v). The membrane's coupling between neighbouring fibres is not in it (each strip takes the whole sheet's law per unit
width), nor does each fibre's own lengthening rate enter. MuJoCo applies it with line_of_action="band_fibres"
(`band_lines.fibre_law`, the callbacks' implementation of the same arithmetic); `benchmarks/band_fibres.py` measures
what it changes against one length.

Table (`<folder>/<tendon>_fibres.npz`, default models/muscles_full): plane_deg, elevation_deg, rotation_deg (the
grid); departure_m (P, E, R, nt); unsolved (P, E, R) bool; meta (JSON: tendon, input_hash, anchor, build_seconds,
...). Cached by input hash: the band table's inputs on this grid, the anchor and FIBRES_VERSION. The build takes
the poses the band table in its folder holds with their fibres (`band_poses`: a band table of the same inputs keeps
each pose's fibre lengths, and its grid nests this one), so after `fem build --bands` it solves the anchor alone.
"""
from __future__ import annotations

import hashlib
import json
import time
from pathlib import Path

import numpy as np
from scipy.interpolate import RegularGridInterpolator
from tqdm import tqdm

from shoulder_bench import full_arm
from shoulder_bench.authoring.fem import bands
from shoulder_bench.authoring.fem.full import locked_folder
from shoulder_bench.authoring.fem.material import Material
from shoulder_bench.band_lines import LENGTH_ANCHOR_DEG, fibres_path, read_fibres
from shoulder_bench.muscle import replacing

FIBRES_VERSION = "band-fibres-1"  # bump when a change alters the tables; part of their input hash
VERIFY_BOUND_PCT = 2.0  # held-out: |fibre force from the table - from the re-solved band| <= this % of F0
VERIFY_ACTIVATIONS = (1.0, 0.0)  # ... at these activations (0: the passive force)


def table_path(tendon: str, folder: Path | None = None) -> Path:
    return fibres_path(tendon, folder)


def input_hash(tendon: str, resolution: str = "full") -> str:
    band = bands.input_hash(tendon, resolution, Material(), grid_axes=bands.axes(None))
    blob = json.dumps({"band": band, "anchor_deg": list(LENGTH_ANCHOR_DEG), "version": FIBRES_VERSION},
                      sort_keys=True)
    return hashlib.sha256(blob.encode()).hexdigest()


def departures(fibre_m: np.ndarray) -> np.ndarray:
    """(P, nt) m from `fibre_m` ((1 + P, nt): the anchor's fibre lengths, then each pose's): each fibre's change from
    the anchor less the mean fibre's change."""
    change = fibre_m[1:] - fibre_m[0]
    return change - change.mean(axis=1, keepdims=True)


def solve(tendon: str, poses: np.ndarray, resolution: str = "full", progress=None, jobs: int = 1,
          known: dict | None = None) -> dict:
    """The departures (P, nt) m at `poses` (P, 3) deg and which converged (P,), the anchor solved first (a
    RuntimeError if it does not converge). known (`band_poses`): poses whose band is already solved, taken as they are;
    "reused": how many."""
    everything = np.vstack([LENGTH_ANCHOR_DEG, poses])
    r = bands.with_known(everything, known,
                          lambda todo: bands.solve_poses(tendon, todo, resolution, progress, jobs=jobs))
    if not r["converged"][0]:
        raise RuntimeError(f"{tendon}: its band has no equilibrium at the anchor pose {LENGTH_ANCHOR_DEG}")
    return {"departure_m": departures(r["fibre_m"]), "converged": r["converged"][1:], "f0_N": r["f0_N"],
            "reused": r.get("reused", 0)}


def band_poses(tendon: str, folder: Path) -> dict | None:
    """The poses the band table in `folder` holds with their fibres, as `solve_poses` gives them (`bands.reusable`:
    only a table built from the inputs a band table would be built from now; a pose solved before the tables kept
    their fibres is left out), so that `fem build --bands` then `--fibres` solves each band once; None if there is no
    such table or it kept no fibres (one written before 2026-12-08 lends nothing, not even its unsolved poses)."""
    known = bands.reusable(bands.table_path(tendon, folder), tendon, "full", Material())
    if known is None or not np.isfinite(known["fibre_m"]).any():
        return None
    keep = ~known["converged"] | np.isfinite(known["fibre_m"]).all(axis=1)
    return dict(known, **{k: known[k][keep] for k in ("poses",) + bands.SOLVED})


def _check_tendons(tendons) -> None:
    unknown = [t for t in tendons if t not in bands.FOOTPRINT_TENDONS]
    if unknown:
        raise ValueError(f"no band for {', '.join(unknown)}; tendons with one: {', '.join(bands.FOOTPRINT_TENDONS)}")


def build(tendons=bands.FOOTPRINT_TENDONS, out: Path | None = None, jobs: int = 1, quiet: bool = False) -> dict:
    """Build (or reuse) each tendon's fibre table in `out` (default models/muscles_full); {tendon: meta + cached}."""
    _check_tendons(tendons)
    grid = bands.axes(None)
    poses = bands.mesh_poses(grid)
    with locked_folder(out, False, jobs, "fibre tables") as folder:
        result, todo = {}, []
        for t in tendons:
            try:
                meta = FibreTable.load(t, folder).meta
            except ValueError:
                meta = {}
            if meta.get("input_hash") == input_hash(t):
                result[t] = dict(meta, cached=True)
            else:
                todo.append((t, band_poses(t, folder)))
        total = sum(int((bands.known_at(np.vstack([LENGTH_ANCHOR_DEG, poses]), k) < 0).sum()) for _, k in todo)
        with tqdm(total=total, desc="fem fibres", unit="pose", disable=quiet or not todo) as bar:
            for t, known in todo:
                t0 = time.perf_counter()
                r = solve(t, poses, progress=bar.update, jobs=jobs, known=known)
                shape = tuple(len(a) for a in grid)
                unsolved = ~r["converged"].reshape(shape)
                departure = bands.neighbours_mean(np.nan_to_num(r["departure_m"]).reshape(shape + (-1,)), unsolved)
                meta = {"tendon": t, "source": "fem footprint sheet, taut band (rest='pose'), a = 1: each fibre's "
                        "length change from the anchor less the mean fibre's", "anchor_deg": list(LENGTH_ANCHOR_DEG),
                        "input_hash": input_hash(t), "version": FIBRES_VERSION, "f0_N": r["f0_N"],
                        "unsolved_poses_deg": poses[unsolved.reshape(-1)].tolist(),
                        "largest_departure_mm": float(np.abs(departure).max() * 1e3), "band_poses": r["reused"],
                        "build_seconds": round(time.perf_counter() - t0, 2)}
                _write(table_path(t, folder), grid, departure, unsolved, meta)
                result[t] = dict(meta, cached=False)
    return {t: result[t] for t in tendons}


def _write(path: Path, grid, departure, unsolved, meta) -> None:
    with replacing(path) as tmp:
        np.savez(tmp, plane_deg=grid[0], elevation_deg=grid[1], rotation_deg=grid[2], departure_m=departure,
                 unsolved=unsolved, meta=np.array(json.dumps(meta, sort_keys=True)))


class FibreTable:
    """A tendon's fibre table: `departure(poses_deg)` (P, nt) m, trilinear, clamped to the grid's edges."""

    def __init__(self, axes_deg, departure_m: np.ndarray, meta: dict):
        self.axes_deg = [np.asarray(a, float) for a in axes_deg]
        self.departure_m = np.asarray(departure_m, float)
        self.meta = meta
        self._read = RegularGridInterpolator(self.axes_deg, self.departure_m)

    @classmethod
    def load(cls, tendon: str, folder: Path | None = None) -> FibreTable:
        arrays, meta = read_fibres(table_path(tendon, folder), tendon)
        return cls([arrays[k] for k in ("plane_deg", "elevation_deg", "rotation_deg")], arrays["departure_m"], meta)

    def departure(self, poses_deg) -> np.ndarray:
        q = np.atleast_2d(np.asarray(poses_deg, float))
        lo, hi = [a[0] for a in self.axes_deg], [a[-1] for a in self.axes_deg]
        return self._read(np.clip(q, lo, hi))


def fibre_force(law, length_m, departure_m, activation, velocity=0.0) -> np.ndarray:
    """(B,) N: the force of the one tendon of `law` (a `TendonLaw` of one tendon) as the mean of its band's fibres
    each at its own length, `length_m` (B,) + `departure_m` (B, nt), at `activation` (B,) and lengthening rate
    `velocity` (B,) m/s (`TendonLaw.force` with these departures); with every departure 0 it is `law.force` at
    `length_m`."""
    d = np.atleast_2d(np.asarray(departure_m, float))
    b = len(d)
    column = [np.broadcast_to(np.asarray(x, float), (b,))[:, None] for x in (length_m, velocity, activation)]
    return law.force(column[0], column[1], np.repeat(column[2], len(law.muscles), axis=1), d[:, :, None])[:, 0]


def verify(tendons=bands.FOOTPRINT_TENDONS, folder: Path | None = None, count: int | None = None, jobs: int = 1,
           seed: int = 0) -> int:
    """Re-solve each tendon's band at the fibre grid's cell centres (`count` of them drawn with `seed`; None: all)
    and compare the fibre force at VERIFY_ACTIVATIONS (at the band's length there, `band_lines`, and v = 0; the
    tendon's shipped FEM and band tables) from the table's departures in `folder` with that from the re-solved band's;
    print one line per tendon; 0 when every held-out pose solved and is within VERIFY_BOUND_PCT of F0."""
    from shoulder_bench.tendon_law import TendonLaw

    _check_tendons(tendons)
    failed = 0
    for t in tendons:
        table = FibreTable.load(t, folder)
        poses = bands.held_out(None)
        if count is not None and count < len(poses):
            poses = poses[np.sort(np.random.default_rng(seed).choice(len(poses), count, replace=False))]
        solved = solve(t, poses, jobs=jobs)
        ok = solved["converged"]
        law = TendonLaw.load("fem", (t,), line_of_action="band")
        length = law.geometry(full_arm.Pose(), poses[ok])[0][:, 0]  # the band's length
        dep = np.abs(table.departure(poses[ok]) - solved["departure_m"][ok]).max(axis=1) * 1e3
        line, over = [], 0
        for a in VERIFY_ACTIVATIONS:
            at = np.full(ok.sum(), a)
            err = 100 * np.abs(fibre_force(law, length, table.departure(poses[ok]), at)
                               - fibre_force(law, length, solved["departure_m"][ok], at)) / float(table.meta["f0_N"])
            over += int((err > VERIFY_BOUND_PCT).sum())
            line.append(f"a = {a:g} largest {err.max():.2f} % of F0 at {poses[ok][int(np.argmax(err))].tolist()}")
        failed += bool(over or not ok.all())
        print(f"{t}: {ok.sum()} of {len(poses)} held-out poses solved; departures from the table within "
              f"{dep.max():.2f} mm (median {np.median(dep):.2f}); fibre force from the table against the re-solved "
              f"band's: {', '.join(line)} (bound {VERIFY_BOUND_PCT} %), {over} over"
              f"{'' if ok.all() else f'; unsolved at {poses[~ok].tolist()}'}: "
              f"{'pass' if not over and ok.all() else 'FAIL'}")
    return 1 if failed else 0
