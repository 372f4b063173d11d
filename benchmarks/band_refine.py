"""Would a finer pose grid bring a band table within the 2 % held-out bound where it misses? (docs/fem.md "Taut bands")

    .venv/bin/python benchmarks/band_refine.py [--tendon T ...] [--at PLANE ELEVATION ROTATION ...]
        [--factors KP KE KR ...] [--starts N] [--branches]                        (seconds to minutes a tendon)

At a held-out pose p of the tasks' grid (a cell centre: by default the pose where `fem verify --bands` found each
tendon's largest error on the first tables, WORST_DEG), that grid cell is divided into a finer grid, the tasks' step
divided by (KP, KE, KR) per coordinate (`--factors`, repeatable; default 2 2 2: the 27 nodes p + {-h/2, 0, h/2}),
the taut band solved at its nodes and at the centres of its cells (its held-out poses), and each centre compared with
the trilinear reading of the correction (band - MJCF arms) on that finer grid, as `fem verify --bands` scores a table:
per coordinate, the torque error at a = 1 in % of the tendon's peak |F(L, 1) r_band| over the shipped table's grid;
printed, the largest over the centres. First printed: the shipped table's error at p (on its own grid). Each pose
solved by the ramp from rest, or with `--starts N` as `bands.least_energy` with N of its starts. Sheets at the tables'
resolution (full). `--branches`: the equilibria at p from the ramp and from each of the six starts instead.
"""
from __future__ import annotations

import argparse
import itertools

import numpy as np

from shoulder_bench import full_arm
from shoulder_bench.authoring.fem import bands
from shoulder_bench.authoring.fem.band_verify import peak_torque, tendon_force
from shoulder_bench.authoring.fem.bands import FOOTPRINT_TENDONS, BandTable, table_path
from shoulder_bench.authoring.fem.footprint import SURFACES
from shoulder_bench.authoring.fem.footprint_compare import compare
from shoulder_bench.tendon_law import TendonLaw

# each tendon's largest error of `fem verify --bands` on the first tables (588 held-out poses; docs/fem.md)
WORST_DEG = {"ssp": (82.5, 125.0, -37.5), "isp": (82.5, 135.0, -37.5), "tmi": (37.5, 45.0, -22.5),
             "tma": (7.5, 75.0, 52.5), "pec1": (82.5, 135.0, -22.5)}


def trilinear(corners: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """corners (2, 2, 2, 3) at a cell's corners, weights (3,) in [0, 1]: the trilinear reading (3,)."""
    out = np.zeros(3)
    for i, j, k in itertools.product((0, 1), repeat=3):
        w = (weights[0] if i else 1 - weights[0]) * (weights[1] if j else 1 - weights[1]) * \
            (weights[2] if k else 1 - weights[2])
        out += w * corners[i, j, k]
    return out


def setup(tendon: str) -> tuple:
    """(the task model posed, the tendon's band table, its force law, its peak torque: the verify's scale)."""
    pose, table, law = full_arm.Pose(), BandTable(table_path(tendon)), TendonLaw.load("fem", tendons=(tendon,))
    return pose, table, law, peak_torque(table, law, pose)


def study(tendon: str, at, factors=((2, 2, 2),), starts: int = 0, surface: str | None = None) -> None:
    surface = surface or bands.surface(tendon)
    pose, table, law, peak = setup(tendon)
    step = np.array([full_arm.POSE_STEP_DEG[c] for c in full_arm.COORDINATES])
    p = np.asarray(at, dtype=float)
    lo = p - step / 2  # the tasks' grid cell whose centre p is
    solved = {}

    def solve(poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:  # (band arms, MJCF arms), each pose solved once
        keys = [tuple(q) for q in np.round(poses, 9)]
        new = sorted(set(k for k in keys if k not in solved))
        if new:
            r = compare(tendon, np.array(new), table.meta["resolution"], pose=pose, rest="pose", surface=surface,
                        offsets_deg=bands.probe_offsets()[:starts] if starts else None)
            solved.update({k: (f, m) for k, f, m in zip(new, r["fem_m"], r["mjcf_m"])})
        return np.array([solved[k][0] for k in keys]), np.array([solved[k][1] for k in keys])

    band, mjcf = solve(p[None])
    at_p = tendon_force(law, pose, tendon, p[None])[0] * np.abs(mjcf[0] + table.correction(p)[0] - band[0]) / peak * 100
    how = "the ramp" if not starts else f"least energy, {starts} start(s)"
    print(f"{tendon:<5} at {tuple(p.tolist())} deg ({how}, contact with the {surface}), error % of peak, plane / "
          "elevation / rotation: the shipped table at p " + " / ".join(f"{x:.2f}" for x in at_p), flush=True)
    for k in map(np.array, factors):
        nodes = lo + np.array(list(itertools.product(*[range(n + 1) for n in k]))) * step / k
        cells = np.array(list(itertools.product(*[range(n) for n in k])))
        centres = lo + (cells + 0.5) * step / k
        band_n, mjcf_n = solve(nodes)
        c = (band_n - mjcf_n).reshape(*(k + 1), 3)  # the correction on the finer grid's nodes in this cell
        band_c, mjcf_c = solve(centres)
        if np.isnan(band_n).any() or np.isnan(band_c).any():
            print(f"  {'x'.join(map(str, k))}: no equilibrium at some pose; skipped")
            continue
        read = np.array([trilinear(c[i:i + 2, j:j + 2, m:m + 2], np.full(3, 0.5)) for i, j, m in cells])
        err = tendon_force(law, pose, tendon, centres)[:, None] * np.abs(mjcf_c + read - band_c) / peak * 100
        print(f"  step / {'x'.join(map(str, k))}: largest at its {len(centres)} cell centres "
              + " / ".join(f"{x:.2f}" for x in err.max(axis=0)), flush=True)


def branches(tendon: str, at) -> None:
    from shoulder_bench.authoring.fem.footprint import FootprintSheet
    from shoulder_bench.authoring.fem.solver import NoConvergence

    pose, table, law, peak = setup(tendon)
    p = np.asarray(at, dtype=float)
    quarter = np.array([full_arm.POSE_STEP_DEG[c] / 4 for c in full_arm.COORDINATES])
    sheet = FootprintSheet(tendon, table.meta["resolution"], pose=pose, rest="pose",
                           surface=bands.surface(tendon))
    found = []
    try:
        ramped = sheet.solve(p)
        found.append(("ramp from rest", ramped, sheet.solve_from(p, ramped["nodes"])["energy_J"]))
    except NoConvergence as exc:
        print(f"{tendon} at {tuple(p.tolist())} deg: the ramp from rest finds no equilibrium ({exc})", flush=True)
    for k, sign in itertools.product(range(3), (-1, 1)):
        q = p.copy()
        q[k] += sign * quarter[k]
        try:
            sol = sheet.solve_from(p, sheet.solve(q)["nodes"])
        except NoConvergence:
            continue
        found.append((f"from {full_arm.COORDINATE_LABELS[full_arm.COORDINATES[k]]} {sign * quarter[k]:+g} deg",
                      sol, sol["energy_J"]))
    force = tendon_force(law, pose, tendon, p[None])[0]
    mjcf = pose.tendon_geometry(p, (tendon,))[1][0, 0]
    read = mjcf + table.correction(p)[0]
    print(f"{tendon} at {tuple(p.tolist())} deg: equilibria of the sheet built there (moment arms mm; energy J; the "
          "table's error % of peak, plane / elevation / rotation)")
    if not found:
        print("  none of the seven starts finds one")
    for label, sol, energy in found:
        err = force * np.abs(read - sol["moment_arm_m"]) / peak * 100
        print(f"  {label:<24} " + " ".join(f"{x:8.3f}" for x in sol["moment_arm_m"] * 1e3)
              + f"  E {energy:.6f}  T {sol['tension_N']:.1f} N  error " + " / ".join(f"{x:.2f}" for x in err),
              flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tendon", nargs="+", choices=FOOTPRINT_TENDONS, default=list(FOOTPRINT_TENDONS))
    ap.add_argument("--at", nargs=3, type=float, action="append", metavar=("PLANE", "ELEVATION", "ROTATION"),
                    help="a held-out pose (deg; repeatable; default each tendon's worst, WORST_DEG)")
    ap.add_argument("--factors", nargs=3, type=int, action="append", metavar=("KP", "KE", "KR"),
                    help="a finer grid in the cell: the tasks' step divided by these (plane, elevation, rotation); "
                    "repeatable (default 2 2 2)")
    ap.add_argument("--starts", type=int, default=0, choices=range(7),
                    help="solve each pose as the least-energy of the ramp's and this many probe starts' equilibria "
                    "(bands.least_energy; default 0: the ramp alone)")
    ap.add_argument("--branches", action="store_true", help="the equilibria at the pose instead (see above)")
    ap.add_argument("--surface", choices=SURFACES,
                    help="the band's contact surface (default its table's, bands.SURFACE: wrap, the MJCF's wrap "
                    "object, or head, the humeral head sphere)")
    args = ap.parse_args()
    for t in args.tendon:
        for at in args.at or [WORST_DEG[t]]:
            if args.branches:
                branches(t, at)
            else:
                study(t, at, [tuple(f) for f in args.factors or [(2, 2, 2)]], args.starts, args.surface)


if __name__ == "__main__":
    main()
