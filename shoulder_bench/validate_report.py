"""The report of `shoulder-bench model validate`: the text tables and the overlay figures (shoulder_bench.validate
computes everything they show)."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from shoulder_bench import anatomy, references
from shoulder_bench.validate import ENVELOPE_MARGIN_MM, NOT_MODELLED, PASSIVE_MAX_DEG, PLANE_NAMES


def _fmt(x) -> str:
    return "-" if x is None else f"{x:.1f}"


def print_report(r: dict, file=None) -> None:
    def say(*a):
        print(*a, file=file or sys.stdout)

    mod, ma = r["model"], r["moment_arms"]
    refs, short = references.REFERENCES, references.SHORT
    say(f"shoulder-bench model validate: {mod['path']} (model version {mod['version']}), muscle tables "
        f"{mod['muscle_model']}")
    say(f"model: {mod['description']}")
    say(f"references: {', '.join(references.LABELS[x] for x in refs)} (computer-model outputs, not cadaver data); "
        "follows: " + ", ".join(f"{m} {short[f['reference']]}" for m, f in r["follows"].items()))
    cols = [0, 30, 60, 90, 120]
    idx = [ma["elevation_deg"].index(c) for c in cols]
    tp = mod["task_plane_deg"]
    say(f"\nElevation moment arm (mm, + elevates), {PLANE_NAMES.get(tp, tp)} plane, rotation 0; model girdle "
        f"{mod['girdle']}")
    say(f"{'':26s}" + "".join(f"{c:>7d}" for c in cols))
    for m in anatomy.MUSCLES:
        say(f"{m + ' model':26s}" + "".join(f"{ma['model_mm'][m][i]:7.1f}" for i in idx))
        for g in references.GIRDLES:
            for ref in refs:
                v = ma["references_mm"][f"{m}/shoulder_elv/{tp}/{g}"][ref]
                say(f"{f'{m} {short[ref]} {g}':26s}" + "".join(f"{v[i]:7.1f}" for i in idx))
    say("\nMoment-arm RMSE (mm) against each reference, elevation 0-120 deg, rotation 0")
    say(f"{'muscle':7s}{'DOF':11s}{'plane':10s}{'girdle':9s}" + "".join(f"{short[x]:>9s}" for x in refs) + "  note")
    groups: dict = {}
    for row in ma["rmse"]:
        groups.setdefault((row["muscle"], row["coordinate"]), []).append(row)
    for (m, coord), rows in groups.items():
        def missing(part):
            return all(row["rmse_mm"][refs[0]] is None for row in part)

        lines = [("both", "both", rows[0])] if missing(rows) else []  # one line for what the model lacks
        for plane in dict.fromkeys(row["plane_deg"] for row in rows) if not lines else ():
            part = [row for row in rows if row["plane_deg"] == plane]
            name = PLANE_NAMES.get(plane, str(plane))
            lines += [(name, "both", part[0])] if missing(part) else [(name, row["girdle"], row) for row in part]
        for plane, girdle, row in lines:
            errs = "".join(f"{_fmt(row['rmse_mm'][x]):>9s}" for x in refs)
            say(f"{m:7s}{references.DOF_LABELS[coord]:11s}{plane:10s}{girdle:9s}{errs}"
                + (f"  {row['note']}" if row["note"] else ""))
    say("\nQuantities")
    say(f"relaxed rest angle (activations 0): {r['relaxed_rest_deg']:.1f} deg")
    k = int(np.argmax(np.abs(r["passive_torque_Nm"])))
    say(f"net passive torque over 0-{PASSIVE_MAX_DEG:g} deg: {r['passive_torque_Nm'][0]:+.2f} N m at 0 deg, largest "
        f"|torque| {r['passive_torque_Nm'][k]:+.2f} N m at {r['passive_angle_deg'][k]:g} deg")
    say("peak isometric torque (a = 1 minus a = 0, 0-120 deg): " + ", ".join(
        f"{m} {p['peak_Nm']:+.2f} N m at {p['at_deg']:g} deg" for m, p in r["peak_isometric_torque"].items()))
    say("ssp/dmi isometric torque ratio: " + ", ".join(f"{a} deg {v:.2f}" for a, v in
                                                        r["capacity_ratio_ssp_dmi"].items()))
    reach = r["ssp_static_reach_deg"]
    say(f"ssp static reach with the {r['humerus_mass_kg']:g} kg humerus (ssp alone at activation 1 holds the arm up "
        f"to): {'none' if reach is None else f'{reach:.1f} deg'}")
    n_pass = sum(t["passed"] for t in r["targets"])
    say(f"\nTargets: {n_pass} of {len(r['targets'])} pass")
    for t in r["targets"]:
        say(f"[{'pass' if t['passed'] else 'FAIL'}] {t['target']}: {t['measured']} (bound: {t['bound']})")
        if t["note"]:
            say(f"       {t['note']}")
    for f in r.get("figures", []):
        say(f"figure: {f}")
    say("all targets met" if r["passed"] else f"{len(r['targets']) - n_pass} target(s) missed: exit status 1")


def write_figures(r: dict, out_dir: Path) -> list[Path]:
    """validate_<muscle>.png in out_dir: elevation moment arm vs elevation, model and the three references, for the
    coronal and scapular planes (columns) and the coupled and fixed girdle (rows); each written atomically."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from shoulder_bench.muscle import replacing

    ma, mod = r["moment_arms"], r["model"]
    x = np.asarray(ma["elevation_deg"])
    colours = {"mobl_arms": "tab:blue", "myoarm": "tab:green", "mobl_opensim": "tab:orange"}
    paths = []
    for m in anatomy.MUSCLES:
        fig, axes = plt.subplots(2, 2, figsize=(10, 7), sharex=True, sharey=True)
        for (i, girdle), (j, (pname, plane)) in ((a, b) for a in enumerate(references.GIRDLES)
                                                 for b in enumerate(references.PLANES.items())):
            ax = axes[i, j]
            curves = ma["references_mm"][f"{m}/shoulder_elv/{plane}/{girdle}"]
            for ref, y in curves.items():
                left = ref in references.ENVELOPE_EXCLUDED.get(m, {})
                ax.plot(x, y, color=colours[ref], ls=":" if left else "-",
                        label=references.LABELS[ref] + (" (not in envelope)" if left else ""))
            used = np.array([y for ref, y in curves.items() if ref not in references.ENVELOPE_EXCLUDED.get(m, {})])
            ax.fill_between(x, used.min(0) - ENVELOPE_MARGIN_MM, used.max(0) + ENVELOPE_MARGIN_MM, color="0.85",
                            label=f"envelope +- {ENVELOPE_MARGIN_MM:g} mm")
            if plane in mod["planes_deg"]:
                fixed_only = girdle != mod["girdle"]
                ax.plot(x, ma["model_mm"][m], "k--" if fixed_only else "k-", lw=2,
                        label=f"model (girdle {mod['girdle']})")
            else:
                ax.text(0.5, 0.05, "model: " + NOT_MODELLED, transform=ax.transAxes, ha="center", fontsize=8)
            ax.axhline(0, color="0.5", lw=0.5)
            ax.set_title(f"{pname} plane ({plane} deg), girdle {girdle}", fontsize=10)
            ax.set_xlabel("elevation (deg)") if i == 1 else None
            ax.set_ylabel("moment arm (mm, + elevates)") if j == 0 else None
        axes[0, 0].legend(fontsize=7, loc="best")
        fig.suptitle(f"{anatomy.MUSCLE_NAMES[m]} ({m}): elevation moment arm, rotation 0")
        fig.tight_layout()
        path = Path(out_dir) / f"validate_{m}.png"
        with replacing(path) as tmp:
            fig.savefig(tmp, dpi=90)
        plt.close(fig)
        paths.append(path)
    return paths
