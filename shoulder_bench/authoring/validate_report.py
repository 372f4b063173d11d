"""The report of `shoulder-bench model validate`: the text tables and the overlay figures
(shoulder_bench.authoring.validate
and, for the v2 model, shoulder_bench.authoring.validate_v2 compute everything they show)."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from shoulder_bench.authoring import anatomy, mobl_data, references
from shoulder_bench.authoring.validate import (
    ENVELOPE_MARGIN_MM,
    NOT_MODELLED,
    PASSIVE_MAX_DEG,
    PLANE_NAMES,
    REST_MAX_DEG,
)

COLOURS = {"mobl_arms": "tab:blue", "myoarm": "tab:green", "mobl_opensim": "tab:orange"}
COLS = [0, 30, 60, 90, 120]


def _fmt(x) -> str:
    return "-" if x is None else f"{x:.1f}"


def print_report(r: dict, file=None) -> None:
    def say(*a):
        print(*a, file=file or sys.stdout)

    mod, ma = r["model"], r["moment_arms"]
    if mod["version"] == "2":
        return _print_v2(r, say)
    if mod["version"] == "full":
        return _print_full(r, say)
    refs, short = references.REFERENCES, references.SHORT
    say(f"shoulder-bench model validate: {mod['path']} (model version {mod['version']}), muscle tables "
        f"{mod['muscle_model']}")
    say(f"model: {mod['description']}")
    _say_references(r, say)
    cols = COLS
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
    say(f"\nTargets: {sum(t['passed'] for t in r['targets'])} of {len(r['targets'])} pass")
    _say_targets(r, say)


def _say_references(r, say):
    refs, short = references.REFERENCES, references.SHORT
    say(f"references: {', '.join(references.LABELS[x] for x in refs)} (computer-model outputs, not cadaver data); "
        "follows: " + ", ".join(f"{m} {short[f['reference']]}" for m, f in r["follows"].items()))


def _say_targets(r, say):
    n_pass = sum(t["passed"] for t in r["targets"])
    for t in r["targets"]:
        say(f"[{'pass' if t['passed'] else 'FAIL'}] {t['target']}: {t['measured']} (bound: {t['bound']})")
        if t.get("coupled") and "planes" not in t:  # the start-of-abduction targets: the coupled girdle, beside
            say(f"       {_coupled(t['coupled'])}")
        for plane, res in t.get("planes", {}).items():  # v2: each candidate tasks' plane
            bound = f" (bound: {res['bound']})" if t["bound"] == "per plane" else ""
            coupled = f"; {_coupled(res['coupled'])}" if "coupled" in res else ""
            say(f"       {PLANE_NAMES[int(plane)]} ({plane} deg) {'pass' if res['passed'] else 'FAIL'}: "
                f"{res['measured']}{bound}{coupled}")
        if t.get("tables"):  # v2: the tasks' own tables' value beside a force target (no target)
            tab = t["tables"]
            say(f"       {tab['label']}, shown, no target: {'pass' if tab['passed'] else 'FAIL'}: {tab['measured']}")
        if t.get("parent_passive_curve"):  # v2: the estimate with the MoBL parent's own passive curve (no target)
            say(f"       with the parent's passive force-length curve (zero up to stretch 1.15; Blemker's starts at "
                f"1), shown, no target: {t['parent_passive_curve']}")
        if t["note"]:
            say(f"       {t['note']}")
    for f in r.get("figures", []):
        say(f"figure: {f}")
    say("all targets met" if r["passed"] else f"{len(r['targets']) - n_pass} target(s) missed: exit status 1")


def _coupled(c: dict) -> str:
    """The coupled-girdle value shown beside a target judged with the girdle fixed (information, no target)."""
    return f"girdle coupled (shown, no target): {c['measured']}" + (f" ({c['note']})" if c["note"] else "")


def _two_plane_table(say, ma, rows, label_width=22):
    """rows: (label, curve key, source) with source 'model' or a reference; both planes side by side."""
    idx = [ma["elevation_deg"].index(c) for c in COLS]
    say(f"{'':{label_width}s}" + "".join(f"{f'{n} ({p} deg)':>37s}" for n, p in references.PLANES.items()))
    say(f"{'':{label_width}s}" + ("  " + "".join(f"{c:>7d}" for c in COLS)) * len(references.PLANES))
    for label, key, source in rows:
        line = f"{label:{label_width}s}"
        for p in references.PLANES.values():
            k = key.format(plane=p)
            v = ma["model_mm"][k] if source == "model" else ma["references_mm"][k][source]
            line += "  " + "".join(f"{v[i]:7.1f}" for i in idx)
        say(line)


def _print_v2(r, say):
    mod, ma = r["model"], r["moment_arms"]
    short, girdles = references.SHORT, references.GIRDLES
    say(f"shoulder-bench model validate: {mod['path']} (model v2, the tasks' geometry: the tasks run its locked 1-DOF "
        f"variant {mod['tasks_model']}; force targets judged on a static estimate, the tasks' tables shown beside)")
    say(f"model: {mod['description']}")
    _say_references(r, say)
    say("v2 muscles: " + "; ".join(f"{m} = " + " + ".join(f"{w:.3f} {t}" for t, w in ws.items())
                                   for m, ws in mod["tendons"].items() if len(ws) > 1)
        + " (F0-weighted mean, the parent's F0)")
    say(f"note: {mod['note']}")
    say("\nElevation moment arm (mm, + elevates), rotation 0 (every DOF: --json and the figures)")
    rows = []
    for m in anatomy.MUSCLES:
        rows += [(f"{m} v2 {g}", f"{m}/shoulder_elv/{{plane}}/{g}", "model") for g in girdles]
        rows += [(f"{m} {short[x]} {g}", f"{m}/shoulder_elv/{{plane}}/{g}", x) for g in girdles
                 for x in references.REFERENCES]
    _two_plane_table(say, ma, rows)
    _rmse_table(say, ma, anatomy.MUSCLES)
    _say_v2_quantities(r, say)
    n_pass = sum(t["passed"] for t in r["targets"])
    tp = mod["task_plane_deg"]
    chosen = ("tasks' plane not chosen yet (validate.TASK_PLANE_V2 = None): the targets in it fail; both candidate "
              "planes shown" if tp is None else f"tasks' plane {PLANE_NAMES[tp]} ({tp} deg)")
    say(f"\nTargets: {n_pass} of {len(r['targets'])} pass; {chosen}")
    say("moment-arm targets met per candidate plane (girdle coupled; the start of abduction girdle fixed): "
        + ", ".join(f"{PLANE_NAMES[int(p)]} {c['passed']} of {c['of']}" for p, c in r["per_plane_passed"].items())
        + "; force targets (static estimate): " + ", ".join(
        f"{PLANE_NAMES[int(p)]} {c['force_passed']} of {c['force_of']}" for p, c in r["per_plane_passed"].items()))
    _say_targets(r, say)


def _rmse_table(say, ma, muscles, which="v2"):
    """Per muscle, DOF and girdle: the RMSE against each reference and the envelope results, both planes."""
    short, girdles = references.SHORT, references.GIRDLES
    say(f"\nMoment-arm RMSE (mm) against each reference; envelope: the references not left out +- "
        f"{ENVELOPE_MARGIN_MM:g} mm, w/o MyoArm: the same without MyoArm ({which} = MyoArm), worst mm outside at deg; "
        "elevation 0-120 deg, rotation 0")
    plane_head = "".join(f"{f'{n} ({p} deg)':>51s}" for n, p in references.PLANES.items())
    say(f"{'':27s}{plane_head}")
    say(f"{'muscle':7s}{'DOF':11s}{'girdle':9s}" + ("  " + "".join(f"{short[x]:>8s}" for x in references.REFERENCES)
                                                   + f"{'envelope':>12s}{'w/o MyoArm':>13s}") * 2)
    by_key = {(x["muscle"], x["coordinate"], x["plane_deg"], x["girdle"]): x for x in ma["rmse"]}
    for m in muscles:
        for c in references.COORDINATES:
            for g in girdles:
                line = f"{m:7s}{references.DOF_LABELS[c]:11s}{g:9s}"
                for p in references.PLANES.values():
                    row = by_key[(m, c, p, g)]
                    line += "  " + "".join(f"{_fmt(row['rmse_mm'][x]):>8s}" for x in references.REFERENCES)
                    for env, width in ((row["envelope"], 12), (row["envelope_without_myoarm"], 13)):
                        out = "inside" if env["inside"] else f"{env['outside_mm']:.1f} at {env['at_deg']:g}"
                        line += f"{out:>{width}s}"
                say(line)
    say("envelope references: " + "; ".join(
        f"{m} " + ", ".join(short[x] for x in references.REFERENCES if x not in references.ENVELOPE_EXCLUDED.get(m, {}))
        for m in muscles) + f" (the {which} targets use this envelope; w/o MyoArm is shown only)")


def _print_full(r, say):
    mod = r["model"]
    say(f"shoulder-bench model validate: {mod['path']} (the full shoulder: {len(mod['muscles'])} muscles, "
        f"{sum(len(w) for w in mod['tendons'].values())} tendons; force targets on a static estimate, the tasks' "
        "FEM tables beside)")
    say(f"model: {mod['description']}")
    say("path source: " + ", ".join(f"{t} {references.SHORT[s]}" for t, s in r["path_source"].items()))
    say(f"note: {mod['note']}")
    say(f"force targets: {r['force_targets']}")
    _rmse_table(say, r["moment_arms"], mod["muscles"], "full")
    _say_full_forces(r["forces"], say)
    say("\nPer muscle and DOF (every envelope, RMSE, role and peak-torque target of it, coronal and scapular planes, "
        "girdle coupled):")
    dofs = list(next(iter(r["summary"].values())))
    say(f"{'muscle':7s}" + "".join(f"{d:>11s}" for d in dofs))
    for m, res in r["summary"].items():
        say(f"{m:7s}" + "".join(f"{res[d]:>11s}" for d in dofs))
    say(f"\nTargets: {sum(t['passed'] for t in r['targets'])} of {len(r['targets'])} pass")
    _say_targets(r, say)


def _say_full_forces(forces: dict, say):
    """The full model's force quantities: the static estimate (judged) and the FEM tables (shown), each plane."""
    say("\nForces, rotation 0, girdle coupled: estimate = static rigid-tendon Hill (judged), FEM = the tasks' tables "
        "(shown), parent = the estimate with the parent's passive curve (shown)")
    for p, s in forces.items():
        rest = " / ".join(f"{s[k]['relaxed_rest_deg']:.1f}" for k in ("hill", "fem", "parent_passive_curve") if s[k])
        passive = "; ".join(f"{references.DOF_LABELS[c]} " + " / ".join(
            f"{s[k]['passive_max_Nm'][c]:+.2f}" for k in ("hill", "fem", "parent_passive_curve") if s[k])
            for c in references.COORDINATES)
        names = list(s["lam_at_0"])
        big = ", ".join(f"{t} {v:.2f}" for t, v in zip(names, s["hill"]["passive_by_tendon_max_Nm"]) if v > 0.1)
        say(f"{PLANE_NAMES[int(p)]} ({p} deg): relaxed rest (estimate / FEM / parent) {rest} deg; largest net passive "
            f"torque over 0-{PASSIVE_MAX_DEG:g} deg {passive} N m; tendons with a passive torque above 0.1 N m there "
            f"(estimate, any DOF): {big or 'none'}")
    s0 = next(iter(forces.values()))  # the side (0 deg) is the same pose in every plane
    say("at 0 deg, L_MT (mm) / fibre stretch (estimate): " + ", ".join(
        f"{t} {s0['L_at_0_mm'][t]:.1f} / {s0['lam_at_0'][t]:.2f}" for t in s0["lam_at_0"]))
    say("peak isometric torque / (F0 x the path source's peak moment arm), estimate (FEM):")
    planes = list(forces)
    say(f"{'muscle':7s}" + "".join(f"{PLANE_NAMES[int(p)] + ' ' + references.DOF_LABELS[c]:>22s}"
                                    for p in planes for c in references.COORDINATES))
    for m in next(iter(forces.values()))["hill"]["peak_isometric"]:
        cells = []
        for p in planes:
            s = forces[p]
            for c in references.COORDINATES:
                e = s["expected"][m][c]["expected_Nm"]
                est = s["hill"]["peak_isometric"][m][c]["peak_Nm"] / e
                fem = f" ({s['fem']['peak_isometric'][m][c]['peak_Nm'] / e:.2f})" if s["fem"] else ""
                cells.append(f"{est:.2f}{fem}")
        say(f"{m:7s}" + "".join(f"{c:>22s}" for c in cells))


def _say_v2_quantities(r, say):
    """The force quantities of the static estimate, each candidate plane."""
    st = r["statics"]
    say(f"\nQuantities ({st['method']}; rotation 0, girdle coupled)")
    planes = [(f"{PLANE_NAMES[int(p)]} ({p} deg)", s) for p, s in st["planes"].items()]

    def line(what, fmt):
        say(f"{what}: " + "; ".join(f"{name} {fmt(s)}" for name, s in planes))

    line("relaxed rest angle (activations 0)", lambda s: f"{s['relaxed_rest_deg']:.1f} deg")
    line(f"net passive torque over 0-{PASSIVE_MAX_DEG:g} deg", lambda s: (
        f"{s['passive_torque_Nm'][0]:+.2f} N m at 0 deg, largest |torque| {s['passive_max_Nm']:+.2f} N m at "
        f"{s['passive_max_at_deg']:g} deg"))
    line("peak isometric torque (a = 1 minus a = 0, 0-120 deg)", lambda s: ", ".join(
        f"{m} {p['peak_Nm']:+.2f} N m at {p['at_deg']:g} deg" for m, p in s["peak_isometric_torque"].items()))
    line("ssp/dmi isometric torque ratio", lambda s: ", ".join(
        f"{a} deg {v:.2f}" for a, v in s["capacity_ratio_ssp_dmi"].items()))
    line(f"ssp static reach with the {r['humerus_mass_kg']:.3g} kg humerus", lambda s: (
        "none" if s["ssp_static_reach_deg"] is None else f"{s['ssp_static_reach_deg']:.1f} deg"))
    line("fibre stretch at 0 deg", lambda s: ", ".join(f"{t} {v:.3f}" for t, v in s["lam_at_0"].items()))
    tab = r.get("tables")
    if tab is None:
        return
    plane = f"{PLANE_NAMES[tab['plane_deg']]} ({tab['plane_deg']} deg)"
    say(f"\nQuantities, {tab['label']}: {tab['folder']}/<tendon>_{tab['muscle_model']}.npz on {tab['model']}, "
        f"{plane} plane, rotation 0, girdle coupled; information, the targets judge the estimate above")
    p = tab["passive_torque_Nm"]
    k = int(np.argmax(np.abs(p)))
    say(f"relaxed rest angle (activations 0): {tab['relaxed_rest_deg']:.1f} deg")
    say(f"net passive torque over 0-{PASSIVE_MAX_DEG:g} deg: {p[0]:+.2f} N m at 0 deg, largest |torque| {p[k]:+.2f} "
        f"N m at {tab['passive_angle_deg'][k]:g} deg")
    say("peak isometric torque (a = 1 minus a = 0, 0-120 deg): " + ", ".join(
        f"{m} {q['peak_Nm']:+.2f} N m at {q['at_deg']:g} deg (ratio {q['ratio']:.2f})"
        for m, q in tab["peak_isometric_torque"].items()))
    say("ssp/dmi isometric torque ratio: " + ", ".join(f"{a} deg {v:.2f}" for a, v in
                                                        tab["capacity_ratio_ssp_dmi"].items()))
    reach = tab["ssp_static_reach_deg"]
    say(f"ssp static reach with the {r['humerus_mass_kg']:.3g} kg humerus: "
        + ("none" if reach is None else f"{reach:.1f} deg"))


def _draw_references(ax, m: str, x, curves: dict) -> None:
    """The references' curves (dotted: left out of the envelope) and the envelope +- margin, shaded."""
    for ref, y in curves.items():
        left = ref in references.ENVELOPE_EXCLUDED.get(m, {})
        ax.plot(x, y, color=COLOURS[ref], ls=":" if left else "-",
                label=references.LABELS[ref] + (" (not in envelope)" if left else ""))
    used = np.array([y for ref, y in curves.items() if ref not in references.ENVELOPE_EXCLUDED.get(m, {})])
    ax.fill_between(x, used.min(0) - ENVELOPE_MARGIN_MM, used.max(0) + ENVELOPE_MARGIN_MM, color="0.85",
                    label=f"envelope +- {ENVELOPE_MARGIN_MM:g} mm")


def write_figures(r: dict, out_dir: Path) -> list[Path]:
    """validate_<muscle>.png in out_dir: elevation moment arm vs elevation, model and the three references, for the
    coronal and scapular planes (columns) and the coupled and fixed girdle (rows); each written atomically. For the
    v2 model validate_v2_<muscle>.png: every DOF (rows) by plane and girdle (columns)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from shoulder_bench.muscle import replacing

    ma, mod = r["moment_arms"], r["model"]
    x = np.asarray(ma["elevation_deg"])
    paths = []
    for m in mod.get("muscles", anatomy.MUSCLES):
        if mod["version"] in ("2", "full"):
            fig = _figure_v2(plt, m, ma, mod["version"])
            path = Path(out_dir) / f"validate_{'v2' if mod['version'] == '2' else 'full'}_{m}.png"
        else:
            fig = _figure_v1(plt, m, ma, mod, x)
            path = Path(out_dir) / f"validate_{m}.png"
        with replacing(path) as tmp:
            fig.savefig(tmp, dpi=90)
        plt.close(fig)
        paths.append(path)
    if r.get("forces"):  # the full model: where the relaxed arm rests
        fig, path = _figure_relaxed(plt, r["forces"]), Path(out_dir) / "validate_full_relaxed_arm.png"
        with replacing(path) as tmp:
            fig.savefig(tmp, dpi=90)
        plt.close(fig)
        paths.append(path)
    return paths


def _figure_relaxed(plt, forces: dict):
    """Net elevation torque on the relaxed arm (activations 0: passive muscle torque + gravity) against elevation,
    coronal and scapular planes: the static estimate, the FEM tables and the estimate with the parent's passive curve;
    the arm rests where a curve crosses zero downwards."""
    fig, axes = plt.subplots(1, len(forces), figsize=(12, 4.5), sharey=True)
    labels = {"hill": "static estimate (judged)", "fem": "the tasks' FEM tables", "parent_passive_curve":
              "estimate, the parent's passive curve"}
    for ax, (p, s) in zip(np.atleast_1d(axes), forces.items()):
        x = np.asarray(s["elevation_deg"])
        for key, style in (("hill", "k-"), ("fem", "C0-"), ("parent_passive_curve", "C2--")):
            if s[key]:
                ax.plot(x, s[key]["net_relaxed_elevation_Nm"], style, label=f"{labels[key]}: rest "
                        f"{s[key]['relaxed_rest_deg']:.1f} deg")
        ax.plot(x, s["gravity_elevation_Nm"], color="0.5", lw=1, label="gravity alone (humerus)")
        ax.axhline(0, color="0.5", lw=0.5)
        ax.axvspan(-REST_MAX_DEG, REST_MAX_DEG, color="0.9", label=f"target: rest within {REST_MAX_DEG:g} deg")
        ax.set_title(f"{PLANE_NAMES[int(p)]} plane ({p} deg), rotation 0, girdle coupled", fontsize=9)
        ax.set_xlabel("elevation (deg)")
        ax.legend(fontsize=7, loc="best")
    np.atleast_1d(axes)[0].set_ylabel("net elevation torque, activations 0 (N m, + elevates)")
    fig.suptitle("The full model's relaxed arm: passive muscle torque + gravity along elevation")
    fig.tight_layout()
    return fig


def _figure_v1(plt, m, ma, mod, x):
    fig, axes = plt.subplots(2, 2, figsize=(10, 7), sharex=True, sharey=True)
    for (i, girdle), (j, (pname, plane)) in ((a, b) for a in enumerate(references.GIRDLES)
                                             for b in enumerate(references.PLANES.items())):
        ax = axes[i, j]
        _draw_references(ax, m, x, ma["references_mm"][f"{m}/shoulder_elv/{plane}/{girdle}"])
        if plane in mod["planes_deg"]:
            fixed_only = girdle != mod["girdle"]
            ax.plot(x, ma["model_mm"][m], "k--" if fixed_only else "k-", lw=2, label=f"model (girdle {mod['girdle']})")
        else:
            ax.text(0.5, 0.05, "model: " + NOT_MODELLED, transform=ax.transAxes, ha="center", fontsize=8)
        ax.axhline(0, color="0.5", lw=0.5)
        ax.set_title(f"{pname} plane ({plane} deg), girdle {girdle}", fontsize=10)
        ax.set_xlabel("elevation (deg)") if i == 1 else None
        ax.set_ylabel("moment arm (mm, + elevates)") if j == 0 else None
    axes[0, 0].legend(fontsize=7, loc="best")
    fig.suptitle(f"{anatomy.MUSCLE_NAMES[m]} ({m}): elevation moment arm, rotation 0")
    fig.tight_layout()
    return fig


def _figure_v2(plt, m, ma, version="2"):
    """3 DOFs (rows) x (coronal, scapular) x (coupled, fixed) (columns): v2 (or the full model) every 1 deg,
    references on their grid."""
    from shoulder_bench.authoring.validate_full import NAMES
    x, xf = np.asarray(ma["elevation_deg"]), np.asarray(ma["fine_elevation_deg"])
    cells = [(n, p, g) for n, p in references.PLANES.items() for g in references.GIRDLES]
    fig, axes = plt.subplots(3, len(cells), figsize=(17, 11), sharex=True, sharey="row")
    signs = {"shoulder_elv": "+ elevates", "shoulder_rot": "+ internal", "elv_angle": "+ anterior"}
    for i, coord in enumerate(references.COORDINATES):
        for j, (pname, plane, girdle) in enumerate(cells):
            ax, key = axes[i, j], f"{m}/{coord}/{plane}/{girdle}"
            _draw_references(ax, m, x, ma["references_mm"][key])
            ax.plot(xf, ma["model_fine_mm"][key], "k-", lw=2, label=f"{'v2' if version == '2' else 'full'} model")
            ax.axhline(0, color="0.5", lw=0.5)
            ax.set_title(f"{references.DOF_LABELS[coord]}: {pname} ({plane} deg), girdle {girdle}", fontsize=9)
            ax.set_xlabel("elevation (deg)") if i == 2 else None
            ax.set_ylabel(f"{references.DOF_LABELS[coord]} moment arm (mm, {signs[coord]})") if j == 0 else None
    axes[0, 0].legend(fontsize=7, loc="best")
    source = mobl_data.PATH_SOURCE.get(m, "myoarm")  # ssp: the parent's own path (docs/model_v2.md); pec1 OpenSim's
    own, match = {"mobl_arms": ("the parent's own path", "parent"), "myoarm": ("MyoArm's path", "MyoArm"),
                  "mobl_opensim": ("the OpenSim file's path", "OpenSim")}[source]
    fig.suptitle(f"{NAMES[m]} ({m}): {'v2' if version == '2' else 'full'} kinematic model against the references, "
                 f"rotation 0 ({'v2' if version == '2' else 'model'} = {own}: its {match} match is near-tautological; "
                 f"the {match} curve lies under the model's)")
    fig.tight_layout()
    return fig
