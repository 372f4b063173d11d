"""Footprint sheets of the full shoulder (issue 12 §2, first step; docs/fem.md "Footprint sheets"): a muscle's free
part as a fibre membrane between two attachment lines, lying on the MJCF's wrap surface by contact, solved in 3-D at
any pose of the 3-DOF model, with the line of action and the torque about each coordinate as outputs of the solve.

Which tendons: those whose free part (the MJCF path from the last humerus site to the next site, on the proximal bone)
is straight or wraps one object, and whose footprint has a source (FOOTPRINT_M): the rotator cuff (ssp over a sphere,
isp over a cylinder, ssc over a sphere, tmi straight), teres major (a sphere), the clavicular pectoralis major
(straight) and the sternal one's two bundles (pec2, pec3: a sphere each; half the sternal head's footprint each, an
assumption), the anterior deltoid (dan, a sphere), the latissimus' three bundles (ld1-3, a cylinder each; a third of its
footprint each, an assumption), and the middle and posterior deltoids (dmi, dpo): their MJCF wraps have the side site
inside the object (MuJoCo's inside wrapping, which no sheet follows), so their sheets drape over the humeral head only
(surface "head"). cor is draped as well but has no footprint source (`width_m` runs it). dan and ld1-3 run on beyond the
free part over a second proximal bone in straight segments (dan: acromion to clavicle; ld: scapula to thorax), whose
length changes with the girdle: the sheet ends at P, and those segments pull on their bones with the sheet's tension, as
MuJoCo's tendon does ("Reduction").

Geometry. The origin line is centred on the proximal site P, the insertion line on the last humerus site Q (or on
INSERTION_M's point: ssc), both along n = (P - c) x (Q - c) at the reference pose (c: the wrap object's centre, or the
joint centre for a straight tendon), each fixed in its bone's frame. Insertion line length: the tendon's insertional
footprint across its fibres (FOOTPRINT_M, with its sources). The origin line has the same length: the free part begins
where the tendon leaves the bone, and no source gives the belly's width there (a stated assumption). A fibre runs from a
point of the origin line to the matching point of the insertion line. Its initial shape at a pose is MuJoCo's wrapped
path (`wrap_geodesic`: straight, or tangent-arc-tangent over the sphere, a helix on the cylinder, on the side of the
wrap's side site); then the solve decides where the sheet lies: the contact with the surface is the solver's penalty
(`solver.MuscleProblem`), not a prescribed path. The contact surface (`surface`) is the MJCF's wrap object (the MoBL
parent's, as the MJCF has them: MuJoCo wraps spheres and cylinders only), or the humeral head (HUMERAL_HEAD, a sphere
fitted to the parent's humerus surface; tmi's and the MJCF's ssc insertion sites lie inside it). The greater tuberosity,
over which the deltoid drapes too, is not a contact surface here (the head sphere only).

Reference (stress-free, fibres at optimal length): the sheet at REFERENCE_POSE_DEG, carried to other poses by a walk
(rest="reference"). The sheet is all fibre (no tendon in series): these solves are about the line of action, which
barely depends on how the force is made. So the fibres lengthen and shorten with the pose as the whole free part
does, where in the muscle the belly and the tendon beyond the free part share that change: at some poses the sheet
goes slack and its line of action means nothing. rest="pose" (the taut band): the sheet stress-free in its draped
shape at the pose it is solved at, every fibre at its optimal length, then activated there: the line of action of
the free part pulled taut, defined at every pose and reached without a walk (one equilibrium per pose, whatever was
solved before), for a force law that takes the force from elsewhere (the length-keyed tables).

Reduction. At equilibrium the sheet pulls on the proximal bone at its origin nodes, on the humerus at its insertion
nodes and pushes the contact surface's body at the nodes in contact; where the path runs on beyond P over a second
proximal bone (`FreePart.beyond`), each straight segment there pulls its two sites towards each other with the sheet's
tension. Each force acts at its point; its generalised force is J_body(x)^T f (MuJoCo's `mj_jac` of the body at that
point), and the coordinates' share is S^T (S the coupling slopes, `full_arm.Pose.slopes`), as for the MuJoCo tendon.
Divided by the tension (the magnitude of the origin's resultant, the pull of a straight first segment), it is the
FEM's moment arm about each coordinate, to be set beside the MJCF tendon's r = -ten_J S (`compare`).
"""
from __future__ import annotations

import mujoco
import numpy as np

from shoulder_bench import full_arm
from shoulder_bench.authoring.fem.footprint_paths import free_part, wrap_geodesic
from shoulder_bench.authoring.fem.material import Blemker, Material
from shoulder_bench.authoring.fem.membrane import membrane_forces
from shoulder_bench.authoring.fem.shells import grid_triangles
from shoulder_bench.authoring.fem.solver import MuscleProblem, NoConvergence, SolverSettings

# Length of each tendon's insertional footprint on the humerus across its fibres, m. Rotator cuff: the maximum
# insertional lengths of Curtis AS, Burbank KM, Tierney JJ, Scheller AD, Curran AR. The insertional footprint of the
# rotator cuff: an anatomic study. Arthroscopy 2006;22(6):609.e1 (20 cadavers; length x width: subscapularis
# 40 x 20, infraspinatus 29 x 19, supraspinatus 23 x 16, teres minor 29 x 21 mm). Teres major: Dancker M, Lambert S,
# Brenner E. Teres major muscle - insertion footprint. J Anat 2017;230(5):631 (28 limbs: 49.6 x 7.4 mm, along the
# crest of the lesser tubercle). Pectoralis major, clavicular head: 56.6 mm of humeral footprint (8 cadavers;
# PMC9502243). Its sternal head: 42.1 mm there, split equally between MoBL's two sternocostal bundles PECM2 and PECM3
# (21.05 mm each, each centred on its own insertion site): no source splits it (Fung et al. 2009, Clin Anat,
# doi:10.1002/ca.20784, find the sternal head in 6-7 segments into one tendon), so the even split is an assumption.
# Deltoid: the widths of the anterior (7.3 mm), middle (4.7 mm) and posterior (7.8 mm) heads' insertions, across the
# humeral shaft, along which their fibres arrive (Rispoli DM, Athwal GS, Sperling JW, Cofield RH. The anatomy of the
# deltoid insertion. J Shoulder Elbow Surg 2009;18(3):386; 10 cadavers; their lengths along the shaft 70, 48.4 and
# 63.4 mm). Latissimus dorsi: its bony attachment in the bicipital groove, 36.5 mm long (craniocaudal, across the
# fibres, as teres major's beside it) and 3.7 mm wide (Dancker et al. 2017, above), split equally between MoBL's three
# bundles LAT1-3 (12.17 mm each, each centred on its own insertion site): no source splits it, an assumption.
FOOTPRINT_M = {"ssp": 0.023, "isp": 0.029, "ssc": 0.040, "tmi": 0.029, "tma": 0.0496, "pec1": 0.0566,
               "pec2": 0.0421 / 2, "pec3": 0.0421 / 2, "dmi": 0.0047, "dpo": 0.0078, "dan": 0.0073,
               "ld1": 0.0365 / 3, "ld2": 0.0365 / 3, "ld3": 0.0365 / 3}
TENDONS = tuple(FOOTPRINT_M)
# Insertion lines centred elsewhere than on the MJCF's last humerus site (humerus frame, m). ssc: the parent's SUBSC
# site lies 2.0 mm inside the head sphere on its articular cap, 22 mm from the parent's own lesser tuberosity, where the
# subscapularis inserts (D'Addesi et al. 2006, Arthroscopy, PMID 16952721; Ide et al. 2008, Arthroscopy, 40 shoulders:
# its footprint's medial edge 3.2-6.5 mm from the cartilage, 16.0 mm wide): its line is centred on the parent's humerus
# surface's most anterior vertex within 35 mm of the head's centre (models/reference/scripts/humeral_cap.py; docs/fem.md
# "ssc on the lesser tuberosity"). The MJCF path keeps the parent's site, the force law its length.
INSERTION_M = {"ssc": (0.025735, 0.003363, 0.003644)}
# The humeral head of the MoBL-ARMS parent's humerus surface (humerus.vtp of osim-rl 3.0.11's MoBL_ARMS_J.osim) as a
# sphere in the humerus frame: `python models/reference/scripts/humeral_head.py <humerus.vtp>` (62 vertices, RMS
# residual 0.89 mm). Cf. the 24 mm mean radius of curvature of Iannotti et al. 1992 (J Bone Joint Surg Am 74:491).
HUMERAL_HEAD = {"centre_m": (0.00042, -0.00053, 0.0019), "radius_m": 0.02432}
SURFACES = ("wrap", "head")  # contact with the MJCF's wrap object, or with the humeral head sphere
# Tendons whose sheet drapes as a flat band: every fibre in the plane parallel to the central fibre's great circle
# (wrapped as on a cylinder about that plane's normal), where each fibre over its own great circle tears the band
# (dpo pulls 1.19 F0 from a drape so torn; dmi's acromial origin and humeral insertion come within 2 deg of antipodal
# about the head's centre at the side in external rotation, where fibres 5 mm apart take great circles far apart;
# docs/fem.md "The deltoids"). Narrow bands only: isp's 29 mm band, sliced flat, finds no equilibrium at some poses.
FLAT_DRAPE = ("dmi", "dpo")
# The sheet's stress-free state: its draped shape at REFERENCE_POSE_DEG, carried to every pose by a walk ("reference":
# the fibres lengthen and shorten with the pose, and go slack), or its draped shape at the pose it is solved at
# ("pose": every fibre at its optimal length at every pose, a taut band whose line of action is defined everywhere)
RESTS = ("reference", "pose")
REFERENCE_POSE_DEG = (30.0, 45.0, 0.0)  # plane, elevation, rotation: mid-range of the tasks' pose space
RESOLUTION = {"full": (31, 9), "coarse": (15, 5)}  # nodes along the fibres, across
ACTIVATION_STEPS = (0.25, 0.5, 0.75, 1.0)  # fractions of the activation, ramped at the reference pose
POSE_STEP_DEG = 10.0  # largest continuation step in any coordinate
SETTINGS = SolverSettings(max_step_activation=0.25, max_iter=60)


class _Problem(MuscleProblem):
    """`MuscleProblem` with its boundary nodes and contact surface (sphere or cylinder) placed by the pose."""

    def nodes_of(self, which: str) -> np.ndarray:
        return self.origin if which == "origin" else self.insertion

    def place(self, origin_xyz, insertion_xyz, centre, radius, axis=None):
        self._origin_xyz, self._insertion_xyz = origin_xyz, insertion_xyz
        self.centre, self.radius, self.axis = np.asarray(centre, float), float(radius), axis

    def predict(self, x: np.ndarray, theta_from: float, theta_to: float) -> np.ndarray:
        y = x.copy()
        y[self.origin], y[self.insertion] = self._origin_xyz, self._insertion_xyz
        return y


class FootprintSheet:
    """One tendon's footprint sheet on the full model: build it at the reference pose, solve it at any pose."""

    problem_class, activation_steps = _Problem, ACTIVATION_STEPS  # (footprint_glenoid's sheets take others)

    def __init__(self, tendon: str, resolution: str | tuple[int, int] = "coarse", width_m: float | None = None,
                 pose: full_arm.Pose | None = None, material: Material | None = None, surface: str = "wrap",
                 rest: str = "reference", flat: bool | None = None, mjcf_insertion: bool = False):
        if tendon not in FOOTPRINT_M and width_m is None:
            raise ValueError(f"no footprint for {tendon!r}; tendons with one: {', '.join(TENDONS)}")
        if surface not in SURFACES:
            raise ValueError(f"unknown contact surface {surface!r}; choose from {', '.join(SURFACES)}")
        if rest not in RESTS:
            raise ValueError(f"unknown stress-free state {rest!r}; choose from {', '.join(RESTS)}")
        self.pose = pose or full_arm.Pose()
        self.m, self.d = self.pose.m, mujoco.MjData(self.pose.m)
        self.part = free_part(self.m, tendon)
        if surface == "wrap" and self.part.inside:
            raise ValueError(f"{tendon}: its wrap's side site lies inside the object (MuJoCo's inside wrapping; not "
                             "draped): its contact surface is the humeral head (surface='head', `fem footprint "
                             "--surface head`)")
        self.surface = surface
        self.flat = tendon in FLAT_DRAPE if flat is None else bool(flat)  # the drape: flat, or fibre by fibre
        self.width = float(FOOTPRINT_M[tendon] if width_m is None else width_m)
        moved = tendon in INSERTION_M and not mjcf_insertion  # mjcf_insertion: the MJCF site's line (checks against it)
        self.insertion = np.asarray(INSERTION_M[tendon]) if moved else None  # its centre in the humerus frame, m
        self.ns, self.nt = RESOLUTION[resolution] if isinstance(resolution, str) else resolution
        self.bodies = {"origin": int(self.m.site_bodyid[self.part.origin_site]),
                       "insertion": int(self.m.site_bodyid[self.part.insertion_site]),
                       "wrap": int(self.m.geom_bodyid[self.part.wrap]) if self.part.wrap is not None else None,
                       "head": int(self.m.body("humerus").id)}
        self._set(REFERENCE_POSE_DEG)
        p, q, c = self._ends()
        if surface == "head":
            radius = HUMERAL_HEAD["radius_m"]
            inside = [k for k, x in (("origin", p), ("insertion", q)) if np.linalg.norm(x - c) < radius]
            if inside:
                raise ValueError(f"{tendon}: its {inside[0]} site lies inside the humeral head sphere; no contact with "
                                 "the head for it")
        n = np.cross(p - c, q - c)
        self.across = {k: self._to_body(k, n / np.linalg.norm(n), vector=True) for k in ("origin", "insertion")}
        self.f0, self.material, self.rest = _f0(tendon), material or Material(), rest
        self._build(self.draped())
        self.reference_length = self.central_length()
        self._at_reference = {}  # activation -> the solution at the reference pose

    def _build(self, X: np.ndarray) -> None:
        """The sheet's problem with its stress-free shape `X` (nodes at the current pose) and its attachment lines
        fixed to their bones where X has them."""
        tri = grid_triangles(self.ns, self.nt)
        st = np.stack(np.meshgrid(np.linspace(0, 1, self.ns), np.linspace(-0.5, 0.5, self.nt), indexing="ij"), -1)
        st = st.reshape(-1, 2)
        ds = np.stack([X[tri[:, 1]] - X[tri[:, 0]], X[tri[:, 2]] - X[tri[:, 0]]], axis=2)
        dst = np.stack([st[tri[:, 1]] - st[tri[:, 0]], st[tri[:, 2]] - st[tri[:, 0]]], axis=2)
        fibres = (ds @ np.linalg.inv(dst))[:, :, 0]
        fibres /= np.linalg.norm(fibres, axis=1, keepdims=True)
        idx = np.arange(self.ns * self.nt).reshape(self.ns, self.nt)
        shell = {"muscle": np.array(self.part.tendon), "nodes": X, "triangles": tri, "fibres": fibres,
                 "thickness": self.f0 / Blemker().sigma_max / self.width, "origin_nodes": idx[0],
                 "insertion_nodes": idx[-1], "theta_ref_deg": np.array(0.0)}
        self.problem = self.problem_class(shell, self.material, SETTINGS, self.f0)
        self.reference = {k: (self._frame(k), X[self.problem.nodes_of(k)]) for k in ("origin", "insertion")}

    # -- kinematics -------------------------------------------------------------------------------------------------
    def _set(self, pose_deg):
        self.d.qpos[:] = self.pose.qpos(pose_deg)[0]
        mujoco.mj_kinematics(self.m, self.d)
        mujoco.mj_comPos(self.m, self.d)
        self.pose_deg = np.asarray(pose_deg, float)

    def _frame(self, which: str):
        b = self.bodies[which]
        return self.d.xpos[b].copy(), self.d.xmat[b].reshape(3, 3).copy()

    def _to_body(self, which, v, vector=False):
        pos, rot = self._frame(which)
        return rot.T @ (v if vector else v - pos)

    def _contact_surface(self):
        """(centre, radius, axis or None, side point or None, body key) of the contact surface here, or None."""
        if self.surface == "head":
            pos, rot = self._frame("head")
            return pos + rot @ np.asarray(HUMERAL_HEAD["centre_m"]), HUMERAL_HEAD["radius_m"], None, None, "head"
        w = self.part.wrap
        if w is None:
            return None
        axis = self.d.geom_xmat[w].reshape(3, 3)[:, 2].copy() if self.m.geom_type[w] == mujoco.mjtGeom.mjGEOM_CYLINDER \
            else None
        side = None if self.part.sidesite is None else self.d.site_xpos[self.part.sidesite].copy()
        return self.d.geom_xpos[w].copy(), float(self.m.geom_size[w, 0]), axis, side, "wrap"

    def _ends(self):
        p = self.d.site_xpos[self.part.origin_site].copy()
        if self.insertion is None:
            q = self.d.site_xpos[self.part.insertion_site].copy()
        else:
            pos, rot = self._frame("insertion")
            q = pos + rot @ self.insertion
        surface = self._contact_surface()
        c = surface[0] if surface is not None else self.d.xanchor[self.m.joint("shoulder_elv").id].copy()
        return p, q, c

    def _fibre(self, p, q, n: int, normal=None) -> tuple[np.ndarray, float]:
        """A fibre's initial shape from p to q: over the contact surface as MuJoCo wraps (`wrap_geodesic`; over a
        sphere in the plane through its centre normal to `normal` if given, as on a cylinder), or straight."""
        surface = self._contact_surface()
        if surface is None:
            return p + np.linspace(0, 1, n)[:, None] * (q - p), float(np.linalg.norm(q - p))
        c, radius, axis, side, _ = surface
        return wrap_geodesic(p, q, c, radius, n, normal if axis is None and normal is not None else axis, side)

    def draped(self) -> np.ndarray:
        """(ns nt, 3) the sheet's initial shape at the current pose: each fibre wrapped as MuJoCo wraps a tendon
        over the contact surface (`_fibre`), from its origin-line point to its insertion-line point; for FLAT_DRAPE
        tendons (or `flat`) in planes parallel to the central fibre's."""
        p, q, c = self._ends()
        n = np.cross(p - c, q - c) if self.flat else None
        normal = None if n is None or np.linalg.norm(n) < 1e-12 else n / np.linalg.norm(n)
        out = np.empty((self.ns, self.nt, 3))
        for j, t in enumerate(np.linspace(-0.5, 0.5, self.nt)):
            pj = p + t * self.width * self._frame("origin")[1] @ self.across["origin"]
            qj = q + t * self.width * self._frame("insertion")[1] @ self.across["insertion"]
            out[:, j] = self._fibre(pj, qj, self.ns, normal)[0]
        return out.reshape(-1, 3)

    def central_length(self) -> float:
        """The length of the central fibre's initial shape at the current pose (m): with surface="wrap", MuJoCo's
        free length."""
        p, q, _ = self._ends()
        return self._fibre(p, q, 2)[1]

    def beyond_length(self) -> float:
        """The length of the path beyond P over a second proximal bone at the current pose (m; 0 where it has none)."""
        x = self.d.site_xpos[list(self.part.beyond)]
        return float(np.linalg.norm(np.diff(x, axis=0), axis=1).sum())

    def boundary(self) -> dict:
        """The origin and insertion nodes at the current pose: the reference ones carried by their bones."""
        out = {}
        for k, ((pos0, rot0), x0) in self.reference.items():
            pos, rot = self._frame(k)
            out[k] = (x0 - pos0) @ rot0 @ rot.T + pos
        return out

    # -- solve and reduce ---------------------------------------------------------------------------------------------
    def solve(self, pose_deg, activation: float = 1.0) -> dict:
        """Equilibrium at `pose_deg` (plane, elevation, rotation) and `activation`; returns the nodes, the tension
        (N), the generalised force about the three coordinates (N m), the FEM moment arms (m), the contact force on
        the contact surface (N) and the central fibre's stretch.

        Continuation: the activation is ramped to `activation` at the reference pose; then the pose moves from there
        in steps of at most POSE_STEP_DEG per coordinate (halved where Newton fails), each predicted by the change of
        the draped shape."""
        if self.rest == "pose":
            return self._solve_taut(pose_deg, activation)
        pb = self.problem
        target = np.asarray(pose_deg, float)
        start = np.asarray(REFERENCE_POSE_DEG, float)
        if activation not in self._at_reference:
            self._place(start)
            self._at_reference[activation] = self._activate(pb.predict(self.draped(), 0.0, 0.0), activation)
        return self.reduce(self._walk(self._at_reference[activation], start, target, activation), activation)

    def _solve_taut(self, pose_deg, activation: float) -> dict:
        """`solve` with rest="pose": the sheet built stress-free in its draped shape at `pose_deg`, the activation
        ramped there (ACTIVATION_STEPS): no walk, so the equilibrium found depends on the pose alone."""
        self._set(pose_deg)
        self._build(self.draped())
        self._place(pose_deg)
        return self.reduce(self._activate(self.problem.predict(self.problem.X, 0.0, 0.0), activation), activation)

    def solve_from(self, pose_deg, start: np.ndarray, activation: float = 1.0) -> dict:
        """rest="pose": the sheet built stress-free at `pose_deg`, as `solve` builds it, but Newton started from the
        free nodes of `start` (e.g. a neighbouring pose's equilibrium) instead of the ramp from rest; `solve`'s
        result plus its potential energy ("energy_J"). NoConvergence where Newton fails."""
        if self.rest != "pose":
            raise ValueError('solve_from builds the sheet at the pose: rest="pose" only')
        self._set(pose_deg)
        self._build(self.draped())
        self._place(pose_deg)
        x, _ = self.problem.newton(self.problem.predict(start, 0.0, 0.0), activation)
        return dict(self.reduce(x, activation), energy_J=self.problem.energy(x, activation))

    def solve_least_energy(self, pose_deg, offsets_deg, activation: float = 1.0, ramp: bool = True) -> dict:
        """rest="pose": the least-energy of the ramp's equilibrium at `pose_deg` (unless not `ramp`) and those Newton
        reaches there from the ramp's at `pose_deg` + each of `offsets_deg` (K, 3) (`solve_from`; the sheet built at
        the pose each time), at `activation`: `solve_from`'s result. NoConvergence where none converges."""
        p, best = np.asarray(pose_deg, float), None
        for start in p + np.vstack([np.zeros((int(ramp), 3)), offsets_deg]):
            try:
                sol = self.solve_from(p, self.solve(start, activation)["nodes"], activation)
            except NoConvergence:
                continue
            if best is None or sol["energy_J"] < best["energy_J"]:
                best = sol
        if best is None:
            raise NoConvergence(f"no equilibrium at {p.tolist()} deg from any of {len(offsets_deg) + ramp} starts")
        return best

    def _activate(self, x: np.ndarray, activation: float) -> np.ndarray:
        """The relaxed sheet `x` (at the placed pose) activated to `activation` in `activation_steps`."""
        a0 = 0.0
        for a in [s * activation for s in self.activation_steps]:
            x, _ = self.problem.step(x, (0.0, a0), (0.0, a))
            a0 = a
        return x

    def solve_path(self, poses_deg, activation: float = 1.0) -> list[dict | None]:
        """`solve` at each of `poses_deg` in turn, each continued from the one before (the first from the reference
        pose) instead of from the reference: along a grid line a step of one grid cell instead of a walk across the
        pose space. Where that finds no equilibrium the pose is solved from the reference; None where neither does.
        Equilibria can depend on the way (contact): `benchmarks/footprint_sweep.py` compares the two. With
        rest="pose" there is no way: each pose is solved on its own, as `solve` does."""
        out, x, at = [], None, None
        for pose in np.asarray(poses_deg, float):
            res = None
            if x is not None and self.rest == "reference":  # continued from the pose before
                try:
                    res = self.reduce(self._walk(x, at, pose, activation), activation)
                except NoConvergence:
                    pass
            if res is None:  # the first pose, or no way from the one before: from the reference
                try:
                    res = self.solve(pose, activation)
                except NoConvergence:
                    pass
            out.append(res)
            x, at = (None, None) if res is None else (res["nodes"], pose)
        return out

    def _walk(self, x: np.ndarray, start, target, activation: float) -> np.ndarray:
        """The nodes continued from equilibrium `x` at pose `start` to pose `target` in steps of at most
        POSE_STEP_DEG per coordinate (halved where Newton fails), each predicted by the change of the draped shape."""
        pb, start, target = self.problem, np.asarray(start, float), np.asarray(target, float)
        at = start
        n = max(1, int(np.ceil(np.max(np.abs(target - start)) / POSE_STEP_DEG - 1e-9)))
        frac, done = 1.0 / n, 0.0
        while done < 1.0 - 1e-12:
            f = min(frac, 1.0 - done)
            nxt = start + (done + f) * (target - start)
            self._place(at)
            before = self.draped()
            self._place(nxt)
            try:
                x_new, _ = pb.newton(pb.predict(x + self.draped() - before, 0.0, 0.0), activation)
            except NoConvergence:
                frac = f / 2.0
                if frac < SETTINGS.min_step_fraction / n:
                    raise NoConvergence(f"{self.part.tendon} at pose {tuple(target)}: no equilibrium on the way "
                                        f"from {tuple(at)}") from None
                continue
            x, at, done = x_new, nxt, done + f
        return x

    def _place(self, pose_deg):
        self._set(pose_deg)
        b = self.boundary()
        surface = self._contact_surface()
        centre, radius, axis = surface[:3] if surface is not None else (np.zeros(3), 0.0, None)
        self.problem.place(b["origin"], b["insertion"], centre, radius, axis)

    def reduce(self, x: np.ndarray, activation: float) -> dict:
        """The solved sheet `x`'s forces on the bones, as the module docstring's "Reduction" says."""
        pb = self.problem
        g = membrane_forces(pb.mem, pb.kernel, x, activation) + (pb.reg_matrix @ (x - pb.X).ravel()).reshape(-1, 3)
        gc = pb._contact(x)[1].reshape(-1, 3)
        q_nv, jacp = np.zeros(self.m.nv), np.zeros((3, self.m.nv))
        loads = [("origin", i, -g[i]) for i in pb.nodes_of("origin")]
        loads += [("insertion", i, -g[i]) for i in pb.nodes_of("insertion")] + self._contact_loads(x, gc)
        tension = float(np.linalg.norm(-g[pb.nodes_of("origin")].sum(0)))
        points = [(x[i], self.bodies[which], f) for which, i, f in loads]
        for a, b in zip(self.part.beyond, self.part.beyond[1:]):  # beyond P: each segment pulls its ends together
            u = self.d.site_xpos[b] - self.d.site_xpos[a]
            u *= tension / np.linalg.norm(u)
            points += [(self.d.site_xpos[s], self.m.site_bodyid[s], f) for s, f in ((a, u), (b, -u))]
        for point, body, f in points:
            mujoco.mj_jac(self.m, self.d, jacp, None, point, int(body))
            q_nv += jacp.T @ f
        q3 = self.pose.slopes(self.pose_deg).T @ q_nv
        return {"nodes": x, "tension_N": tension, "torque_Nm": q3, "moment_arm_m": q3 / tension,
                "contact_N": float(np.linalg.norm(gc[pb.free].sum(0))), "pose_deg": self.pose_deg.copy(),
                "activation": activation, "stretch": self.central_length() / self.reference_length}

    def _contact_loads(self, x: np.ndarray, gc: np.ndarray) -> list:
        """The free nodes push the contact surface's body where they touch it (gc: the contact gradient, (N, 3))."""
        surface = self._contact_surface()
        return [] if surface is None else [(surface[4], i, gc[i]) for i in self.problem.free if np.any(gc[i] != 0.0)]

    def mjcf_moment_arm(self, pose_deg) -> np.ndarray:
        """(3,) the MJCF tendon's moment arms about plane, elevation, rotation at `pose_deg` (m)."""
        return self.pose.tendon_geometry(pose_deg, (self.part.tendon,))[1][0, 0]


def _f0(tendon: str) -> float:
    """The tendon's maximum isometric force (the MoBL parent's F0, as the length-driven sheets), N."""
    from shoulder_bench.authoring import mobl_data, tendons

    return float(tendons.load_parent()[mobl_data.FULL_MUSCLES[tendon]].f0)
