"""Constant-strain-triangle (CST) membrane with fibres: energy, nodal forces and tangent, vectorised over elements.

Each triangle gets a local reference frame (e1 along its fibre, e2 = n x e1) in which its reference edges form the
2x2 matrix Dm. The deformation gradient is the 3x2 map F = Ds Dm^-1 (Ds: deformed edges), C = F^T F, the fibre
stretch is lambda = |F e1| = sqrt(C11) and the element energy is

    E_e = A_e h_e [ W_background(C) + W_fibre(lambda, a) ]     (A_e reference area, h_e reference thickness)

The energy density is written once as a function of C = (C11, C22, C12) (`material`); its first and second
derivatives in c are written out in closed form (`material.fibre_derivatives`, `material.background_derivatives`,
chained to c here) and held to torch autograd of the energy, branch by branch (`autograd_derivatives`,
tests/test_membrane.py): autograd itself took 42 % of a band solve. The chain rule to node positions, which only
involves the linear maps F = sum_a x_a B_a and C = F^T F, is written out in numpy. The 9x9 element blocks
(`membrane_blocks`) go into the Newton system's fixed layout (`assembly`), or a sparse matrix (`membrane_tangent`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import torch

from shoulder_bench.authoring.fem.material import (
    Material,
    background_derivatives,
    background_energy,
    fibre_derivatives,
    fibre_energy,
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


_D2_DET = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -2.0]])  # d2(det C)/dc2


class ElementKernel:
    """Energy density W(C11, C22, C12) and its first and second derivatives, batched over elements, in closed form:
    W = W_background(tr C, det C) + W_fibre(sqrt(C11)), each piece's derivatives from `material`, chained through
    d tr/dc = (1, 1, 0), d det/dc = (C22, C11, -2 C12) and d2 det/dc2 (`_D2_DET`). The chain rule to node positions
    (C = F^T F, F = sum_a x_a B_a) is done by hand below."""

    def __init__(self, material: Material):
        self.material = material

    def energy(self, c: np.ndarray, activation: float) -> np.ndarray:
        with np.errstate(invalid="ignore", divide="ignore"):  # a collapsed element: NaN, as autograd gave
            return energy_density(c, activation, self.material)

    def derivatives(self, c: np.ndarray, activation: float, second: bool = True):
        with np.errstate(invalid="ignore", divide="ignore"):  # a collapsed element (a line search's trial point):
            return self._derivatives(c, activation, second)  # NaN, never accepted (solver._line_search)

    def _derivatives(self, c: np.ndarray, activation: float, second: bool):
        c0, c1, c2 = c[:, 0], c[:, 1], c[:, 2]
        w, w_t, w_d, w_tt, w_td, w_dd = background_derivatives(c0 + c1, c0 * c1 - c2**2, self.material.background)
        lam = np.sqrt(c0)
        w_f, f1, f2 = fibre_derivatives(lam, activation, self.material.fibre)
        t = np.array([1.0, 1.0, 0.0])
        d = np.stack([c1, c0, -2.0 * c2], axis=1)
        dw = w_t[:, None] * t + w_d[:, None] * d
        dw[:, 0] += 0.5 * f1 / lam
        if not second:
            return w + w_f, dw, None
        td = t[None, :, None] * d[:, None, :]
        d2w = (w_tt[:, None, None] * np.outer(t, t) + w_td[:, None, None] * (td + td.transpose(0, 2, 1))
               + w_dd[:, None, None] * d[:, :, None] * d[:, None, :] + w_d[:, None, None] * _D2_DET)
        d2w[:, 0, 0] += 0.25 * (f2 - f1 / lam) / lam**2
        return w + w_f, dw, d2w


def _shape_gradients(mem: Membrane) -> np.ndarray:
    """B (T, 3 nodes, 2): F = sum_a x_a B_a."""
    base = np.array([[-1.0, -1.0], [1.0, 0.0], [0.0, 1.0]])
    return np.einsum("ak,tkl->tal", base, mem.dm_inv)


def membrane_kinematics(mem: Membrane, x: np.ndarray):
    b = _shape_gradients(mem)
    f = np.einsum("tai,tak->tik", x[mem.triangles], b)  # (T, 3, 2)
    f1, f2 = f[:, :, 0], f[:, :, 1]
    c = np.stack([(f1 * f1).sum(1), (f2 * f2).sum(1), (f1 * f2).sum(1)], axis=1)
    return b, f1, f2, c


def membrane_energy(mem: Membrane, kernel: ElementKernel, x: np.ndarray, activation: float) -> float:
    _, _, _, c = membrane_kinematics(mem, x)
    return float(np.sum(mem.area * mem.thickness * kernel.energy(c, activation)))


def _element_gradient(b, f1, f2, dw, vol):
    # dc/dx_a: (T, a, 3 comps of c, 3 coords)
    dc = np.stack([2.0 * b[:, :, 0, None] * f1[:, None], 2.0 * b[:, :, 1, None] * f2[:, None],
                   b[:, :, 0, None] * f2[:, None] + b[:, :, 1, None] * f1[:, None]], axis=2)
    ge = vol[:, None, None] * np.einsum("ti,taid->tad", dw, dc)
    return dc, ge


def membrane_forces(mem: Membrane, kernel: ElementKernel, x: np.ndarray, activation: float) -> np.ndarray:
    """Gradient of the membrane energy w.r.t. node positions, (N, 3) (minus the internal nodal forces)."""
    b, f1, f2, c = membrane_kinematics(mem, x)
    _, dw, _ = kernel.derivatives(c, activation, second=False)
    _, ge = _element_gradient(b, f1, f2, dw, mem.area * mem.thickness)
    g = np.zeros((mem.n_nodes, 3))
    np.add.at(g, mem.triangles.reshape(-1), ge.reshape(-1, 3))
    return g


def element_dofs(mem: Membrane) -> np.ndarray:
    """Each element's 9 degrees of freedom (its nodes' x, y, z), (T, 9)."""
    return (3 * mem.triangles[:, :, None] + np.arange(3)).reshape(-1, 9)  # (T, 9)


def _material_blocks(d2w: np.ndarray, dc: np.ndarray) -> np.ndarray:
    """The material part of the element Hessians, sum_ij W_ij dc_i/dx_a (dc_j/dx_b)^T, (T, 3, 3, 3, 3), as batched
    (9 x 3)(3 x 3)(3 x 9) matrix products (the one-call einsum "tij,taid,tbje->tadbe" is the same to rounding and ~25 x
    slower: benchmarks/fem_solver_speed.py)."""
    t = len(dc)
    return (dc.transpose(0, 1, 3, 2).reshape(t, 9, 3) @ d2w @ dc.transpose(0, 2, 1, 3).reshape(t, 3, 9)).reshape(
        t, 3, 3, 3, 3)


def membrane_blocks(mem: Membrane, kernel: ElementKernel, x: np.ndarray, activation: float):
    """(energy, gradient (3N,), element Hessians (T, 9, 9) over `element_dofs`)."""
    b, f1, f2, c = membrane_kinematics(mem, x)
    w, dw, d2w = kernel.derivatives(c, activation)
    vol = mem.area * mem.thickness
    dc, ge = _element_gradient(b, f1, f2, dw, vol)
    h_mat = _material_blocks(d2w, dc)
    # geometric part: sum_i W_i d2c_i/dx_a dx_b (a multiple of the 3x3 identity)
    s = (2.0 * dw[:, 0, None, None] * b[:, :, None, 0] * b[:, None, :, 0]
         + 2.0 * dw[:, 1, None, None] * b[:, :, None, 1] * b[:, None, :, 1]
         + dw[:, 2, None, None] * (b[:, :, None, 0] * b[:, None, :, 1] + b[:, :, None, 1] * b[:, None, :, 0]))
    he = vol[:, None, None, None, None] * (h_mat + s[:, :, None, :, None] * np.eye(3)[None, None, :, None, :])
    g = np.bincount(element_dofs(mem).ravel(), weights=ge.reshape(-1, 9).ravel(), minlength=3 * mem.n_nodes)
    return float(np.sum(vol * w)), g, he.reshape(-1, 9, 9)


def membrane_tangent(mem: Membrane, kernel: ElementKernel, x: np.ndarray, activation: float):
    """(energy, gradient (3N,), sparse Hessian (3N x 3N) CSR)."""
    e, g, he = membrane_blocks(mem, kernel, x, activation)
    dofs = element_dofs(mem)
    n = 3 * mem.n_nodes
    rows = np.repeat(dofs, 9, axis=1).ravel()
    cols = np.tile(dofs, (1, 9)).ravel()
    return e, g, sp.csr_matrix((he.ravel(), (rows, cols)), shape=(n, n))
