"""The latissimus dorsi transfer (issue 13, `ld_transfer`): the v2 model with ld1-3 rerouted, and its table sets.

The operation (Gerber et al. 1988, Clin Orthop 232:51; L'Episcopo's for the irreparable posterosuperior cuff tear):
the latissimus tendon is detached from its humeral insertion (the floor of the intertubercular groove), passed
behind the humerus between the posterior deltoid and the teres minor, and fixed on the greater tuberosity at the
posterosuperior footprint (the infraspinatus/supraspinatus insertion). Its origins and muscle belly stay.

What the model does (docs/surgery.md "ld_transfer"), for each bundle ld1-3 (MyoArm's LAT1-3):
* kept: the thoracic origin, the thoracic via points and the scapular via point (the inferior angle), i.e. every
  path item off the humerus (`KEPT`: the items after the last humeral one);
* removed: the humeral insertion (LATk-P1), the humeral via point LATk-P2 and the two humeral-shaft cylinders
  (TMAJ_LAThum, delt2hum) that lead the tendon round the anterior shaft into the groove: the tendon no longer goes
  there. The sites and geoms stay in the file (unused; the bodies of both models are identical);
* new insertion: MoBL's INFSP humeral insertion `INFSP_INFSP-P1` (identical in the parent and MyoArm,
  models/reference), the posterosuperior greater-tuberosity footprint the operation fixes the tendon to;
* new wrapping: the infraspinatus's humeral-head cylinder `infsp_new_cylinder` with its side site
  `infsp_new_sidesite` (MyoArm's stand-in for the parent's INFSP_and_TMIN_hum_head ellipsoid), so the rerouted
  tendon wraps over the posterior humeral head as the infraspinatus does.

Tendon slack lengths (the re-tensioning rule, `slack_lengths`): F0, l_opt and a0 stay the parent's; the surgeon
fixes the tendon under the tension it had, so l_ts is set so that each bundle's fibre stretch with the arm at the
side (the tasks' 0 deg: coronal plane, rotation 0, girdle coupled) equals the intact bundle's there. With a rigid
tendon and constant-width pennation that is l_ts' = l_ts + L_MT'(0) - L_MT(0). Not fitted to any target.

`python -m shoulder_bench.authoring.mobl` writes models/shoulder_v2_ld_transfer.xml (3-DOF),
models/shoulder_v2_task_ld_transfer.xml (the tasks' locked variant) and models/shoulder_full_task_ld_transfer.xml (the
full shoulder's task model, the 3-DOF tasks' ld_transfer) beside the intact files (`write_models`). ld's paths are the
same in the full shoulder, so are its re-tensioned slack lengths (`fem build --full --variant ld_transfer`).
"""
from __future__ import annotations

import dataclasses
import functools
import re
from pathlib import Path

import mujoco

from shoulder_bench import arm, full_arm
from shoulder_bench.authoring import mobl, statics_v2, tendons
from shoulder_bench.authoring import mobl_data as D

NAME = "ld_transfer"
REROUTED = ("ld1", "ld2", "ld3")
INSERTION = "INFSP_INFSP-P1"  # MoBL's infraspinatus insertion on the greater tuberosity (parent = MyoArm)
WRAP, SIDE = "infsp_new_cylinder", "infsp_new_sidesite"  # the infraspinatus's humeral-head cylinder and side site
FILENAME = arm.GEOMETRIES[NAME]["model_3dof"].name  # shoulder_v2_ld_transfer.xml
TASK_FILENAME = arm.GEOMETRIES[NAME]["model"].name  # shoulder_v2_task_ld_transfer.xml
FOLDER = arm.GEOMETRIES[NAME]["tables"]  # models/muscles_v2_ld_transfer
FULL_TASK_FILENAME = full_arm.GEOMETRIES[NAME]["model"].name  # shoulder_full_task_ld_transfer.xml
SLACK_RULE = ("l_ts' = l_ts + L_MT'(0) - L_MT(0): the intact bundle's fibre stretch with the arm at the side "
              "(tasks' 0 deg, coronal, rotation 0, girdle coupled); F0, l_opt, a0 the parent's")


def rerouted_paths(folder: Path | None = None) -> dict[str, list]:
    """ld1-3's new paths (Site/Wrap items, insertion first as in mobl_data): the INFSP insertion, the INFSP head
    cylinder with its side site, then the bundle's own items off the humerus (scapular via point, thorax)."""
    paths = D.muscle_paths(folder)
    isp = paths["isp"]
    insertion, wrap = isp[0], isp[1]
    if insertion.name != INSERTION or not isinstance(wrap, D.Wrap) or wrap.name != WRAP or wrap.side.name != SIDE:
        raise ValueError(f"isp's path no longer starts {INSERTION}, {WRAP} ({SIDE}): {isp[:2]}")
    out = {}
    for t in REROUTED:
        items = paths[t]
        last = max(k for k, it in enumerate(items) if it.body == "humerus")
        kept = items[last + 1:]
        if not kept or not all(isinstance(it, D.Site) and it.body in ("scapula", "thorax") for it in kept):
            raise ValueError(f"{t}: the items after its last humeral one are not scapular/thoracic sites: {kept}")
        out[t] = [insertion, wrap, *kept]
    return out


def _route(items) -> str:
    """A path as mobl.model_xml writes it inside <spatial>."""
    parts = []
    for it in items:
        if isinstance(it, D.Site):
            parts.append(f'<site site="{it.name}"/>')
        else:
            side = "" if it.side is None else f' sidesite="{it.side.name}"'
            parts.append(f'<geom geom="{it.name}"{side}/>')
    return "".join(parts)


def model_xml(folder: Path | None = None, **options) -> str:
    """`mobl.model_xml(**options)` with ld1-3 rerouted (`rerouted_paths`); model name + "_ld_transfer". Every
    site and geom of the new paths already exists in the intact file (isp's, ld's), so only the three <spatial>
    routes change."""
    xml = mobl.model_xml(folder=folder, **options)
    for t, items in rerouted_paths(folder).items():
        xml, n = re.subn(rf'(<spatial name="{t}"[^>]*>).*?(</spatial>)',
                         lambda m, items=items: m.group(1) + _route(items) + m.group(2), xml)
        if n != 1:
            raise ValueError(f"mobl.model_xml wrote {n} <spatial name={t!r}> elements, expected one")
    xml, n = re.subn(r'<mujoco model="([^"]+)">', r'<mujoco model="\1_ld_transfer">', xml, count=1)
    note = ("\n  <!-- Latissimus dorsi transfer (shoulder_bench/authoring/transfer.py, docs/surgery.md): ld1-3 "
            f"re-inserted at {INSERTION},\n       wrapped on {WRAP} ({SIDE}); origins and scapular/thoracic via "
            "points kept. -->")
    head, sep, rest = xml.partition("-->")
    return head + sep + note + rest


def task_model_xml() -> str:
    """The tasks' model with the transfer (`mobl.task_model_xml`'s options)."""
    return model_xml(locked_plane_deg=arm.TASK_PLANE_DEG, dynamics=True, actuators=True, scene=True)


def full_task_model_xml() -> str:
    """The full shoulder's task model with the transfer (`mobl.full_task_model_xml`'s options): the 3-DOF tasks'
    `ld_transfer` (full_arm.GEOMETRIES)."""
    return model_xml(muscles="full", dynamics=True, actuators=True, scene=True, timestep=mobl.FULL_TIMESTEP,
                     armature=mobl.FULL_ARMATURE)


def write_models(models_dir: Path | None = None) -> list[Path]:
    """Write the transfer's 3-DOF model, the tasks' model and the full shoulder's task model into `models_dir`
    (default the package's models)."""
    from shoulder_bench.model import MODELS_DIR

    out = []
    for name, text in ((FILENAME, model_xml()), (TASK_FILENAME, task_model_xml()),
                       (FULL_TASK_FILENAME, full_task_model_xml())):
        path = Path(models_dir or MODELS_DIR) / name
        path.write_text(text)
        out.append(path)
    return out


@functools.cache
def side_lengths(plane_deg: float = arm.TASK_PLANE_DEG) -> dict[str, tuple[float, float]]:
    """{bundle: (intact L_MT, transferred L_MT)} (m) with the arm at the side (0 deg, rotation 0, coupled)."""
    out = {}
    for key, xml in (("intact", mobl.model_xml(locked_plane_deg=plane_deg)),
                     ("transfer", model_xml(locked_plane_deg=plane_deg))):
        L, _ = statics_v2.LockedPath(model=mujoco.MjModel.from_xml_string(xml)).tendon_geometry([0.0], REROUTED)
        out[key] = L[0]
    return {t: (float(out["intact"][k]), float(out["transfer"][k])) for k, t in enumerate(REROUTED)}


def slack_lengths() -> dict[str, float]:
    """The re-tensioned l_ts' (m) of ld1-3 (`SLACK_RULE`), always from the tasks' plane."""
    parent = tendons.load_parent()
    return {t: parent[statics_v2.PARENT_MUSCLE[t]].l_ts + (new - old) for t, (old, new) in side_lengths().items()}


@dataclasses.dataclass(frozen=True)
class Variant:
    """A table set: which tendons, in which folder, on which model, with which fibre parameters."""
    name: str | None  # None: the intact shoulder
    tendons: tuple[str, ...]
    folder: Path

    def model_xml(self, **options) -> str:
        return mobl.model_xml(**options) if self.name is None else model_xml(**options)

    def parameters(self) -> dict[str, tendons.FibreParams]:
        parent = tendons.load_parent()
        p = {t: parent[statics_v2.PARENT_MUSCLE[t]] for t in self.tendons}
        if self.name == NAME:
            p = {t: dataclasses.replace(v, l_ts=slack_lengths()[t]) for t, v in p.items()}
        return p


VARIANTS = {None: Variant(None, statics_v2.TENDONS, arm.TABLE_FOLDER), NAME: Variant(NAME, REROUTED, FOLDER)}


def variant(name: str | None) -> Variant:
    if name not in VARIANTS:
        raise ValueError(f"unknown table variant {name!r}; choose from {[k for k in VARIANTS if k]} (or none)")
    return VARIANTS[name]
