"""`shoulder-bench fem verify`: held-out FEM solves against the tables, MuJoCo's torque against the FEM's, literature
checks, and the figure. Every check prints `[pass]` or `[FAIL]`; the exit status is 1 when any fails.

1. Interpolation: re-solve the FEM at (angle, activation) points between grid points and compare with the table's
   bilinear interpolation (the callback's scheme): |error| <= 2 % of the FEM torque or <= 0.2 N m.
2. MuJoCo vs FEM: the joint torque MuJoCo applies (actuator callback x tendon moment arm, zero velocity, each muscle
   alone) equals the table's FEM torque at every grid pose within APPLIED_TOL = 1 % of that muscle's peak |FEM
   torque| over the grid (no angle excepted).
3. Literature (reference file ../shared/reference/shoulder_parameters.md), over 0-120 deg, isometric torque = each
   muscle alone at a = 1 minus a = 0: dmi and ssp elevate wherever the literature moment arm is >= 5 mm; the ssp
   share of the dmi + ssp elevation torque is largest early and falls with elevation; ld depresses above 30 deg;
   peak torques in the bands dmi 15-60, ssp 3-20, ld 8-50 (depressing), isp |torque| <= 10 N m.

The figure (muscle_torques.png) goes to --out, default the current working directory.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from shoulder_bench.authoring import anatomy
from shoulder_bench.authoring.fem import output_folder

Check = tuple[str, bool, str]  # (what is checked, passed, the measured value)

HELD_OUT_ANGLES = np.array([2.5, 42.5, 87.5, 132.5])
HELD_OUT_ACTIVATIONS = (0.175, 0.625, 0.9)
REL_TOL, ABS_TOL = 0.02, 0.2
APPLIED_TOL = 0.01  # of the muscle's peak |FEM torque|: bound on |MuJoCo-applied - FEM torque| at every grid pose
# Literature moment arms for abduction, mm (straight-line MoBL paths, reference file); ld: LAT1, LAT2, LAT3.
LIT_ANGLES = np.array([0.0, 30.0, 60.0, 90.0, 120.0])
LIT_MOMENT_ARM_MM = {
    "ssp": [[16, 16, 11, 3, -3]],
    "isp": [[-2, -1, 0, 3, 7]],
    "dmi": [[22, 39, 49, 46, 23]],
    "ld": [[np.nan, -7, -26, -35, -37], [np.nan, 3, -26, -44, -50], [np.nan, 4, -35, -55, -60]],
}
PEAK_BANDS = {"dmi": (15.0, 60.0), "ssp": (3.0, 20.0), "ld": (8.0, 50.0), "isp": (0.0, 10.0)}
FIGURE_NAME = "muscle_torques.png"


def load_tables(folder: Path | None = None) -> dict[str, dict]:
    from shoulder_bench.model import MODELS_DIR
    from shoulder_bench.muscle import MuscleTable

    folder = Path(folder or MODELS_DIR / "muscles")
    if not folder.is_dir():
        raise FileNotFoundError(f"--tables {folder} is not a folder; give the folder holding <muscle>_fem.npz "
                                f"for {', '.join(anatomy.MUSCLES)} (default: {MODELS_DIR / 'muscles'})")
    out = {}
    for m in anatomy.MUSCLES:
        path = folder / f"{m}_fem.npz"
        MuscleTable.load(path)  # a missing or corrupt table: an error naming it and the command that rebuilds it
        with np.load(path, allow_pickle=False) as z:
            out[m] = {k: z[k] for k in z.files}
            out[m]["meta"] = json.loads(str(z["meta"]))
    return out


def interpolate(table: dict, angle_deg: float, activation: float) -> float:
    """Bilinear table torque (linear in angle on the uniform grid, linear in activation between levels)."""
    ang, act, tq = table["angle_deg"], table["activation"], table["torque_Nm"]
    x = np.clip((angle_deg - ang[0]) / (ang[1] - ang[0]), 0, len(ang) - 1 - 1e-9)
    i, w = int(x), x - int(x)
    j = min(int(np.searchsorted(act, activation, side="right")) - 1, len(act) - 2)
    u = (activation - act[j]) / (act[j + 1] - act[j])
    col = tq[:, j] * (1 - u) + tq[:, j + 1] * u
    return float(col[i] * (1 - w) + col[i + 1] * w)


def held_out(tables: dict, muscles=anatomy.MUSCLES) -> list[Check]:
    """Re-solve the held-out points with the same mesh resolution, material and solver as each table."""
    from shoulder_bench.authoring.fem.material import Material
    from shoulder_bench.authoring.fem.shells import build_shell
    from shoulder_bench.authoring.fem.solver import MuscleProblem, SolverSettings

    rows = []
    for m in muscles:
        meta = tables[m]["meta"]
        res = "coarse" if meta["resolution"] == [21, 6] else "full"
        problem = MuscleProblem(build_shell(m, res), Material(), SolverSettings(**meta["solver"]))
        for a in HELD_OUT_ACTIVATIONS:
            _, torque, _, _ = problem.sweep(HELD_OUT_ANGLES, a)
            for th, t in zip(HELD_OUT_ANGLES, torque):
                ti = interpolate(tables[m], th, a)
                rows.append((f"{m} {th:5.1f} deg, a = {a:.3f}", abs(ti - t) <= max(REL_TOL * abs(t), ABS_TOL),
                             f"FEM {t:8.3f}, table {ti:8.3f}, error {ti - t:7.3f} N m"))
    return rows


CONVERGENCE_RESOLUTIONS = ((11, 3), (21, 6), (41, 11), (81, 21))
CONVERGENCE_POINTS = ((30.0, 1.0), (90.0, 1.0), (60.0, 0.5))


def convergence(muscle: str = "ssp") -> list[tuple]:
    """Torque at a few (angle, activation) points on successively halved meshes, with the observed order
    p = log2(|t_h - t_h/2| / |t_h/2 - t_h/4|). Prints a table; returns its rows."""
    from shoulder_bench.authoring.fem.shells import build_shell
    from shoulder_bench.authoring.fem.solver import MuscleProblem

    torques = {}
    for res in CONVERGENCE_RESOLUTIONS:
        problem = MuscleProblem(build_shell(muscle, res))
        for th, a in CONVERGENCE_POINTS:
            _, t, _, _ = problem.sweep(np.array([th]), a)
            torques[res, th, a] = t[0]
    rows = []
    print(f"mesh convergence, {muscle}: torque (N m) per mesh (nodes along x across)")
    heads = " ".join(f"{f'{r[0]}x{r[1]}':>10}" for r in CONVERGENCE_RESOLUTIONS)
    print(f"{'angle':>6} {'act':>5} {heads}  order")
    for th, a in CONVERGENCE_POINTS:
        t = [torques[r, th, a] for r in CONVERGENCE_RESOLUTIONS]
        d = np.abs(np.diff(t))
        order = [float(np.log2(d[i] / d[i + 1])) if d[i + 1] > 0 else float("inf") for i in range(len(d) - 1)]
        rows.append((th, a, t, order))
        print(f"{th:6.1f} {a:5.2f} " + " ".join(f"{v:10.4f}" for v in t) + "  " + ", ".join(f"{o:.2f}" for o in order))
    return rows


def isometric(tables: dict, m: str) -> tuple[np.ndarray, np.ndarray]:
    t = tables[m]
    return t["angle_deg"], t["torque_Nm"][:, -1] - t["torque_Nm"][:, 0]


def literature_checks(tables: dict) -> list[Check]:
    checks = []
    ang, iso = {}, {}
    for m in anatomy.MUSCLES:
        a, t = isometric(tables, m)
        sel = (a >= 0) & (a <= 120)
        ang[m], iso[m] = a[sel], t[sel]
    for m in ("dmi", "ssp"):
        lit = np.interp(ang[m], LIT_ANGLES, np.asarray(LIT_MOMENT_ARM_MM[m][0], float))
        where = lit >= 5.0
        ok = bool(np.all(iso[m][where] > 0))
        checks.append((f"{m} elevates where the literature moment arm >= 5 mm "
                       f"({ang[m][where].min():.0f}-{ang[m][where].max():.0f} deg)", ok,
                       f"min {iso[m][where].min():.2f} N m"))
    share = iso["ssp"] / np.maximum(iso["ssp"] + iso["dmi"], 1e-9)
    early = share[ang["ssp"] <= 30].max()
    at90 = share[np.isclose(ang["ssp"], 90)][0]
    checks.append(("ssp share of elevation largest early (0-30 deg), falls by 90 deg",
                   bool(early >= share.max() - 1e-12 and at90 < early),
                   f"share 0 deg {share[0]:.2f}, max {share.max():.2f} at {ang['ssp'][share.argmax()]:.0f} deg, "
                   f"90 deg {at90:.2f}"))
    sel = ang["ld"] >= 30
    checks.append(("ld depresses above 30 deg", bool(np.all(iso["ld"][sel] < 0)),
                   f"max {iso['ld'][sel].max():.2f} N m"))
    for m, (lo, hi) in PEAK_BANDS.items():
        if m == "ld":
            peak = -iso[m].min()
            label = f"ld peak depressing torque in {lo:g}-{hi:g} N m"
        elif m == "isp":
            peak = np.abs(iso[m]).max()
            label = f"isp |torque| <= {hi:g} N m"
        else:
            peak = iso[m].max()
            label = f"{m} peak elevating torque in {lo:g}-{hi:g} N m"
        checks.append((label, bool(lo <= peak <= hi), f"{peak:.2f} N m"))
    return checks


def draw_figure(tables: dict, path: Path) -> Path:
    import matplotlib

    from shoulder_bench.muscle import replacing

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 4, figsize=(15, 6.5), sharex=True)
    for c, m in enumerate(anatomy.MUSCLES):
        t = tables[m]
        ang = t["angle_deg"]
        ax = axes[0, c]
        ax.plot(ang, 1000 * t["moment_arm_m"], "k-", label="MJCF tendon (ours)")
        fa = t["insertion_force_N"][:, -1] - t["insertion_force_N"][:, 0]
        eff = (t["torque_Nm"][:, -1] - t["torque_Nm"][:, 0]) / np.maximum(np.linalg.norm(fa, axis=1), 1e-9)
        ax.plot(ang, 1000 * eff, "b--", label="FEM torque / |insertion force|")
        for k, arm in enumerate(LIT_MOMENT_ARM_MM[m]):
            ax.plot(LIT_ANGLES, arm, "o", color=f"C{k + 1}", label="literature" + (f" LAT{k + 1}" if m == "ld" else ""))
        ax.axhline(0, color="0.7", lw=0.8)
        ax.set_title(f"{m} ({anatomy.MUSCLE_NAMES[m]})")
        ax.set_ylabel("moment arm (mm)" if c == 0 else "")
        ax.legend(fontsize=7)
        ax = axes[1, c]
        for j, a in enumerate(t["activation"]):
            ax.plot(ang, t["torque_Nm"][:, j], color=plt.cm.viridis(a), lw=1.0, label=f"a = {a:g}")
        ax.plot(ang, t["torque_Nm"][:, -1] - t["torque_Nm"][:, 0], "r--", lw=1.5, label="isometric (a=1 minus a=0)")
        ax.axhline(0, color="0.7", lw=0.8)
        ax.set_xlabel("abduction (deg)")
        ax.set_ylabel("torque (N m, + elevates)" if c == 0 else "")
        if c == 0:
            ax.legend(fontsize=7)
    fig.suptitle("FEM muscle tables: moment arms and joint torques (shoulder-bench fem verify)")
    fig.tight_layout()
    with replacing(path) as tmp:
        fig.savefig(tmp, dpi=110)
    plt.close(fig)
    return path


def applied_torques(folder: Path | None = None) -> dict[str, np.ndarray]:
    """{muscle: (K, J)} joint torque MuJoCo applies at every grid (angle, activation) of that muscle's table, through
    the actuator callback and the tendon moment arm, at zero velocity, with only that muscle active."""
    import mujoco

    from shoulder_bench.model import attach_law, compile_model, install_callbacks, tendon_jacobian
    from shoulder_bench.muscle import ForceLaw

    law = ForceLaw.load("fem", folder=folder)
    m = compile_model()
    attach_law(m, law)
    install_callbacks()
    d = mujoco.MjData(m)
    out = {}
    for c, table in enumerate(law.tables):
        applied = np.zeros_like(table.torque_Nm)
        for k, angle in enumerate(table.angle_deg):
            for j, a in enumerate(table.activation):
                d.qvel[:], d.ctrl[:] = 0.0, 0.0
                d.qpos[0], d.ctrl[c] = np.radians(angle), a
                mujoco.mj_forward(m, d)
                applied[k, j] = d.actuator_force[c] * tendon_jacobian(m, d)[c, 0]
        out[table.muscle] = applied
    return out


def applied_vs_fem(tables: dict, applied: dict[str, np.ndarray]) -> list[Check]:
    """Per muscle: the largest |applied - FEM torque| over the whole grid, in N m and as % of the muscle's peak |FEM
    torque|; passes when <= APPLIED_TOL of that peak."""
    checks = []
    for m, t in tables.items():
        err = np.abs(applied[m] - t["torque_Nm"])
        peak = float(np.abs(t["torque_Nm"]).max())
        k, j = np.unravel_index(int(err.argmax()), err.shape)
        worst = float(err[k, j])
        checks.append((f"{m}: MuJoCo-applied vs FEM torque at all {err.size} grid poses", worst <= APPLIED_TOL * peak,
                       f"max |error| {worst:.3f} N m = {100 * worst / peak:.2f} % of its peak {peak:.2f} N m "
                       f"(at {t['angle_deg'][k]:g} deg, a = {t['activation'][j]:g}; bound {100 * APPLIED_TOL:g} %)"))
    return checks


def report(sections: list[tuple[str, list[Check]]]) -> int:
    """Print each section's checks as [pass] / [FAIL] lines, then a summary naming every failed check.
    Returns 0 when all pass, 1 otherwise."""
    failed = []
    for title, checks in sections:
        print(f"\n{title}")
        for label, ok, detail in checks:
            print(f"  [{'pass' if ok else 'FAIL'}] {label}: {detail}")
            if not ok:
                failed.append(label)
    total = sum(len(checks) for _, checks in sections)
    if not failed:
        print(f"\nall {total} checks pass")
        return 0
    print(f"\n{len(failed)} of {total} checks FAILED:")
    for label in failed:
        print(f"  [FAIL] {label}")
    return 1


def verify(folder: Path | None = None, out: Path | None = None, figure: bool = True) -> int:
    """Run all checks and print them; draw the figure into `out` (default: the working directory).
    Returns 0 when all pass, 1 otherwise. Inputs and output are checked before any work."""
    out = output_folder(Path.cwd() if out is None else out, "--out") if figure else None
    tables = load_tables(folder)
    sections = [
        (f"held-out FEM solves vs bilinear table interpolation (pass: |error| <= {100 * REL_TOL:g} % or <= "
         f"{ABS_TOL:g} N m)", held_out(tables)),
        (f"MuJoCo's applied joint torque vs the FEM's, every grid pose (pass: max |error| <= {100 * APPLIED_TOL:g} "
         "% of the muscle's peak |FEM torque|)", applied_vs_fem(tables, applied_torques(folder))),
        ("literature checks (0-120 deg, isometric = a=1 minus a=0)", literature_checks(tables)),
    ]
    if figure:
        print(f"figure: {draw_figure(tables, out / FIGURE_NAME)}")
    return report(sections)
