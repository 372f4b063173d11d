"""`shoulder-bench fem verify --full`: the full shoulder's tables (`fem.full`) against fresh solves and against what
MuJoCo applies, over the whole pose space. Every check prints `[pass]` or `[FAIL]`; exit status 1 when any fails.

1. Held-out poses: the poses halfway between the pose grid's (`held_out_poses`), at activations between the
   table's levels (HELD_OUT_ACTIVATIONS). At each, the sheet is re-solved at the pose's own musculotendon length and
   compared with the table's interpolation there; the torque error in each coordinate is |dF| |r_k(q)|, bound
   HELD_OUT_TOL = 2 % of the tendon's peak |torque| in that coordinate (over the pose grid, every level).
2. MuJoCo vs FEM: at every pose of the grid and every activation level, each muscle alone (a law of its tendons
   only), the generalised force MuJoCo applies, S^T qfrc_actuator (S the coupling slopes), against the table's
   F(L(q), a) r(q) summed over the muscle's tendons; bound APPLIED_TOL = 1 % of the muscle's peak |torque| in each
   coordinate.

`coarse=True` re-solves on the coarse sheets (for tables built with `--coarse`, the tests).
"""
from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np

from shoulder_bench import full_arm
from shoulder_bench.authoring.fem.verify import Check, report

HELD_OUT_ACTIVATIONS = (0.175, 0.625, 0.9)
HELD_OUT_PER_TENDON = 12  # held-out poses per tendon, spread over its length range
HELD_OUT_TOL = 0.02
APPLIED_TOL = 0.01
LABELS = tuple(full_arm.COORDINATE_LABELS[c] for c in full_arm.COORDINATES)


def held_out_poses(refine=1) -> np.ndarray:
    """(P, 3) poses halfway between the pose grid's in every coordinate (deg); `refine` K (or one per coordinate):
    the grid's with its step divided by K (a band table's, `fem.bands.REFINE`)."""
    k = np.broadcast_to(np.asarray(refine), (3,))
    step = {c: full_arm.POSE_STEP_DEG[c] / kc for c, kc in zip(full_arm.COORDINATES, k)}
    axes = [np.arange(lo + step[c] / 2, hi, step[c]) for c, (lo, hi) in full_arm.POSE_RANGE_DEG.items()]
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)


def _interp(table, length: np.ndarray, activation: float) -> np.ndarray:
    from shoulder_bench.tendon_law import TendonLaw

    law = TendonLaw([table])
    return law.force(length[:, None], np.zeros((len(length), 1)), np.full((len(length), 1), activation))[:, 0]


def peak_torques(law, pose: full_arm.Pose, poses: np.ndarray) -> np.ndarray:
    """(n tendons, 3) each tendon's peak |F r_k| over `poses` and the table's levels."""
    L, r = pose.tendon_geometry(poses, law.actuators)
    peak = np.zeros((len(law.actuators), 3))
    for c, t in enumerate(law.tables):
        for a in t.activation:
            f = _interp(t, L[:, c], a)
            peak[c] = np.maximum(peak[c], np.abs(f[:, None] * r[:, c]).max(axis=0))
    return peak


def held_out(law, pose: full_arm.Pose, coarse: bool = False, tendons=None, geometry: str | None = None) -> list[Check]:
    from shoulder_bench.authoring.fem.full import specs
    from shoulder_bench.authoring.fem.material import Material
    from shoulder_bench.authoring.fem.v2 import SETTINGS
    from shoulder_bench.authoring.fem.v2_sheet import SheetProblem

    grid = full_arm.pose_grid()
    peaks = peak_torques(law, pose, grid)
    poses = held_out_poses()
    L, r = pose.tendon_geometry(poses, law.actuators)
    all_specs, checks = specs(geometry), []
    for c, t in enumerate(law.actuators):
        if tendons is not None and t not in tendons:
            continue
        order = np.argsort(L[:, c])
        pick = order[np.linspace(0, len(order) - 1, HELD_OUT_PER_TENDON).round().astype(int)]
        spec = all_specs[t]
        problem = SheetProblem(spec, "coarse" if coarse else "full", Material(), SETTINGS)
        worst, at = np.zeros(3), [None] * 3
        for a in HELD_OUT_ACTIVATIONS:
            solved = problem.sweep_extents(L[pick, c] - spec.l_ts, a)["force_N"]
            d_force = np.abs(_interp(law.tables[c], L[pick, c], a) - np.maximum(solved, 0.0))
            err = d_force[:, None] * np.abs(r[pick, c])  # (picked, 3)
            for k in range(3):
                i = int(np.argmax(err[:, k]))
                if err[i, k] > worst[k]:
                    worst[k], at[k] = err[i, k], (poses[pick[i]], a)
        for k in range(3):
            ok = worst[k] <= HELD_OUT_TOL * peaks[c, k]
            where = "" if at[k] is None else f" at pose {tuple(int(round(x)) for x in at[k][0])} deg, a = {at[k][1]:g}"
            checks.append((f"{t} {LABELS[k]}: {HELD_OUT_PER_TENDON} held-out poses x {len(HELD_OUT_ACTIVATIONS)} "
                           "activations re-solved", bool(ok),
                           f"max |error| {worst[k]:.4f} N m = {100 * worst[k] / peaks[c, k]:.3f} % of its peak "
                           f"{peaks[c, k]:.2f} N m{where}"))
    return checks


def applied_vs_fem(folder: Path | None = None, line_of_action: str = "mjcf", muscles=None,
                   geometry: str | None = None) -> list[Check]:
    """Section 2: each muscle alone (`muscles`, default all), MuJoCo's applied generalised force against the FEM's at
    every grid pose and level. line_of_action "band": the band tendons (`band_lines.BAND_TENDONS`), each acting along
    its band (`fem verify --bands`; the band tables from `folder`, the force tables from models/muscles_full, as
    the held-out check takes them), against F(L_band(q), a) times the band's own moment arms at its table's grid poses
    (below a = 1 plus its level table's move from them, where it has one); "band_fibres": the same, F the mean of
    its band's fibres' (`TendonLaw.force` with `TendonLaw.departures`; the fibre tables from `folder` too)."""
    from shoulder_bench.band_lines import AXES, BAND_TENDONS, BandLines, read_table, table_path
    from shoulder_bench.tendon_law import TendonLaw

    if line_of_action == "mjcf":
        return [c for muscle in muscles or full_arm.ACTUATORS for c in applied_checks(
            TendonLaw.load("fem", full_arm.ACTUATORS[muscle], folder, groups={muscle: full_arm.ACTUATORS[muscle]},
                           geometry=geometry), muscle, full_arm.pose_grid(), geometry=geometry)]
    checks = []
    for t in muscles or BAND_TENDONS:
        law = TendonLaw.load("fem", (t,))
        law.lines = BandLines.load((t,), folder, line_of_action == "band_fibres")
        arrays = read_table(table_path(t, folder))[0]
        poses = np.stack(np.meshgrid(*(arrays[k] for k in AXES), indexing="ij"), axis=-1).reshape(-1, 3)
        arms, lines = arrays["moment_arm_m"].reshape(-1, 1, 3), law.lines  # below a = 1: its level table's move
        checks += applied_checks(law, t, poses, lambda a, r=arms, c=lines, q=poses: r + c.correction(q, a)
                                 - c.correction(q, 1.0))
    return checks


def applied_checks(law, muscle: str, poses: np.ndarray, arms: np.ndarray | None = None,
                   geometry: str | None = None) -> list[Check]:
    """`law` (one muscle's) attached to the full shoulder (the model of `geometry`, default intact): S^T
    (qfrc_actuator + the passive callback's band forces) at `poses` (P, 3) deg and every level against F(L(q), a)
    (L: `law.geometry`'s, the bands' lengths where it has band lines) times `arms` (P, tendons, 3) or `arms(a)`,
    default the MJCF tendons' arms; bound APPLIED_TOL of the muscle's peak |torque| in each coordinate."""
    from shoulder_bench.model import attach_law, install_callbacks

    m = full_arm.compile_full(geometry)
    attach_law(m, law)
    install_callbacks()
    pose, d = full_arm.Pose(m), mujoco.MjData(m)
    L, r = law.geometry(pose, poses)  # with band lines: the bands' lengths, at which the force is read
    r = r if arms is None else arms
    qpos = pose.qpos(poses)
    levels = law.levels
    ids = [m.actuator(t).id for t in law.actuators]
    applied, table = np.zeros((len(poses), len(levels), 3)), np.zeros((len(poses), len(levels), 3))
    for j, a in enumerate(levels):
        f = law.force(L, np.zeros_like(L), np.full((len(poses), 1), a), law.departures(poses))  # (P, n)
        table[:, j] = np.einsum("pn,pnk->pk", f, r(a) if callable(r) else r)
        d.ctrl[:] = 0.0
        d.ctrl[ids] = a
        for p in range(len(poses)):
            d.qpos[:], d.qvel[:] = qpos[p], 0.0
            mujoco.mj_forward(m, d)
            # the passive callback's forces: qfrc_passive less MuJoCo's own passive terms
            band = d.qfrc_passive - d.qfrc_spring - d.qfrc_damper - d.qfrc_gravcomp - d.qfrc_fluid
            applied[p, j] = pose.slopes(poses[p]).T @ (d.qfrc_actuator + band)
    peak = np.abs(table).max(axis=(0, 1))
    checks = []
    for k in range(3):
        err = np.abs(applied[..., k] - table[..., k])
        p, j = np.unravel_index(int(np.argmax(err)), err.shape)
        checks.append((f"{muscle} {LABELS[k]}: MuJoCo-applied vs FEM at all {len(poses)} grid poses x {len(levels)} "
                       "levels",
                       bool(err.max() <= APPLIED_TOL * peak[k]),
                       f"max |error| {err.max():.2e} N m = {100 * err.max() / peak[k]:.2e} % of its peak "
                       f"{peak[k]:.2f} N m (at ({', '.join(f'{x:g}' for x in poses[p])}) deg, a = {levels[j]:g})"))
    return checks


def verify(folder: Path | None = None, coarse: bool = False, geometry: str | None = None) -> int:
    """Run both sections and print them; 0 when all pass, 1 otherwise. `geometry` (ld_transfer): its rerouted
    tendons' tables (in the geometry's folder, `full_arm.GEOMETRIES`) on its model, the muscle they make up alone."""
    from shoulder_bench.tendon_law import TendonLaw

    rerouted = None if geometry is None else full_arm.GEOMETRIES[geometry]["tendons"]
    if geometry is not None and folder is not None:
        raise ValueError(f"a variant's tables are read from {full_arm.GEOMETRIES[geometry]['tables']}; leave --tables "
                         "out with --variant")
    law = TendonLaw.load("fem", folder=folder, groups=full_arm.ACTUATORS,
                         geometry=geometry)  # a missing table: an error naming it
    pose = full_arm.Pose(full_arm.compile_full(geometry))
    muscles = None if geometry is None else [m for m, ts in full_arm.ACTUATORS.items() if set(ts) & set(rerouted)]
    sections = [
        (f"held-out poses re-solved vs the table (pass: |error| <= {100 * HELD_OUT_TOL:g} % of the tendon's peak "
         "|torque| in that coordinate)", held_out(law, pose, coarse, rerouted, geometry)),
        (f"MuJoCo's applied generalised force vs the FEM's, every grid pose and level (pass: <= "
         f"{100 * APPLIED_TOL:g} % of the muscle's peak |torque| in that coordinate)",
         applied_vs_fem(folder, muscles=muscles, geometry=geometry)),
    ]
    return report(sections)
