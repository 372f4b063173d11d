"""Writes the v2 shoulder model, `models/shoulder_v2.xml`, from MoBL-ARMS data (MyoArm's MuJoCo conversion).

`python -m shoulder_bench.authoring.mobl` regenerates the file; tests/test_mobl.py checks the shipped file is up to
date and
validates its kinematics against MyoArm's moment-arm table, which nothing here is fitted to. See docs/model_v2.md.

What comes from where (all read by `shoulder_bench.authoring.mobl_data` from `models/reference/`):

- bodies thorax -> clavicle -> clavphant -> scapula -> scapphant -> humphant -> humphant1 -> humerus with MyoArm's
  frames (`muscle_parameters.csv`, `body_frame` rows), EXCEPT the clavicle, which sits at MoBL's SC joint location
  (6.325, 6.93, 25.465) mm in the thorax frame (the `mobl_opensim` clavicle row). MyoArm puts it at (25.5, 6.9, -6.3)
  mm (reference README section 6.2: its girdle is 37 mm off its thorax attachments); the thorax sites keep MoBL's
  thorax coordinates, so moving the clavicle back is what makes them consistent with the girdle. MyoArm's clavicle
  frame is parallel to its thorax frame, so the clavicle gets no rotation;
- hinges with MyoArm's axes, order and ranges, named as MoBL's coordinates (`coordinate_definitions.csv`);
- joint equality constraints with MyoArm's polycoef (`girdle_coupling.csv`): the girdle rhythm driven by
  shoulder_elv, and shoulder1_r2 = -elv_angle;
- sites, wrap geoms (MyoArm's spheres and cylinders; its spheres are its stand-ins for MoBL's ellipsoids) and side
  sites of INFSP, DELT2, LAT1-3 as spatial tendons isp, dmi, ld1, ld2, ld3; ssp is the MoBL-ARMS parent's own SUPSP
  (three fixed points and its one wrap sphere, `mobl_data.PATH_SOURCE`, `models/reference/mobl_arms_parent_paths.csv`);
- the humerus inertial (`humerus_inertia.csv`). The girdle and phantom bodies get a 0.1 g placeholder (MuJoCo needs
  mass on moving bodies; MoBL's girdle masses are not in the reference data);
- visual geoms only: MoBL's `Thorax` wrap ellipsoid as the rib cage, a capsule clavicle from the SC to the AC joint,
  a flat ellipsoid scapula through the glenoid (GH centre), the SUPSP origin and the LAT3 scapular point, and a
  capsule humerus from the GH centre to twice its COM.

World frame: the thorax frame (x anterior, y superior, z lateral) rotated +90 deg about x, so world x is anterior,
z superior and y points to the subject's left (the right arm is on -y). No actuators by default (`actuators=True`
adds one per tendon, for the v2 Hill tables, `shoulder_bench.authoring.hill_v2`), no contact (no geom has a contype),
RK4 at
v1's timestep. No scene by default; the tasks' file (`task_model_xml`) has one (`scene=True`: sky, floor, light,
cameras `front` and `back`), so the tasks' physics renders by itself.
"""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

from shoulder_bench.authoring import mobl_data as D
from shoulder_bench.authoring.mjcf import MUSCLE_RGBA, PHYSICS_TIMESTEP

FILENAME = "shoulder_v2.xml"
TASK_FILENAME = "shoulder_v2_task.xml"  # arm.MODEL_FILE
THORAX_QUAT = (math.sqrt(0.5), math.sqrt(0.5), 0.0, 0.0)  # thorax y (superior) -> world z
# Placeholder inertial of the girdle and phantom bodies: MuJoCo refuses massless moving bodies, and the reference
# data has no girdle masses. Not anatomy; 0.1 g puts no measurable load on the slaved joints.
PLACEHOLDER_INERTIAL = '<inertial pos="0 0 0" mass="0.0001" diaginertia="1e-08 1e-08 1e-08"/>'
FULL_FILENAME = "shoulder_full.xml"  # the full shoulder's 3-DOF kinematic model (issue 12, docs/model_full.md)
FULL_TASK_FILENAME = "shoulder_full_task.xml"  # its stepping variant with actuators and scene (full_arm.MODEL_FILE)
# The full shoulder's stepping settings (docs/model_full.md "Dynamics", benchmarks/full_dynamics.py). RK4 at 10 ms:
# with the muscles on, the fast mode is axial rotation (humerus inertia about its long axis ~2e-3 kg m^2 against
# the tendons' stiffness), and 20 ms diverged under random activations where 10 ms did not. Armature 1e-4 kg m^2 on
# the three glenohumeral coordinates: MyoSuite's MyoArm's value for its arm joints (myo_sim
# arm/assets/myoarm_assets.xml, default class "arm"); it gives the plane of elevation an inertia at elevation 0,
# where MoBL's elv_angle and shoulder1_r2 cancel and the plane moves nothing but placeholders (docs/model_v2.md).
FULL_TIMESTEP = 0.01
FULL_ARMATURE = 1e-4
GH_COORDINATES = ("elv_angle", "shoulder_elv", "shoulder_rot")
# v1's colours for the four; the added muscles by group (deltoid reds, rotator cuff oranges, pectoral blues). Visual.
TENDON_RGBA = {**{t: MUSCLE_RGBA[t[:2] if t.startswith("ld") else t] for t in D.MUSCLES},
               "dan": "0.85 0.20 0.30 1", "dpo": "0.65 0.10 0.40 1", "ssc": "0.90 0.55 0.25 1",
               "tmi": "0.80 0.60 0.30 1", "tma": "0.55 0.30 0.55 1", "pec1": "0.25 0.40 0.80 1",
               "pec2": "0.20 0.30 0.70 1", "pec3": "0.15 0.25 0.60 1", "cor": "0.30 0.60 0.60 1"}
# Simulating the model (`model_xml(dynamics=True)` + `arm.harden_couplings`; benchmarks/v2_dynamics.py, docs/model_v2.md
# "Dynamics: options measured"). Numerical settings, not anatomy; none has a source.
# MuJoCo's hardest impedance (solimp dmax is capped at 0.9999): the couplings' regularizer R = (1 - d)/d * A_hat.
COUPLING_SOLIMP = (0.9999, 0.9999, 0.001, 0.5, 2)

# model_xml(scene=True): v1's scene (models/scene.xml: sky, haze, headlight, a directional key light, the floor 1.35 m
# below the shoulder) with its cameras `front` (anterior view, the right arm on the image's left) and `back` aimed at
# this model's shoulder: the GH centre is at about (-0.02, -0.17, 0) m, the humerus reaches y = -0.44 m at 90 deg and
# z = +0.29 m at the top of its range; the view (fovy 45 deg at 0.85 m) spans the arm over its range and the thorax.
# Visual only; the sky texture is small (it is compiled into every task model).
SCENE = {
    "visual": """  <statistic center="-0.02 -0.19 0" extent="0.5"/>
  <visual>
    <global offwidth="1280" offheight="960"/>
    <headlight diffuse="0.6 0.6 0.6" ambient="0.3 0.3 0.3" specular="0 0 0"/>
    <rgba haze="0.15 0.25 0.35 1"/>
  </visual>
  <asset>
    <texture type="skybox" builtin="gradient" rgb1="0.3 0.5 0.7" rgb2="0 0 0" width="64" height="384"/>
    <texture type="2d" name="groundplane" builtin="checker" mark="edge" rgb1="0.2 0.3 0.4" rgb2="0.1 0.2 0.3"
             markrgb="0.8 0.8 0.8" width="300" height="300"/>
    <material name="groundplane" texture="groundplane" texuniform="true" texrepeat="5 5" reflectance="0.2"/>
  </asset>""",
    "worldbody": """    <!-- scene (rendering only) -->
    <light name="key" pos="0.8 0.4 1.0" dir="-0.6 -0.3 -0.7" directional="true"/>
    <geom name="floor" pos="0 0 -1.35" size="0 0 0.05" type="plane" material="groundplane" group="0"/>
    <camera name="front" pos="0.85 -0.19 0.04" xyaxes="0 1 0 -0.05 0 1" fovy="45"/>
    <camera name="back" pos="-0.85 -0.19 0.04" xyaxes="0 -1 0 0.05 0 1" fovy="45"/>
""",
}


def _n(x: float) -> str:
    """A data value, as written in the CSV (at most 10 significant digits)."""
    s = f"{x:.10g}"
    return "0" if s == "-0" else s


def _c(x: float) -> str:
    """A computed (visual) value, fixed precision so the file does not depend on the CPU's last bits."""
    s = f"{x:.5f}".rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def _v(p, f=_n) -> str:
    return " ".join(f(float(x)) for x in p)


def _euler_xyz_quat(a: tuple) -> tuple:
    """OpenSim body-fixed XYZ rotation (rad) as a quaternion w x y z: q = qx(a0) qy(a1) qz(a2)."""
    q = np.array([1.0, 0.0, 0.0, 0.0])
    for k, ang in enumerate(a):
        r = np.zeros(4)
        r[0], r[k + 1] = math.cos(ang / 2), math.sin(ang / 2)
        w1, v1, w2, v2 = q[0], q[1:], r[0], r[1:]
        q = np.concatenate([[w1 * w2 - v1 @ v2], w1 * v2 + w2 * v1 + np.cross(v1, v2)])
    return tuple(q)


def _mat_quat(R: np.ndarray) -> tuple:
    """Rotation matrix (columns = the body axes) to a quaternion w x y z (R has a positive trace here)."""
    w = math.sqrt(max(0.0, 1.0 + R[0, 0] + R[1, 1] + R[2, 2])) / 2
    return (w, (R[2, 1] - R[1, 2]) / (4 * w), (R[0, 2] - R[2, 0]) / (4 * w), (R[1, 0] - R[0, 1]) / (4 * w))


def _scapula_visual(frames: dict, paths: dict) -> str:
    """A flat ellipsoid in the blade's plane through the glenoid, the SUPSP origin and LAT3's scapular point."""
    g = np.array(frames["scapphant"].pos)  # the GH centre (glenoid) in the scapula frame
    s = np.array(next(i.pos for i in reversed(paths["ssp"]) if isinstance(i, D.Site)))  # supraspinous fossa
    i3 = np.array(next(i.pos for i in paths["ld3"] if isinstance(i, D.Site) and i.body == "scapula"))  # inf. angle
    c = (g + s + i3) / 3
    e1 = (s - i3) / np.linalg.norm(s - i3)
    n = np.cross(s - g, i3 - g)
    e3 = n / np.linalg.norm(n)
    e2 = np.cross(e3, e1)
    R = np.column_stack([e1, e2, e3])
    if np.trace(R) < 0:  # keep the quaternion formula well conditioned: flip two axes (same ellipsoid)
        R[:, 1:] *= -1
    pts = np.stack([g, s, i3]) - c
    half = np.abs(pts @ R).max(axis=0)
    size = (half[0] + 0.01, half[1] + 0.01, 0.004)
    return (f'<geom name="scapula" type="ellipsoid" class="bone" pos="{_v(c, _c)}" '
            f'quat="{_v(_mat_quat(R), _c)}" size="{_v(size, _c)}"/>')


def _qmul(a, b) -> tuple:
    w1, v1, w2, v2 = a[0], np.asarray(a[1:]), b[0], np.asarray(b[1:])
    return (w1 * w2 - v1 @ v2, *(w1 * v2 + w2 * v1 + np.cross(v1, v2)))


def _axis_quat(axis, angle: float) -> tuple:
    u = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    return (math.cos(angle / 2), *(math.sin(angle / 2) * u))


def _rotate(q, v) -> tuple:
    """R(q) v for a unit quaternion q = (w, x, y, z)."""
    p = _qmul(_qmul(q, (0.0, *v)), (q[0], -q[1], -q[2], -q[3]))
    return tuple(p[1:])


def _locked_values(plane_deg: float) -> dict[str, float]:
    """The locked 1-DOF variant's fixed GH coordinates (rad): the plane, shoulder1_r2 = -plane, rotation 0."""
    p = math.radians(plane_deg)
    return {"elv_angle": p, "shoulder1_r2": -p, "shoulder_rot": 0.0}


def _lock(frames: dict, joints: list, locked: dict[str, float]) -> tuple[dict, list]:
    """Bake locked hinges into the body frames: a body's leading locked joints into its own quat, its trailing ones
    into its child's pos and quat (allowed only where the body carries nothing but its placeholder inertial, so
    nothing else it holds would have to turn). MuJoCo applies a body's joints in order, xquat = quat * q1 * q2 ..."""
    frames, kept = dict(frames), []
    by_body = {b: [j for j in joints if j.body == b] for b in D.CHAIN}
    for i, b in enumerate(D.CHAIN):
        js = by_body[b]
        free = [k for k, j in enumerate(js) if j.name not in locked]
        lead = js[:free[0]] if free else js
        trail = js[free[-1] + 1:] if free else []
        if free and any(j.name in locked for j in js[free[0]:free[-1] + 1]):
            raise ValueError(f"body {b}: a locked joint between free ones cannot be baked into a frame")
        q = frames[b].quat
        for j in lead:
            q = _qmul(q, _axis_quat(j.axis, locked[j.name]))
        frames[b] = dataclasses.replace(frames[b], quat=q)
        if trail:
            if b in ("thorax", "clavicle", "scapula", "humerus") or i + 1 == len(D.CHAIN):
                raise ValueError(f"body {b}: trailing locked joints only on a phantom body")
            r = (1.0, 0.0, 0.0, 0.0)
            for j in trail:
                r = _qmul(r, _axis_quat(j.axis, locked[j.name]))
            child = frames[D.CHAIN[i + 1]]
            frames[child.name] = dataclasses.replace(child, pos=_rotate(r, child.pos), quat=_qmul(r, child.quat))
        kept += [j for j in js if j.name not in locked]
    return frames, kept


def model_xml(clavicle: str = "mobl", folder: Path | None = None, locked_plane_deg: float | None = None,
              dynamics: bool = False, actuators: bool = False, scene: bool = False, paths: str = "v2",
              muscles: str = "v2", timestep: float = PHYSICS_TIMESTEP, armature: float = 0.0) -> str:
    """The v2 MJCF. `clavicle="myoarm"` puts the clavicle where MyoArm has it and `paths="myoarm"` gives every
    tendon MyoArm's path (ssp's too; v2's ssp is the parent's, `mobl_data.PATH_SOURCE`): both for the
    reconstruction tests only.

    `locked_plane_deg`: the locked 1-DOF variant the paper's tasks run on: elevation (`shoulder_elv`) the only GH
    coordinate, in the plane of elevation `locked_plane_deg` (0 = coronal), axial rotation 0. `elv_angle`,
    `shoulder1_r2` (= -plane) and `shoulder_rot` become fixed rotations of the humphant and humerus frames; the
    girdle stays coupled to elevation by the same polycoef equalities.

    `dynamics=True`: settings for stepping the model (docs/model_v2.md "Dynamics: options measured"): the coupled
    (slaved) joints get no limits (their ranges start at their rest value, and below 0 deg elevation, past a soft
    limit, the couplings would fight them; the drivers' limits bound them), the equalities get `COUPLING_SOLIMP`.
    Compile, then `arm.harden_couplings(model)`. RK4 at v1's timestep, no joint damping (none is needed for stability
    and no value has a source). The default (False) is the shipped kinematic file.

    `actuators=True`: one `general` actuator per tendon (ssp, isp, dmi, ld1, ld2, ld3), declared as v1's
    (`mjcf.model_xml`): tendon transmission, `user` gain and bias, ctrlrange 0..1, `user="law column"` (the law id
    is filled in at load time, `model.attach_law`). Why a tendon transmission: MuJoCo applies the joint force
    F x ten_J, and ten_J is the exact derivative of the same path length `ten_length` that the table's fibre
    length comes from (`hill_v2`), so the applied torque is the table's at every pose by construction, with no
    separately fitted moment arm that could drift from the path; along the coupled girdle the reduced torque is
    S^T ten_J^T F, S the coupling slopes. A table that changes (the FEM's, later) changes data, not this. Compile
    with `model.compile_model`'s recipe (user actuators cannot be compiled while the callbacks are installed).

    `paths="mobl_opensim"`: the OpenSim file's path for every tendon whose muscle it has (tests and the
    path-source rule only, `mobl_data.muscle_paths`).

    `muscles="full"`: the full shoulder (`mobl_data.FULL_MUSCLES`: the v2 six tendons and dan, dpo, ssc, tmi, tma,
    pec1-3, cor on MyoArm's paths; docs/model_full.md), model name `shoulder_full`; the default "v2" is the four.

    `timestep`: the physics step (s, RK4; default v1's); `armature`: joint armature (kg m^2) of the free
    glenohumeral coordinates (GH_COORDINATES; default none). The full shoulder's task model uses FULL_TIMESTEP and
    FULL_ARMATURE.

    `scene=True`: what rendering needs (`SCENE`): sky, floor, lights and the cameras `front` and `back`, v1's
    (models/scene.xml) framed on this model's shoulder and girdle. Visual only: no effect on the dynamics."""
    frames, joints, paths = D.body_frames(folder), D.joints(folder), D.muscle_paths(folder, paths, muscles)
    D.check_clavicle_parallel(folder)
    if clavicle not in ("mobl", "myoarm"):
        raise ValueError(f"clavicle must be 'mobl' or 'myoarm', not {clavicle!r}")
    sc = D.mobl_sc_location(folder) if clavicle == "mobl" else D.myoarm_sc_location(folder)
    locked = {} if locked_plane_deg is None else _locked_values(float(locked_plane_deg))
    frames, joints = _lock(frames, joints, locked)
    slaved = {c.dependent for c in D.couplings(folder)}
    inner = {b: [] for b in D.CHAIN}
    for j in joints:
        free = ' limited="false"' if dynamics and j.name in slaved else ""
        if armature and j.name in GH_COORDINATES:
            free += f' armature="{_n(float(armature))}"'
        inner[j.body].append(f'<joint name="{j.name}" axis="{_v(j.axis)}" range="{_v(j.range_deg)}"{free}/>')
    for b in D.CHAIN[1:-1]:
        inner[b].append(PLACEHOLDER_INERTIAL)
    hum = D.humerus_inertial(folder)
    inner["humerus"].append(f'<inertial pos="{_v(hum.com)}" mass="{_n(hum.mass)}" fullinertia="{_v(hum.full)}"/>')
    tpos, trot, tsize = D.thorax_ellipsoid(folder)
    inner["thorax"].append(f'<geom name="thorax" type="ellipsoid" class="bone" pos="{_v(tpos)}" '
                           f'quat="{_v(_euler_xyz_quat(trot), _c)}" size="{_v(tsize)}"/>')
    inner["clavicle"].append(f'<geom name="clavicle" type="capsule" class="bone" size="0.006" '
                             f'fromto="0 0 0 {_v(frames["clavphant"].pos)}"/>')
    inner["scapula"].append(_scapula_visual(frames, paths))
    inner["humerus"].append(f'<geom name="humerus" type="capsule" class="bone" size="0.012" '
                            f'fromto="0 0 0 {_v([2 * x for x in hum.com], _c)}"/>')
    seen, tendons = {}, []
    for tendon, items in paths.items():
        route = []
        for it in items:
            if isinstance(it, D.Site):
                _place(seen, inner, it, f'<site name="{it.name}" pos="{_v(it.pos)}" class="muscle_site"/>')
                route.append(f'<site site="{it.name}"/>')
                continue
            size = _v(it.size)
            _place(seen, inner, it, f'<geom name="{it.name}" type="{it.kind}" class="wrap" pos="{_v(it.pos)}" '
                                    f'quat="{_v(it.quat)}" size="{size}"/>')
            side = ""
            if it.side is not None:
                _place(seen, inner, it.side, f'<site name="{it.side.name}" pos="{_v(it.side.pos)}" class="side_site"/>')
                side = f' sidesite="{it.side.name}"'
            route.append(f'<geom geom="{it.name}"{side}/>')
        tendons.append(f'<spatial name="{tendon}" width="0.003" rgba="{TENDON_RGBA[tendon]}">'
                       + "".join(route) + "</spatial>")
    imp = f' solimp="{_v(COUPLING_SOLIMP)}"' if dynamics else ""
    eqs = [f'<joint name="{c.name}" joint1="{c.dependent}" joint2="{c.driver}" polycoef="{_v(c.polycoef)}"{imp}/>'
           for c in D.couplings(folder) if c.dependent not in locked and c.driver not in locked]
    acts = [f'<general name="{t}" tendon="{t}" gaintype="user" biastype="user" ctrlrange="0 1" user="0 {k}"/>'
            for k, t in enumerate(paths)] if actuators else []
    body_attr = {b: f'pos="{_v(frames[b].pos)}" quat="{_v(frames[b].quat)}"' for b in D.CHAIN[2:]}
    body_attr["thorax"] = f'pos="0 0 0" quat="{_v(THORAX_QUAT)}"'
    body_attr["clavicle"] = f'pos="{_v(sc)}" quat="1 0 0 0"'
    body = ""
    for depth, b in reversed(list(enumerate(D.CHAIN))):
        pad = "  " * (depth + 2)
        lines = "".join(f"{pad}  {x}\n" for x in inner[b])
        body = f'{pad}<body name="{b}" {body_attr[b]}>\n{lines}{body}{pad}</body>\n'
    where = "MoBL's SC location" if clavicle == "mobl" else "MyoArm's clavicle location (test variant)"
    name, variant = ("shoulder_v2", "") if muscles == "v2" else (
        "shoulder_full", f"\n       Full shoulder: {len(paths)} tendons ({', '.join(paths)}).")
    if locked:
        name += "_locked"
        variant += (f"\n       Locked 1-DOF variant: plane of elevation {_n(float(locked_plane_deg))} deg, axial "
                    "rotation 0\n       (elv_angle, shoulder1_r2, shoulder_rot baked into the frames).")
    if dynamics:
        variant += ("\n       Dynamics settings: slaved joints unlimited, hard coupling impedance; call\n"
                    "       arm.harden_couplings(model) after compiling.")
    if timestep != PHYSICS_TIMESTEP or armature:
        variant += (f"\n       Stepping: RK4 at {_n(float(timestep))} s, glenohumeral armature {_n(float(armature))} "
                    "kg m^2 (mobl.FULL_TIMESTEP, FULL_ARMATURE).")
    if actuators:
        variant += "\n       Actuators: one per tendon, user gain/bias (the tabled force law, model.attach_law)."
    if scene:
        variant += "\n       Scene: sky, floor, lights, cameras front and back (rendering only)."
    nl = "\n    "
    visual = SCENE["visual"] if scene else '  <visual><global offwidth="1280" offheight="960"/></visual>'
    scene_body = SCENE["worldbody"] if scene else ""
    size = '\n  <size nuser_actuator="2"/>' if actuators else ""
    act_block = f"\n  <actuator>\n    {nl.join(acts)}\n  </actuator>" if actuators else ""
    return f"""<mujoco model="{name}">
  <!-- Generated by shoulder_bench/authoring/mobl.py from models/reference/*.csv (MyoArm's MoBL-ARMS geometry;
       clavicle at {where}); edit those, not this file. docs/model_v2.md{variant} -->
  <compiler angle="degree" autolimits="true" inertiafromgeom="false"/>
  <option timestep="{_n(float(timestep))}" integrator="RK4" gravity="0 0 -9.81"><flag contact="disable"/></option>{size}
{visual}
  <default>
    <geom contype="0" conaffinity="0" group="1"/>
    <default class="bone"><geom rgba="0.89 0.85 0.76 1"/></default>
    <default class="wrap"><geom rgba="0.75 0.80 0.85 0.35" group="2"/></default>
    <default class="muscle_site"><site size="0.004" rgba="0.9 0.2 0.2 1" group="3"/></default>
    <default class="side_site"><site size="0.003" rgba="0.2 0.9 0.2 1" group="4"/></default>
  </default>
  <worldbody>
{scene_body}{body}  </worldbody>
  <equality>
    {nl.join(eqs)}
  </equality>
  <tendon>
    {nl.join(tendons)}
  </tendon>{act_block}
</mujoco>
"""


def _place(seen: dict, inner: dict, item, xml: str) -> None:
    """Add a site/geom to its body once; an item shared by several paths must be the same in every row."""
    if isinstance(item, D.Wrap):
        item = dataclasses.replace(item, side=None)  # the side site belongs to the path, not to the geom
    if item.name in seen:
        if seen[item.name] != item:
            raise ValueError(f"{item.name} differs between the muscles that use it: {seen[item.name]} vs {item}")
        return
    if item.body not in inner:
        raise ValueError(f"{item.name} is on body {item.body!r}, not in the modelled chain {D.CHAIN}")
    seen[item.name] = item
    inner[item.body].append(xml)


def task_model_xml() -> str:
    """The tasks' model (`arm.MODEL_FILE`): the locked 1-DOF variant in the tasks' plane, stepping settings, actuators,
    and the scene (the tasks' physics renders by itself: dm_control's `physics.render`, gymnasium's `render()`)."""
    from shoulder_bench.arm import TASK_PLANE_DEG

    return model_xml(locked_plane_deg=TASK_PLANE_DEG, dynamics=True, actuators=True, scene=True)


def full_task_model_xml() -> str:
    """The full shoulder's task model (`full_arm.MODEL_FILE`): 3-DOF, stepping settings (FULL_TIMESTEP,
    FULL_ARMATURE), one actuator per tendon, and the scene."""
    return model_xml(muscles="full", dynamics=True, actuators=True, scene=True, timestep=FULL_TIMESTEP,
                     armature=FULL_ARMATURE)


def write_model(models_dir: Path | None = None) -> list[Path]:
    """Write `shoulder_v2.xml` (the 3-DOF model), `shoulder_v2_task.xml` (the tasks' locked variant),
    `shoulder_full.xml` (the full shoulder's 3-DOF model) and `shoulder_full_task.xml` (its task model) into
    `models_dir` (default: the package's models folder)."""
    from shoulder_bench.model import MODELS_DIR

    out = []
    for name, text in ((FILENAME, model_xml()), (TASK_FILENAME, task_model_xml()),
                       (FULL_FILENAME, model_xml(muscles="full")), (FULL_TASK_FILENAME, full_task_model_xml())):
        path = Path(models_dir or MODELS_DIR) / name
        path.write_text(text)
        out.append(path)
    return out


if __name__ == "__main__":
    from shoulder_bench.authoring import transfer  # the latissimus transfer's variants of both files (issue 13)

    for p in (*write_model(), *transfer.write_models()):
        print(p)
