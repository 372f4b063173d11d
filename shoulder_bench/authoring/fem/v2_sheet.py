"""The v2 muscle sheet: a flat pennated fibre membrane between two aponeuroses, in series with a rigid tendon.

Geometry (from the MoBL-ARMS parent's l_opt, alpha0, F0; `SheetSpec`): a rectangle in the x-y plane, x along the
line of action. The origin aponeurosis is the edge x = 0, the insertion aponeurosis (which carries the tendon) the
edge x = L0 with L0 = l_opt cos(alpha0), so a fibre that crosses from one aponeurosis to the other at the pennation
angle alpha0 is l_opt long: the reference configuration is stress-free with those fibres at optimal length, as
constant-width Hill at lam = 1. Width W = WIDTH_OVER_LENGTH x L0 (a placeholder footprint: the next issue takes W
from the real attachment footprints), thickness h = PCSA / (W cos alpha0), PCSA = F0 / sigma_max, so that the fibres
crossing a section x = const have the muscle's PCSA and the sheet at uniform lam = 1, a = 1 pulls the tendon with
F0 cos alpha0.

Boundary conditions: the origin edge is fixed; the insertion edge is a rigid aponeurosis held on the line of action
(lateral position fixed) and moved along x so that the sheet's axial extent is L_MT(q) - l_ts, the musculotendon
length less the rigid tendon. The lateral edges are free. Out of plane the sheet is held flat (z = 0): in-plane
loading leaves z undetermined on a membrane, and the sheet has nothing to wrap over.

Where the FEM differs from constant-width Hill: the free lateral edges (fibres near them end on a free edge, and
the sheet narrows), the background's own stiffness (passive force on top of Blemker's f_passive) and tension-field
wrinkling. In the interior of a wide sheet the deformation is F = diag(s, 1), exactly Hill's constant-width
kinematics, so a wide sheet tends to Hill plus the background.

The solve reuses `solver.MuscleProblem` (energy, Newton, line search, substep halving); only the boundary
conditions, the predictor and the reduction are this sheet's. Its continuation parameter (MuscleProblem's "theta")
is the axial strain in % of L0, so `SolverSettings.max_step_deg` is read as a step in % strain here.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from shoulder_bench.authoring.fem.material import Blemker, Material
from shoulder_bench.authoring.fem.membrane import membrane_forces, membrane_kinematics
from shoulder_bench.authoring.fem.shells import grid_triangles
from shoulder_bench.authoring.fem.solver import MuscleProblem, NoConvergence, SolverSettings

WIDTH_OVER_LENGTH = 1.0  # W / L0: a square sheet until the real footprints (next issue) give W
RESOLUTION = {"full": (33, 33), "coarse": (9, 9)}  # nodes along the axis, across


@dataclass(frozen=True)
class SheetSpec:
    """One v2 muscle's sheet, all in SI units (from the parent's CSV; `from_parent`)."""

    muscle: str
    f0: float  # N
    l_opt: float  # m
    l_ts: float  # m
    alpha0: float  # rad
    width_over_length: float = WIDTH_OVER_LENGTH

    @classmethod
    def from_parent(cls, muscle: str, p) -> SheetSpec:
        return cls(muscle, float(p.f0), float(p.l_opt), float(p.l_ts), float(p.alpha0))

    @property
    def rest_extent(self) -> float:
        """L0 = l_opt cos alpha0, the axial extent of the stress-free sheet."""
        return self.l_opt * float(np.cos(self.alpha0))

    @property
    def width(self) -> float:
        return self.width_over_length * self.rest_extent

    def thickness(self, sigma_max: float) -> float:
        return self.f0 / sigma_max / (self.width * float(np.cos(self.alpha0)))

    def as_dict(self) -> dict:
        return asdict(self)


def build_sheet(spec: SheetSpec, resolution: str | tuple[int, int] = "full", fibre: Blemker | None = None) -> dict:
    """The sheet as arrays, in MuscleProblem's shell format (nodes, triangles, fibres, thickness, edges)."""
    nx, ny = RESOLUTION[resolution] if isinstance(resolution, str) else resolution
    fibre = fibre or Blemker()
    x, y = np.linspace(0.0, spec.rest_extent, nx), np.linspace(-0.5 * spec.width, 0.5 * spec.width, ny)
    nodes = np.stack([*np.meshgrid(x, y, indexing="ij"), np.zeros((nx, ny))], axis=-1).reshape(-1, 3)
    tri = grid_triangles(nx, ny)
    fib = np.tile([np.cos(spec.alpha0), np.sin(spec.alpha0), 0.0], (len(tri), 1))
    idx = np.arange(nx * ny).reshape(nx, ny)
    return {"muscle": np.array(spec.muscle), "nodes": nodes, "triangles": tri.astype(np.int64), "fibres": fib,
            "thickness": np.full(len(tri), spec.thickness(fibre.sigma_max)),
            "origin_nodes": idx[0].astype(np.int64), "insertion_nodes": idx[-1].astype(np.int64),
            "theta_ref_deg": np.array(0.0), "resolution": np.array([nx, ny], dtype=np.int64)}


class SheetProblem(MuscleProblem):
    """MuscleProblem with the v2 boundary conditions; "theta" is the axial strain of the sheet in % of L0."""

    def __init__(self, spec: SheetSpec, resolution="full", material: Material | None = None,
                 settings: SolverSettings | None = None):
        material = material or Material()
        self.spec = spec
        super().__init__(build_sheet(spec, resolution, material.fibre), material, settings, f0=spec.f0)
        self.radius = 0.0  # no bone to contact: the penalty is identically zero
        self.free_dofs = (3 * self.free[:, None] + np.arange(2)).ravel()  # in-plane only, z stays 0
        self.l0 = spec.rest_extent

    def strain_pct(self, extent: float) -> float:
        return 100.0 * (extent / self.l0 - 1.0)

    def insertion_positions(self, strain_pct: float) -> np.ndarray:
        return self.X[self.insertion] + np.array([self.l0 * strain_pct / 100.0, 0.0, 0.0])

    def predict(self, x: np.ndarray, e_from: float, e_to: float) -> np.ndarray:
        """Move each node along x by its harmonic weight (0 at the origin, 1 at the insertion) times the change."""
        y = x.copy()
        y[:, 0] += self.weight * self.l0 * (e_to - e_from) / 100.0
        y[self.origin] = self.X[self.origin]
        y[self.insertion] = self.insertion_positions(e_to)
        return y

    def reaction(self, x: np.ndarray, activation: float) -> tuple[float, float]:
        """(tendon force: the axial force holding the insertion edge, N, > 0 pulls; lateral force on it, N)."""
        u = (x - self.X).ravel()
        g = (membrane_forces(self.mem, self.kernel, x, activation).ravel() + self.reg_matrix @ u).reshape(-1, 3)
        f = g[self.insertion].sum(0)
        return float(f[0]), float(f[1])

    def fibre_stretch(self, x: np.ndarray) -> tuple[float, float, float]:
        """(min, area-weighted mean, max) of the element fibre stretch sqrt(C11)."""
        lam = np.sqrt(membrane_kinematics(self.mem, x)[3][:, 0])
        return float(lam.min()), float(np.sum(lam * self.mem.area) / self.mem.area.sum()), float(lam.max())

    def sweep_extents(self, extents: np.ndarray, activation: float, callback=None, neighbour=None) -> dict:
        """Solve at every axial extent (m) for one activation by continuation: activation ramped at the stress-free
        reference, then walked through `extents` in order from the one nearest L0, up and down. Where that path
        fails it restarts from `neighbour` = solutions of another activation at the same extents. Returns arrays
        force_N, lateral_N, newton_iterations, stretch (K, 3) and the solutions x (K, N, 3)."""
        e = np.array([self.strain_pct(v) for v in extents])
        k = len(e)
        out = {"force_N": np.zeros(k), "lateral_N": np.zeros(k), "newton_iterations": np.zeros(k, int),
               "stretch": np.zeros((k, 3)), "x": np.zeros((k, self.mem.n_nodes, 3))}
        x0, its0 = self.step(self.X.copy(), (0.0, 0.0), (0.0, activation))
        start = int(np.argmin(np.abs(e)))
        for n, order in enumerate((np.arange(start, k), np.arange(start - 1, -1, -1))):
            x, prev, extra = x0, 0.0, its0 if n == 0 else 0  # the ramp's iterations count once
            for i in order:
                try:
                    x, its = self.step(x, (prev, activation), (e[i], activation))
                except NoConvergence:
                    if neighbour is None:
                        raise
                    a_n, x_n = neighbour
                    x, its = self.step(x_n[i], (e[i], a_n), (e[i], activation))
                prev = e[i]
                out["force_N"][i], out["lateral_N"][i] = self.reaction(x, activation)
                out["newton_iterations"][i], out["stretch"][i], out["x"][i] = its + extra, self.fibre_stretch(x), x
                extra = 0
                if callback is not None:
                    callback()
        return out
