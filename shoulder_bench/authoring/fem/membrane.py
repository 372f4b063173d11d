"""Constant-strain-triangle (CST) membrane with fibres: energy, nodal forces and tangent, vectorised over elements.

Each triangle gets a local reference frame (e1 along its fibre, e2 = n x e1) in which its reference edges form the
2x2 matrix Dm. The deformation gradient is the 3x2 map F = Ds Dm^-1 (Ds: deformed edges), C = F^T F, the fibre
stretch is lambda = |F e1| = sqrt(C11) and the element energy is

    E_e = A_e h_e [ W_background(C) + W_fibre(lambda, a) ]     (A_e reference area, h_e reference thickness)

The energy density is written once as a function of C = (C11, C22, C12) (`material`); its first and second
derivatives in c are written out in closed form (`material.fibre_point`, `material.background_point`, chained to c
in `_point`) and held to torch autograd of the energy, branch by branch (`autograd_derivatives`,
tests/test_membrane.py): autograd itself took 42 % of a band solve. The chain rule to node positions, which only
involves the linear maps F = sum_a x_a B_a and C = F^T F, is written out too, and the whole per-element pass
(energy, gradient, 9x9 element blocks) is one numba-compiled loop over the elements (`_element_pass`): as numpy
array code on a band's ~500 elements each of its ~100 array operations cost more in call overhead than in arithmetic
(20-90 x slower, benchmarks/fem_solver_speed.py). The element blocks (`membrane_blocks`) go into the Newton system's
fixed layout (`assembly`), or a sparse matrix (`membrane_tangent`).
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numba
import numpy as np
import scipy.sparse as sp
import torch

from shoulder_bench.authoring.fem.material import (
    Material,
    background_energy,
    background_parameters,
    background_point,
    fibre_energy,
    fibre_parameters,
    fibre_point,
)


@dataclass
class Membrane:
    """Reference geometry of a fibre membrane (all arrays per element unless said)."""

    nodes: np.ndarray  # (N, 3) reference positions
    triangles: np.ndarray  # (T, 3) node indices
    dm_inv: np.ndarray  # (T, 2, 2)
    area: np.ndarray  # (T,) reference area
    thickness: np.ndarray  # (T,) reference thickness

    @classmethod
    def from_mesh(cls, nodes, triangles, fibres, thickness) -> Membrane:
        nodes = np.asarray(nodes, float)
        tri = np.asarray(triangles, np.int64)
        x0, x1, x2 = (nodes[tri[:, i]] for i in range(3))
        normal = np.cross(x1 - x0, x2 - x0)
        area = 0.5 * np.linalg.norm(normal, axis=1)
        normal /= (2.0 * area)[:, None]
        e1 = np.asarray(fibres, float)
        e1 = e1 - (e1 * normal).sum(1, keepdims=True) * normal  # fibre projected into the element plane
        e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
        e2 = np.cross(normal, e1)
        edges = np.stack([x1 - x0, x2 - x0], axis=2)  # (T, 3, 2)
        dm = np.stack([np.einsum("ti,tij->tj", e1, edges), np.einsum("ti,tij->tj", e2, edges)], axis=1)
        th = np.broadcast_to(np.asarray(thickness, float), area.shape).copy()
        return cls(nodes, tri, np.linalg.inv(dm), area, th)

    @property
    def n_nodes(self) -> int:
        return len(self.nodes)

    @cached_property
    def shape_gradients(self) -> np.ndarray:
        """B (T, 3 nodes, 2): F = sum_a x_a B_a."""
        base = np.array([[-1.0, -1.0], [1.0, 0.0], [0.0, 1.0]])
        return np.einsum("ak,tkl->tal", base, self.dm_inv)


def energy_density(c, activation: float, material: Material):
    """Energy per reference volume from c = (C11, C22, C12) per element (T, 3), numpy or torch; C11 is along the
    fibre."""
    lib = torch if isinstance(c, torch.Tensor) else np
    tr_c = c[:, 0] + c[:, 1]
    det_c = c[:, 0] * c[:, 1] - c[:, 2] ** 2
    return background_energy(tr_c, det_c, material.background) + fibre_energy(lib.sqrt(c[:, 0]), activation,
                                                                              material.fibre)


def autograd_derivatives(c: np.ndarray, activation: float, material: Material):
    """(W, dW/dc, d2W/dc2) by torch autograd of `energy_density`: what `ElementKernel`'s closed form is held to
    (tests/test_membrane.py) and timed against (benchmarks/fem_solver_speed.py)."""
    ct = torch.from_numpy(c).requires_grad_(True)
    w = energy_density(ct, activation, material)
    (dw,) = torch.autograd.grad(w.sum(), ct, create_graph=True)
    rows = torch.eye(3, dtype=ct.dtype)[:, None, :].expand(3, *ct.shape)  # the three rows in one batched pass
    (d2w,) = torch.autograd.grad(dw, ct, grad_outputs=rows, is_grads_batched=True)
    return w.detach().numpy(), dw.detach().numpy(), d2w.permute(1, 0, 2).numpy()


@numba.njit(cache=True, error_model="numpy", inline="always")
def _point(c0, c1, c2, activation, fib, bg, dw, d2w):
    """W at c = (C11, C22, C12), its gradient into dw (3,) and its Hessian into d2w (3, 3): the background through
    tr C and det C (d tr/dc = (1, 1, 0), d det/dc = (C22, C11, -2 C12)), the fibre through lambda = sqrt(C11)."""
    wb, w_t, w_d, w_tt, w_td, w_dd = background_point(c0 + c1, c0 * c1 - c2 * c2, bg[0], bg[1], bg[2], bg[3])
    lam = np.sqrt(c0)
    wf, f1, f2 = fibre_point(lam, activation, fib[0], fib[1], fib[2], fib[3], fib[4], fib[5])
    d0, d1, d2 = c1, c0, -2.0 * c2
    dw[0] = w_t + w_d * d0 + 0.5 * f1 / lam
    dw[1] = w_t + w_d * d1
    dw[2] = w_d * d2
    tv = (1.0, 1.0, 0.0)
    dv = (d0, d1, d2)
    for i in range(3):
        for j in range(3):
            d2w[i, j] = w_tt * tv[i] * tv[j] + w_td * (tv[i] * dv[j] + dv[i] * tv[j]) + w_dd * dv[i] * dv[j]
    d2w[0, 1] += w_d  # d2(det C)/dc2
    d2w[1, 0] += w_d
    d2w[2, 2] -= 2.0 * w_d
    d2w[0, 0] += 0.25 * (f2 - f1 / lam) / lam**2
    return wb + wf


@numba.njit(cache=True, error_model="numpy")
def _derivatives_at(c, activation, fib, bg):
    n = len(c)
    w, dw, d2w = np.empty(n), np.empty((n, 3)), np.empty((n, 3, 3))
    for t in range(n):
        w[t] = _point(c[t, 0], c[t, 1], c[t, 2], activation, fib, bg, dw[t], d2w[t])
    return w, dw, d2w


@numba.njit(cache=True, error_model="numpy")
def _element_pass(x, triangles, b, vol, activation, fib, bg, g, he):
    """The membrane's energy (returned), its gradient added into g (3N,), element by element in order, and with
    `he` of shape (T, 9, 9) (not (0, 9, 9)) each element's Hessian block over its 9 dofs: the chain rule through
    F = sum_a x_a B_a, C = F^T F, dc/dx_a (`dc`), and the geometric part sum_i W_i d2c_i/dx_a dx_b (a multiple of
    the 3x3 identity)."""
    hessian = he.shape[0] > 0
    f1, f2 = np.empty(3), np.empty(3)
    dw, d2w, dc, ge = np.empty(3), np.empty((3, 3)), np.empty((3, 3, 3)), np.empty(9)
    energy = 0.0
    for t in range(len(triangles)):
        for k in range(3):
            f1[k] = x[triangles[t, 0], k] * b[t, 0, 0] + x[triangles[t, 1], k] * b[t, 1, 0] \
                + x[triangles[t, 2], k] * b[t, 2, 0]
            f2[k] = x[triangles[t, 0], k] * b[t, 0, 1] + x[triangles[t, 1], k] * b[t, 1, 1] \
                + x[triangles[t, 2], k] * b[t, 2, 1]
        c0 = f1[0] * f1[0] + f1[1] * f1[1] + f1[2] * f1[2]
        c1 = f2[0] * f2[0] + f2[1] * f2[1] + f2[2] * f2[2]
        c2 = f1[0] * f2[0] + f1[1] * f2[1] + f1[2] * f2[2]
        energy += vol[t] * _point(c0, c1, c2, activation, fib, bg, dw, d2w)
        for a in range(3):
            for k in range(3):
                dc[a, 0, k] = 2.0 * b[t, a, 0] * f1[k]
                dc[a, 1, k] = 2.0 * b[t, a, 1] * f2[k]
                dc[a, 2, k] = b[t, a, 0] * f2[k] + b[t, a, 1] * f1[k]
                ge[3 * a + k] = vol[t] * (dw[0] * dc[a, 0, k] + dw[1] * dc[a, 1, k] + dw[2] * dc[a, 2, k])
                g[3 * triangles[t, a] + k] += ge[3 * a + k]
        if not hessian:
            continue
        for a in range(3):
            for q in range(3):
                s = 2.0 * dw[0] * b[t, a, 0] * b[t, q, 0] + 2.0 * dw[1] * b[t, a, 1] * b[t, q, 1] \
                    + dw[2] * (b[t, a, 0] * b[t, q, 1] + b[t, a, 1] * b[t, q, 0])
                for k in range(3):
                    for m in range(3):
                        h = 0.0
                        for i in range(3):
                            h += dc[a, i, k] * (d2w[i, 0] * dc[q, 0, m] + d2w[i, 1] * dc[q, 1, m]
                                                + d2w[i, 2] * dc[q, 2, m])
                        he[t, 3 * a + k, 3 * q + m] = vol[t] * (h + s if k == m else h)
    return energy


class ElementKernel:
    """The energy density W(C11, C22, C12) (`energy`, numpy or torch: `energy_density`) and, compiled, its first and
    second derivatives in closed form: W = W_background(tr C, det C) + W_fibre(sqrt(C11)), each piece's derivatives
    from `material` (`background_point`, `fibre_point`), chained through d tr/dc = (1, 1, 0), d det/dc = (C22, C11,
    -2 C12) and d2 det/dc2. `evaluate` goes on by the chain rule to the nodes (C = F^T F, F = sum_a x_a B_a), all
    in one compiled pass over the elements (`_element_pass`)."""

    def __init__(self, material: Material):
        self.material = material
        self.fib = np.array(fibre_parameters(material.fibre), float)
        self.bg = np.array(background_parameters(material.background), float)

    def energy(self, c: np.ndarray, activation: float) -> np.ndarray:
        with np.errstate(invalid="ignore", divide="ignore"):  # a collapsed element: NaN, as autograd gave
            return energy_density(c, activation, self.material)

    def derivatives(self, c: np.ndarray, activation: float, second: bool = True):
        """(W, dW/dc, d2W/dc2) per element of c (T, 3); a collapsed element gives NaN (a line search's trial point,
        never accepted: solver._line_search)."""
        w, dw, d2w = _derivatives_at(np.ascontiguousarray(c, float), float(activation), self.fib, self.bg)
        return w, dw, d2w if second else None

    def evaluate(self, mem: Membrane, x: np.ndarray, activation: float, hessian: bool):
        """(energy, gradient (3N,), element Hessians (T, 9, 9) or None) of `mem` at x."""
        g = np.zeros(3 * mem.n_nodes)
        he = np.empty((len(mem.triangles) if hessian else 0, 9, 9))
        e = _element_pass(np.ascontiguousarray(x, float), mem.triangles, mem.shape_gradients,
                          mem.area * mem.thickness, float(activation), self.fib, self.bg, g, he)
        return e, g, he if hessian else None


def membrane_kinematics(mem: Membrane, x: np.ndarray):
    b = mem.shape_gradients
    f = np.einsum("tai,tak->tik", x[mem.triangles], b)  # (T, 3, 2)
    f1, f2 = f[:, :, 0], f[:, :, 1]
    c = np.stack([(f1 * f1).sum(1), (f2 * f2).sum(1), (f1 * f2).sum(1)], axis=1)
    return b, f1, f2, c


def membrane_energy(mem: Membrane, kernel: ElementKernel, x: np.ndarray, activation: float) -> float:
    _, _, _, c = membrane_kinematics(mem, x)
    return float(np.sum(mem.area * mem.thickness * kernel.energy(c, activation)))


def membrane_forces(mem: Membrane, kernel: ElementKernel, x: np.ndarray, activation: float) -> np.ndarray:
    """Gradient of the membrane energy w.r.t. node positions, (N, 3) (minus the internal nodal forces)."""
    return membrane_forces_energy(mem, kernel, x, activation)[0]


def membrane_forces_energy(mem: Membrane, kernel: ElementKernel, x: np.ndarray, activation: float):
    """(`membrane_forces`, the energy): one compiled pass gives both."""
    e, g, _ = kernel.evaluate(mem, x, activation, hessian=False)
    return g.reshape(-1, 3), e


def element_dofs(mem: Membrane) -> np.ndarray:
    """Each element's 9 degrees of freedom (its nodes' x, y, z), (T, 9)."""
    return (3 * mem.triangles[:, :, None] + np.arange(3)).reshape(-1, 9)  # (T, 9)


def membrane_blocks(mem: Membrane, kernel: ElementKernel, x: np.ndarray, activation: float):
    """(energy, gradient (3N,), element Hessians (T, 9, 9) over `element_dofs`)."""
    return kernel.evaluate(mem, x, activation, hessian=True)


def membrane_tangent(mem: Membrane, kernel: ElementKernel, x: np.ndarray, activation: float):
    """(energy, gradient (3N,), sparse Hessian (3N x 3N) CSR)."""
    e, g, he = membrane_blocks(mem, kernel, x, activation)
    dofs = element_dofs(mem)
    n = 3 * mem.n_nodes
    rows = np.repeat(dofs, 9, axis=1).ravel()
    cols = np.tile(dofs, (1, 9)).ravel()
    return e, g, sp.csr_matrix((he.ravel(), (rows, cols)), shape=(n, n))
