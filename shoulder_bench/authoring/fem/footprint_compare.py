"""The footprint sheets solved at many poses (`compare`): the loop the footprint commands share (the report, the taut
band's grid check, the band tables and their verify), and the band continued down in activation (`continued`)."""
from __future__ import annotations

import numpy as np

from shoulder_bench import full_arm
from shoulder_bench.authoring.fem.footprint import FootprintSheet
from shoulder_bench.authoring.fem.solver import NoConvergence

HALVINGS = 3  # a continuation step where Newton fails is halved, at most this many times (down to 1/8 of it)


def continued(sheet: FootprintSheet, pose_deg, nodes: np.ndarray, activations, offsets_deg=()) -> np.ndarray:
    """(L, 3) m: the band's moment arms at each of `activations` (descending) below the equilibrium `nodes` (at
    `pose_deg`, a = 1). At each level the least-energy of two equilibria: the one continued from the level above
    (Newton, `FootprintSheet.solve_from`, a step where it fails halved, HALVINGS times at most) and the ramp's from rest
    at that level (`solve`, then `solve_from` for its energy); the next level continues from the one kept. Below a = 1
    the band has several equilibria at some poses, and the continuation alone lands on a higher one at some poses and
    not at their neighbours (`benchmarks/band_activation.py --along`); the least energy is the rule the tables hold at
    a = 1 too (`bands.least_energy`). Where neither converges, the least energy of those Newton reaches from the ramp's
    at the pose + each of `offsets_deg` (K, 3) (the tendon's least-energy starts, as at a = 1); NaN at a level where
    none converges, the next level continued from the last one kept."""
    arms, above = np.full((len(activations), 3), np.nan), 1.0
    for i, a in enumerate(activations):
        found = []
        for start in ("continued", "ramp"):
            try:
                found.append(_step(sheet, pose_deg, nodes, above, a, HALVINGS) if start == "continued"
                             else sheet.solve_from(pose_deg, sheet.solve(pose_deg, a)["nodes"], a))
            except NoConvergence:
                pass
        if not found and len(offsets_deg):
            try:
                found.append(sheet.solve_least_energy(pose_deg, offsets_deg, a, ramp=False))
            except NoConvergence:
                pass
        if not found:
            continue
        best = min(found, key=lambda sol: sol["energy_J"])
        arms[i], nodes, above = best["moment_arm_m"], best["nodes"], a
    return arms


def _step(sheet: FootprintSheet, pose_deg, nodes: np.ndarray, a_from: float, a_to: float, halvings: int) -> dict:
    """`solve_from` at `a_to` from the equilibrium `nodes` at `a_from`; where Newton fails, through the midpoint."""
    try:
        return sheet.solve_from(pose_deg, nodes, a_to)
    except NoConvergence:
        if halvings == 0:
            raise
        mid = (a_from + a_to) / 2
        half = _step(sheet, pose_deg, nodes, a_from, mid, halvings - 1)
        return _step(sheet, pose_deg, half["nodes"], mid, a_to, halvings - 1)


def fibre_lengths(sheet: FootprintSheet, nodes: np.ndarray) -> np.ndarray:
    """(nt,) m: each fibre's length in the sheet `nodes` ((ns nt, 3), fibre fastest): the polyline along it from the
    origin line to the insertion line."""
    x = np.asarray(nodes).reshape(sheet.ns, sheet.nt, 3)
    return np.linalg.norm(np.diff(x, axis=0), axis=2).sum(axis=0)


def compare(tendon: str, poses_deg, resolution="coarse", width_m: float | None = None, progress=None,
            surface: str = "wrap", pose: full_arm.Pose | None = None, rest: str = "reference",
            offsets_deg=None, activations=(), fallback: bool = False) -> dict:
    """FEM vs MJCF moment arms of `tendon` at `poses_deg` (P, 3): arrays (P, 3) in m (NaN where the sheet found no
    equilibrium: `converged`), the tensions and contact forces (N), each fibre's length in the solved sheet ("fibre_m",
    (P, nt) m, `fibre_lengths`), the central fibre's stretch (its initial shape's length over the reference's), its
    F0 (N). progress: called after each pose. surface: the sheet's contact surface
    (`SURFACES`). pose: the model posed (default: the task model, compiled anew). rest: the sheet's stress-free
    state (`RESTS`). offsets_deg (K, 3): each pose's least-energy equilibrium from those starts
    (`FootprintSheet.solve_least_energy`) instead of the ramp's; with `fallback`, the ramp's, and where it finds none
    the least-energy from those starts. activations (levels below 1, descending): the band at each, from the
    a = 1 equilibrium down (`continued`: the least-energy of the continuation and the ramp at each level, else from
    the starts; rest="pose" only), its arms in "fem_m_at" (P, L, 3), NaN where none converges. A ValueError if the
    tendon has no sheet (`FootprintSheet`). The footprint commands' loop over poses (the report, the taut band's grid
    check, the band tables and their verify)."""
    sheet = FootprintSheet(tendon, resolution, width_m, pose=pose, surface=surface, rest=rest)
    poses = np.atleast_2d(np.asarray(poses_deg, float))
    out = {"fem_m": np.full((len(poses), 3), np.nan), "mjcf_m": np.zeros((len(poses), 3)),
           "tension_N": np.full(len(poses), np.nan), "contact_N": np.full(len(poses), np.nan),
           "converged": np.zeros(len(poses), bool), "stretch": np.zeros(len(poses)),
           "fem_m_at": np.full((len(poses), len(activations), 3), np.nan),
           "fibre_m": np.full((len(poses), sheet.nt), np.nan)}
    for k, p in enumerate(poses):
        out["mjcf_m"][k] = sheet.mjcf_moment_arm(p)
        sheet._set(p)
        out["stretch"][k] = sheet.central_length() / sheet.reference_length
        try:
            s = sheet.solve(p) if offsets_deg is None or fallback else sheet.solve_least_energy(p, offsets_deg)
        except NoConvergence:
            s = None
        if s is None and fallback and offsets_deg is not None:
            try:
                s = sheet.solve_least_energy(p, offsets_deg, ramp=False)
            except NoConvergence:
                pass
        if s is not None:
            out["fem_m"][k], out["tension_N"][k] = s["moment_arm_m"], s["tension_N"]
            out["contact_N"][k], out["converged"][k] = s["contact_N"], True
            out["fibre_m"][k] = fibre_lengths(sheet, s["nodes"])
            if len(activations):
                starts = () if offsets_deg is None else offsets_deg
                out["fem_m_at"][k] = continued(sheet, p, s["nodes"], activations, starts)
        if progress is not None:
            progress()
    return {"tendon": tendon, "poses_deg": poses, "width_m": sheet.width, "resolution": (sheet.ns, sheet.nt),
            "surface": surface, "rest": rest, "f0_N": sheet.f0, **out}
