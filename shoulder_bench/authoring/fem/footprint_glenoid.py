"""The glenoid as a contact for the footprint sheets on the humeral head (docs/fem.md "Where isp's and ssc's bands
roll"): a study option, `GlenoidSheet`; no table uses it.

Where isp's and ssc's taut bands roll over the head sphere between grid poses, their contact with the head has slid
into the glenoid's place on it (`benchmarks/band_glenoid.py`): the space between the two articular surfaces, which
the head sphere alone leaves open. Here that space is closed. Geometry (placed from published data, not fitted):

* the glenoid's centre on the head: on the line from the head's centre towards the trigonum spinae, the line glenoid
  version is measured against (Friedman et al. 1992, J Bone Joint Surg Am 74:1032; by it the glenoid face lies within
  a few degrees of normal to that line), the trigonum spinae stood in for by the most medial vertex of the MoBL-ARMS
  parent's scapula surface (MEDIAL_VERTEX_M; a proxy, the mesh labels no landmark; benchmarks/band_glenoid.py has the
  references and recomputes it);
* its outline: a circle on the head at HALF_ARC_DEG from that centre, the mean of the half-arcs of a glenoid 39 mm high
  and 29 mm wide (Iannotti et al. 1992, J Bone Joint Surg Am 74:491) on the head sphere (53 and 37 deg): the
  ellipse's orientation on the head is not known here, so a circle;
* its depth: the space within SOCKET_M of the head's surface inside the outline is the glenoid-labral socket's
  (5 mm deep across the glenoid with the labrum: Howell SM, Galinat BJ. The glenoid-labral socket. Clin Orthop Relat
  Res 1989;243:122).

The contact: a penalty on the sheet's nodes inside that space, in the arc length by which a node lies inside the
outline (its angle from the outline times the head's radius / sin(HALF_ARC_DEG)), with the head contact's C2 ramp
(SMOOTHING_M, a numerical choice: the head's 1e-5 m left Newton stalling at the outline's edge) and stiffness,
faded out across the socket's depth by a smoothstep; exact gradient and Hessian (tested against differences). It
pushes the nodes along the head away from the glenoid's centre, and its reaction acts on the scapula. The drape: the
nodes of MuJoCo's wrap (`FootprintSheet.draped`) that start inside the space are moved to the outline at their
distance from the head's centre, on the side of the glenoid the MJCF wrap's side site is on (no side site: their own
side), so that the sheet starts outside the obstacle it cannot be pushed through.
"""
from __future__ import annotations

import numba
import numpy as np

from shoulder_bench.authoring.fem.footprint import HUMERAL_HEAD, FootprintSheet
from shoulder_bench.authoring.fem.solver import MuscleProblem

MEDIAL_VERTEX_M = (-0.095237, -0.056267, -0.105782)  # scapula.vtp's most medial vertex (least z), scapula frame
GLENOID_MM = (39.0, 29.0)  # height, width (Iannotti et al. 1992)
HALF_ARCS_DEG = tuple(float(np.degrees(np.arcsin(s / 2e3 / HUMERAL_HEAD["radius_m"]))) for s in GLENOID_MM)
HALF_ARC_DEG = float(np.mean(HALF_ARCS_DEG))  # the contact's circle: the mean of the height's and width's half-arcs
SOCKET_M = 0.005
SMOOTHING_M = 0.002
ACTIVATION_STEPS = tuple(np.arange(1, 9) / 8.0)  # the ramp in eighths (in quarters, as footprint's, Newton stalls)


def glenoid_axis(m, medial=MEDIAL_VERTEX_M) -> np.ndarray:
    """The unit axis from the glenohumeral joint centre of model `m` towards `medial` (the trigonum spinae's stand-in),
    scapula frame."""
    axis = np.asarray(medial, dtype=float) - m.body("scapphant").pos  # the joint centre in the scapula frame
    return axis / np.linalg.norm(axis)


@numba.njit(cache=True, error_model="numpy")
def cap_pass(x, centre, axis, cos_t, scale, radius, depth, k, dl, g, blocks):
    """The glenoid penalty node by node: its energy (returned), gradient into g (3N,) and, where `blocks` has N rows,
    each node's Hessian block. s = scale (n.axis - cos_t) (n the node's direction from `centre`), faded by a
    smoothstep w(r) from 1 at the head's `radius` to 0 at radius + depth."""
    energy = 0.0
    for i in range(len(x)):
        u = x[i] - centre
        r = np.sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2])
        n = u / max(r, 1e-12)
        na = n[0] * axis[0] + n[1] * axis[1] + n[2] * axis[2]
        s = scale * (na - cos_t)
        t = min(max((r - radius) / depth, 0.0), 1.0)
        if s <= 0.0 or t >= 1.0:
            for a in range(3):
                g[3 * i + a] = 0.0
            if blocks.shape[0] > 0:
                blocks[i] = 0.0
            continue
        if s < dl:
            h, h1, h2 = k[i] * s**3 / (6 * dl), k[i] * s**2 / (2 * dl), k[i] * s / dl
        else:
            h = k[i] * (dl**2 / 6 + dl * (s - dl) / 2 + (s - dl) ** 2 / 2)
            h1, h2 = k[i] * (dl / 2 + s - dl), k[i]
        w = 1.0 - (3 * t**2 - 2 * t**3)
        inner = 0.0 < t < 1.0
        w1 = -(6 * t - 6 * t**2) / depth if inner else 0.0
        w2 = -(6 - 12 * t) / depth**2 if inner else 0.0
        energy += h * w
        gs = scale * (axis - na * n) / r  # ds/dx
        for a in range(3):
            g[3 * i + a] = h1 * w * gs[a] + h * w1 * n[a]
        if blocks.shape[0] > 0:
            for a in range(3):
                for b in range(3):
                    eye = 1.0 if a == b else 0.0
                    d2r = (eye - n[a] * n[b]) / r
                    d2s = scale * (-axis[a] * n[b] - n[a] * axis[b] - na * (eye - 3 * n[a] * n[b])) / r**2
                    blocks[i, a, b] = (h2 * w * gs[a] * gs[b] + h1 * w1 * (gs[a] * n[b] + n[a] * gs[b])
                                       + h1 * w * d2s + h * w2 * n[a] * n[b] + h * w1 * d2r)
    return energy


class _GlenoidProblem(FootprintSheet.problem_class):
    """The footprint sheets' problem with the glenoid's contact beside the head's (`place_glenoid`: where the pose
    puts it)."""

    glenoid = None  # (head centre, unit axis towards the glenoid), world

    def place_glenoid(self, centre, axis):
        self.glenoid = (np.asarray(centre, float), np.asarray(axis, float))

    def glenoid_contact(self, x: np.ndarray, blocks: bool = True):
        n = len(x)
        g, node_blocks = np.zeros(3 * n), np.zeros((n if blocks else 0, 3, 3))
        half = np.radians(HALF_ARC_DEG)
        e = cap_pass(np.ascontiguousarray(x, float), self.glenoid[0], self.glenoid[1], float(np.cos(half)),
                     float(HUMERAL_HEAD["radius_m"] / np.sin(half)), float(HUMERAL_HEAD["radius_m"]), SOCKET_M,
                     self.settings.contact_stiffness * self.node_area, SMOOTHING_M, g, node_blocks)
        return e, g, node_blocks if blocks else None

    def _contact(self, x: np.ndarray, blocks: bool = True):
        e, g, b = MuscleProblem._contact(self, x, blocks)
        if self.glenoid is None:
            return e, g, b
        e2, g2, b2 = self.glenoid_contact(x, blocks)
        return e + e2, g + g2, (b + b2) if blocks else None


class GlenoidSheet(FootprintSheet):
    """A footprint sheet on the humeral head (surface="head") with the glenoid as a second contact."""

    problem_class, activation_steps = _GlenoidProblem, ACTIVATION_STEPS

    def __init__(self, tendon: str, *args, **kwargs):
        if kwargs.get("surface", "wrap") != "head":
            raise ValueError('the glenoid is a contact beside the humeral head: surface="head" only')
        super().__init__(tendon, *args, **kwargs)
        self.bodies["scapula"] = int(self.m.body("scapula").id)

    def glenoid(self) -> tuple[np.ndarray, np.ndarray]:
        """(the head's centre, the unit axis from it towards the glenoid's centre), world, at the current pose."""
        rot = self.d.xmat[self.m.body("scapula").id].reshape(3, 3)
        return self._contact_surface()[0], rot @ glenoid_axis(self.m)

    def _place(self, pose_deg):
        super()._place(pose_deg)
        self.problem.place_glenoid(*self.glenoid())

    def draped(self) -> np.ndarray:
        """MuJoCo's wrap, fibre by fibre, its nodes inside the socket moved to the outline (module docstring)."""
        x = super().draped()
        centre, axis = self.glenoid()
        side = None
        if self.part.sidesite is not None:
            side = self.d.site_xpos[self.part.sidesite] - centre
            side = side - (side @ axis) * axis
            side /= np.linalg.norm(side)
        half, radius = np.radians(HALF_ARC_DEG), HUMERAL_HEAD["radius_m"]
        for i, v in enumerate(x - centre):
            r = np.linalg.norm(v)
            u = v / r
            if r >= radius + SOCKET_M or u @ axis <= np.cos(half):
                continue
            across = u - (u @ axis) * axis
            if side is not None and across @ side < 0.0:
                across -= 2.0 * (across @ side) * side
            if np.linalg.norm(across) < 1e-12:
                across = side if side is not None else np.cross(axis, [1.0, 0.0, 0.0])
            across /= np.linalg.norm(across)
            x[i] = centre + r * (np.cos(half) * axis + np.sin(half) * across)
        return x

    def _contact_loads(self, x: np.ndarray, gc: np.ndarray) -> list:
        """The head's contact pushes the humerus, the glenoid's the scapula."""
        head, socket = self._contact_parts(x)
        loads = super()._contact_loads(x, head)
        return loads + [("scapula", i, socket[i]) for i in self.problem.free if np.any(socket[i] != 0.0)]

    def _contact_parts(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The contact gradients (N, 3) of the head and of the glenoid at the nodes `x`."""
        head = MuscleProblem._contact(self.problem, x, blocks=False)[1].reshape(-1, 3)
        return head, self.problem.glenoid_contact(x, blocks=False)[1].reshape(-1, 3)

    def reduce(self, x: np.ndarray, activation: float) -> dict:
        """`FootprintSheet.reduce`, with contact_N the head's contact force alone and glenoid_N the glenoid's (N)."""
        out = super().reduce(x, activation)
        head, socket = (part[self.problem.free].sum(0) for part in self._contact_parts(x))
        out["contact_N"], out["glenoid_N"] = float(np.linalg.norm(head)), float(np.linalg.norm(socket))
        return out
