"""Quasi-static equilibrium of one muscle sheet: Newton with line search, load stepping, contact, regularisation.

Unknowns are the free node positions; origin nodes stay at their reference positions and insertion nodes are carried
rigidly by the humerus, x = R_x(theta - theta_ref) X. The total energy is

    E(x) = sum_e E_e(x)                                   membrane (fibres + co-rotational background)
         + 1/2 kappa sum_i A_i max(0, R - |x_i - c|)^2    penalty contact with the humeral head sphere (c, R)
                                                   (or a cylinder: the distance from its axis)
         + 1/2 k_reg sum_(interior i) |(L (x - X))_i|^2   small out-of-plane regularisation (umbrella Laplacian)

and equilibrium is grad E = 0 on the free dofs. Newton steps solve H p = -g (`assembly`); a singular tangent gets a
small Levenberg shift; a backtracking line search on the residual norm guards the step. A step in (theta, a) that
Newton cannot finish is halved (load stepping) until it can. The membrane's element pass and the contact penalty are
compiled loops (numba; `membrane`, `_contact_pass`)."""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numba
import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from shoulder_bench.authoring import anatomy
from shoulder_bench.authoring.fem.assembly import Assembly, FreeMatrix
from shoulder_bench.authoring.fem.material import Material
from shoulder_bench.authoring.fem.membrane import (
    ElementKernel,
    Membrane,
    element_dofs,
    membrane_blocks,
    membrane_energy,
    membrane_forces,
    membrane_forces_energy,
)


@dataclass(frozen=True)
class SolverSettings:
    tol: float = 1e-4  # converged when the largest free-node force residual < tol * F0 (N)
    max_iter: int = 30
    contact_stiffness: float = 1e11  # kappa, Pa/m: contact pressure per metre of penetration
    contact_smoothing: float = 1e-5  # delta, m: penetration over which the penalty stiffness ramps up
    regularisation: float = 0.1  # k_reg = this * E * mean thickness (N/m per node)
    max_step_deg: float = 5.0  # continuation step in angle
    max_step_activation: float = 0.25  # continuation step in activation
    min_step_fraction: float = 1.0 / 64.0
    stall_factor: float = 10.0  # a stalled line search is accepted when the residual is below this * tol
    iteration_stall: bool = False  # a study option: also accept Newton's last iterate below stall_factor * tol

    def as_dict(self) -> dict:
        d = asdict(self)
        if not d["iteration_stall"]:  # only where chosen: the tables built without it keep their input hashes
            del d["iteration_stall"]
        return d


class NoConvergence(RuntimeError):
    pass


def rotation_x(theta_rad: float) -> np.ndarray:
    c, s = np.cos(theta_rad), np.sin(theta_rad)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _boundary_nodes(triangles: np.ndarray) -> np.ndarray:
    e = np.sort(np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]]), axis=1)
    uniq, count = np.unique(e, axis=0, return_counts=True)
    return np.unique(uniq[count == 1])


def _umbrella(triangles: np.ndarray, n: int) -> sp.csr_matrix:
    """Rows x_i - mean(neighbours of i) for interior nodes (zero for any linear field on a regular grid)."""
    e = np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]])
    adj = sp.coo_matrix((np.ones(len(e)), (e[:, 0], e[:, 1])), shape=(n, n))
    adj = ((adj + adj.T) > 0).astype(float).tocsr()
    deg = np.asarray(adj.sum(1)).ravel()
    lap = sp.identity(n) - sp.diags(1.0 / deg) @ adj
    interior = np.setdiff1d(np.arange(n), _boundary_nodes(triangles))
    return lap.tocsr()[interior]


def _harmonic_weight(triangles, n, origin, insertion) -> np.ndarray:
    """0 at the origin nodes, 1 at the insertion nodes, graph-harmonic in between (used by the predictor)."""
    e = np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]])
    adj = sp.coo_matrix((np.ones(len(e)), (e[:, 0], e[:, 1])), shape=(n, n))
    adj = ((adj + adj.T) > 0).astype(float).tocsr()
    lap = (sp.diags(np.asarray(adj.sum(1)).ravel()) - adj).tocsr()
    w = np.zeros(n)
    w[insertion] = 1.0
    fixed = np.union1d(origin, insertion)
    free = np.setdiff1d(np.arange(n), fixed)
    w[free] = spla.spsolve(lap[free][:, free].tocsc(), -lap[free][:, fixed] @ w[fixed])
    return w


# sheet_topology's results by mesh and attachment lines (a few sheets at a time; a dict, so a benchmark can swap it)
TOPOLOGY_CACHE: dict = {}


def sheet_topology(triangles: np.ndarray, n: int, origin: np.ndarray, insertion: np.ndarray):
    """What a sheet's problem takes from its connectivity alone: L^T L of the regularisation's umbrella Laplacian L
    (per dof) and the predictor's harmonic weight (read-only), worked out once per mesh and attachment lines. A
    footprint band builds its problem anew at every pose it solves (four times a pose for a least-energy tendon), and
    these two were ~11 % of its solve (docs/fem.md "Newton")."""
    key = (np.shape(triangles), int(n), *(np.asarray(a).tobytes() for a in (triangles, origin, insertion)))
    hit = TOPOLOGY_CACHE.get(key)
    if hit is None:
        lap = sp.kron(_umbrella(triangles, n), sp.identity(3)).tocsr()
        weight = _harmonic_weight(triangles, n, origin, insertion)
        weight.setflags(write=False)
        hit = (lap.T @ lap, weight)
        if len(TOPOLOGY_CACHE) >= 16:
            TOPOLOGY_CACHE.clear()
        TOPOLOGY_CACHE[key] = hit
    return hit


@numba.njit(cache=True, error_model="numpy")
def _contact_pass(x, centre, axis, cylinder, radius, k, dl, g, blocks):
    """`MuscleProblem._contact` node by node: the energy (returned), its gradient into g (3N,) and, where `blocks` has
    N rows, each node's Hessian block, d2e n n^T - e'/r (P - n n^T) (P: the identity, less a a^T for a cylinder)."""
    energy = 0.0
    for i in range(len(x)):
        d = x[i] - centre
        if cylinder:
            d = d - (d[0] * axis[0] + d[1] * axis[1] + d[2] * axis[2]) * axis
        r = np.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
        gap = max(radius - r, 0.0)
        if gap < dl:
            e, de, d2e = k[i] * gap**3 / (6 * dl), k[i] * gap**2 / (2 * dl), k[i] * gap / dl
        else:
            e = k[i] * (dl**2 / 6 + dl * (gap - dl) / 2 + (gap - dl) ** 2 / 2)
            de, d2e = k[i] * (dl / 2 + gap - dl), k[i]
        energy += e
        rr = max(r, 1e-12)
        nrm = d / rr
        for a in range(3):
            g[3 * i + a] = -de * nrm[a]
        if blocks.shape[0] > 0:
            for a in range(3):
                for b in range(3):
                    nn = nrm[a] * nrm[b]
                    p = (1.0 if a == b else 0.0) - (axis[a] * axis[b] if cylinder else 0.0)
                    blocks[i, a, b] = d2e * nn - (de / rr) * (p - nn)
    return energy


class MuscleProblem:
    """One muscle sheet, ready to solve at any (theta, activation)."""

    # How the Newton systems are factorised (`assembly.LAYOUTS`): every sheet numbers its nodes row by row across the
    # fibres (`shells.grid_triangles`), so its tangent is banded as numbered and LAPACK's banded solvers (Cholesky
    # where positive definite, else LU) solve it faster than SuperLU in any column order, with the same steps to
    # rounding (`python benchmarks/fem_solver_speed.py --layouts COLAMD BANDED`, `--layouts BANDED_LU BANDED`;
    # docs/fem.md "Newton")
    layout = "BANDED"

    def __init__(self, shell: dict, material: Material | None = None, settings: SolverSettings | None = None,
                 f0: float | None = None):
        material = material or Material()
        settings = settings or SolverSettings()
        self.shell = shell
        self.material = material
        self.settings = settings
        self.mem = Membrane.from_mesh(shell["nodes"], shell["triangles"], shell["fibres"], shell["thickness"])
        self.kernel = ElementKernel(material)
        n = self.mem.n_nodes
        self.X = self.mem.nodes.copy()
        self.theta_ref = float(shell["theta_ref_deg"])
        self.origin = np.asarray(shell["origin_nodes"], np.int64)
        self.insertion = np.asarray(shell["insertion_nodes"], np.int64)
        fixed = np.union1d(self.origin, self.insertion)
        self.free = np.setdiff1d(np.arange(n), fixed)
        self.free_dofs = (3 * self.free[:, None] + np.arange(3)).ravel()
        self.f0 = float(f0 if f0 is not None else anatomy.F0[str(shell["muscle"])])
        self.node_area = np.bincount(self.mem.triangles.ravel(), np.repeat(self.mem.area / 3.0, 3), minlength=n)
        k_reg = settings.regularisation * material.background.youngs_modulus * float(np.mean(self.mem.thickness))
        lap_squared, self.weight = sheet_topology(self.mem.triangles, n, self.origin, self.insertion)
        self.reg_matrix = (k_reg * lap_squared).tocsr()
        self.centre = np.zeros(3)
        self.radius = anatomy.HUMERAL_HEAD_RADIUS
        self.axis = None  # contact with the sphere (centre, radius); a unit axis: the infinite cylinder about it
        self.stalled = 0  # solves accepted at stall_factor * tol (reported in the table meta)

    # -- energy -----------------------------------------------------------------------------------------------
    def _contact(self, x: np.ndarray, blocks: bool = True):
        """C2 penalty: e(g) = kappa A g^3 / (6 delta) for penetration g < delta, quadratic beyond (g: the radius less
        the distance from the centre, or from the axis for a cylinder): (energy, gradient (3N,), and with `blocks`
        each node's 3x3 Hessian block (N, 3, 3), else None). Compiled, node by node (`_contact_pass`).

        The cubic start keeps the tangent continuous when a node touches the head, so Newton does not chatter
        between contact and no contact.
        """
        n = len(x)
        g, node_blocks = np.zeros(3 * n), np.empty((n if blocks else 0, 3, 3))
        axis = np.zeros(3) if self.axis is None else np.asarray(self.axis, float)
        e = _contact_pass(np.ascontiguousarray(x, float), np.asarray(self.centre, float), axis, self.axis is not None,
                          float(self.radius), self.settings.contact_stiffness * self.node_area,
                          float(self.settings.contact_smoothing), g, node_blocks)
        return e, g, node_blocks if blocks else None

    def newton_system(self, x: np.ndarray, activation: float) -> tuple[float, FreeMatrix]:
        """(energy, the tangent stiffness on the free dofs): membrane, regularisation and contact."""
        e, _, he = membrane_blocks(self.mem, self.kernel, x, activation)
        u = (x - self.X).ravel()
        ec, _, blocks = self._contact(x)
        return e + 0.5 * float(u @ (self.reg_matrix @ u)) + ec, self._assembly().matrix(he, blocks)

    def _assembly(self) -> Assembly:
        """The free-dof matrix's layout, worked out once per free set and `layout`."""
        key = (self.layout, self.free_dofs.tobytes())
        if self.__dict__.get("_assembled", (None,))[0] != key:
            self._assembled = (key, Assembly(self.free_dofs, element_dofs(self.mem), self.mem.n_nodes,
                                             self.reg_matrix, self.layout))
        return self._assembled[1]

    def energy(self, x: np.ndarray, activation: float) -> float:
        u = (x - self.X).ravel()
        return membrane_energy(self.mem, self.kernel, x, activation) + 0.5 * float(u @ (self.reg_matrix @ u)) \
            + self._contact(x, blocks=False)[0]

    # -- boundary conditions and predictor -------------------------------------------------------------------------
    def insertion_positions(self, theta_deg: float) -> np.ndarray:
        return self.X[self.insertion] @ rotation_x(np.radians(theta_deg - self.theta_ref)).T

    def predict(self, x: np.ndarray, theta_from: float, theta_to: float) -> np.ndarray:
        """Rotate each node about +x by its harmonic weight times the angle change (exact at both ends)."""
        dt = np.radians(theta_to - theta_from) * self.weight
        c, s = np.cos(dt), np.sin(dt)
        y = x.copy()
        y[:, 1] = c * x[:, 1] - s * x[:, 2]
        y[:, 2] = s * x[:, 1] + c * x[:, 2]
        y[self.origin] = self.X[self.origin]
        y[self.insertion] = self.insertion_positions(theta_to)
        return y

    # -- Newton ------------------------------------------------------------------------------------------------------
    def gradient(self, x: np.ndarray, activation: float) -> np.ndarray:
        return self.gradient_energy(x, activation)[0]

    def gradient_energy(self, x: np.ndarray, activation: float) -> tuple[np.ndarray, float]:
        """(grad E, E) from one pass (the line search's trial points need both)."""
        u = (x - self.X).ravel()
        gm, em = membrane_forces_energy(self.mem, self.kernel, x, activation)
        ru = self.reg_matrix @ u
        ec, gc, _ = self._contact(x, blocks=False)
        return gm.ravel() + ru + gc, em + 0.5 * float(u @ ru) + ec

    def newton(self, x: np.ndarray, activation: float) -> tuple[np.ndarray, int]:
        """Solve grad E = 0 for the free nodes from x (fixed nodes already placed). Returns (x, iterations).

        The line search uses the residual norm, not the energy: on the descending limb of the active force-length
        curve (lambda > ~1.09 at a = 1) the fibre tangent is negative and the uniform solution is a saddle of E that
        an energy-decreasing method would leave for a mesh-dependent localised one; residual Newton with continuation
        follows the uniform branch, as ArtiSynth's quasi-static solver does.
        """
        s = self.settings
        tol = s.tol * self.f0
        x = x.copy()
        fd = self.free_dofs
        g = self.gradient(x, activation)
        r = g[fd]
        for it in range(s.max_iter + 1):
            rn = float(np.linalg.norm(r))
            if np.max(np.abs(r)) < tol:
                return x, it
            if it == s.max_iter:
                if s.iteration_stall and np.max(np.abs(r)) < s.stall_factor * tol:
                    self.stalled += 1  # Newton cycling within the stall band at its iteration limit
                    return x, it
                break
            e, h = self.newton_system(x, activation)
            diag_scale = h.mean_abs_diagonal()
            step = None
            for shift in (0.0, 1e-6, 1e-4, 1e-2, 1.0) if h.finite() else ():  # Levenberg shifts (of the mean
                p = h.solve(r, shift * diag_scale)  # diagonal); none on a non-finite matrix (SuperLU can crash on one)
                if p is None or not np.all(np.isfinite(p)):
                    continue
                step = self._line_search(x, -p, r, rn, e, activation)
                if step is not None:
                    break
            if step is None:
                if np.max(np.abs(r)) < s.stall_factor * tol:
                    self.stalled += 1  # kinks of the law (passive onset at lambda = 1, wrinkling) stall Newton
                    return x, it
                raise NoConvergence(f"line search failed (residual {np.max(np.abs(r)):.3g} N)")
            xt, rt = step
            x, r = xt, rt
        raise NoConvergence(f"no convergence in {s.max_iter} iterations (residual {np.max(np.abs(r)):.3g} N)")

    def _line_search(self, x, p, r, rn, e, activation):
        """Backtrack on p until the residual norm or the energy (Armijo) decreases; None if neither does. A point
        whose residual is not finite (an element collapsed: the energy can stay finite there) is never accepted."""
        fd = self.free_dofs
        t, slope = 1.0, float(r @ p)
        while t >= 1e-3:
            xt = x.copy()
            xt.reshape(-1)[fd] += t * p
            gt, et = self.gradient_energy(xt, activation)
            rt = gt[fd]
            if not np.all(np.isfinite(rt)):
                t *= 0.5
                continue
            if np.linalg.norm(rt) <= (1.0 - 1e-4 * t) * rn:
                return xt, rt
            if slope < 0.0 and et <= e + 1e-4 * t * slope:
                return xt, rt  # energy descent also counts: contact and wrinkling switches can raise the residual
            t *= 0.5
        return None

    def step(self, x: np.ndarray, state: tuple[float, float], target: tuple[float, float]):
        """Move from a converged (x, (theta, a)) to target, halving substeps on failure. Returns (x, newton its)."""
        s = self.settings
        th0, a0 = state
        th1, a1 = target
        n = max(1, int(np.ceil(max(abs(th1 - th0) / s.max_step_deg, abs(a1 - a0) / s.max_step_activation) - 1e-9)))
        frac, done, its = 1.0 / n, 0.0, 0
        while done < 1.0 - 1e-12:
            f = min(frac, 1.0 - done)
            tha = th0 + done * (th1 - th0)
            thb, ab = th0 + (done + f) * (th1 - th0), a0 + (done + f) * (a1 - a0)
            try:
                xn, k = self.newton(self.predict(x, tha, thb), ab)
            except NoConvergence:
                frac = f / 2.0
                if frac < s.min_step_fraction / n:
                    raise
                continue
            x, done, its = xn, done + f, its + k
        return x, its

    # -- reduction -------------------------------------------------------------------------------------------------
    def insertion_reaction(self, x: np.ndarray, activation: float) -> tuple[np.ndarray, float]:
        """(force the muscle exerts on the humerus at the insertion (3,), torque about +x, N m).

        Contact forces from the head sphere are radial through the joint centre, so they add no torque.
        """
        u = (x - self.X).ravel()
        g = (membrane_forces(self.mem, self.kernel, x, activation).ravel() + self.reg_matrix @ u).reshape(-1, 3)
        f = -g[self.insertion]
        torque = np.cross(x[self.insertion], f)[:, 0].sum()
        return f.sum(0), float(torque)

    def sweep(self, thetas: np.ndarray, activation: float, callback=None, neighbour=None):
        """Solve at every angle of `thetas` for one activation, by continuation from the stress-free reference.

        Ramps the activation at theta_ref, then walks up and down in angle. Where that path fails (slack sheets at
        low activation stall Newton), it restarts from `neighbour` = (activation', solutions at activation') by
        stepping the activation at fixed angle. Returns (forces (K, 3), torques (K,), Newton iterations (K,),
        solutions (K, N, 3)).
        """
        thetas = np.asarray(thetas, float)
        k = len(thetas)
        forces, torques, iters = np.zeros((k, 3)), np.zeros(k), np.zeros(k, int)
        xs = np.zeros((k, self.mem.n_nodes, 3))
        x0, _ = self.step(self.X.copy(), (self.theta_ref, 0.0), (self.theta_ref, activation))
        for order in (np.where(thetas >= self.theta_ref)[0], np.where(thetas < self.theta_ref)[0][::-1]):
            order = order[np.argsort(np.abs(thetas[order] - self.theta_ref), kind="stable")]
            x, th = x0, self.theta_ref
            for i in order:
                try:
                    x, its = self.step(x, (th, activation), (thetas[i], activation))
                except NoConvergence:
                    if neighbour is None:
                        raise
                    a_n, x_n = neighbour
                    x, its = self.step(x_n[i], (thetas[i], a_n), (thetas[i], activation))
                th = thetas[i]
                forces[i], torques[i] = self.insertion_reaction(x, activation)
                iters[i], xs[i] = its, x
                if callback is not None:
                    callback()
        return forces, torques, iters, xs
