"""The membrane's nodal forces and tangent are the derivatives of its energy (shoulder_bench/authoring/fem/membrane.py):
central finite differences on a small fibre sheet, stretched taut and sheared, at full and no activation; and the
element kernel's closed-form derivatives against torch autograd of the same energy density."""
from __future__ import annotations

import numpy as np
import pytest

from shoulder_bench.authoring.fem.material import Material
from shoulder_bench.authoring.fem.membrane import (
    ElementKernel,
    Membrane,
    autograd_derivatives,
    membrane_energy,
    membrane_forces,
    membrane_forces_energy,
    membrane_tangent,
)
from shoulder_bench.authoring.fem.shells import grid_triangles


def sheet(seed: int = 0):
    """A 5 x 4-node sheet 40 x 30 mm in the x-y plane with fibres along x, and a deformed state of it: stretched 15 %
    along the fibres, 5 % across, sheared, lifted out of plane and jittered (taut everywhere: no wrinkling switch)."""
    rng = np.random.default_rng(seed)
    u, v = np.meshgrid(np.linspace(0.0, 0.04, 5), np.linspace(0.0, 0.03, 4), indexing="ij")
    nodes = np.stack([u.ravel(), v.ravel(), np.zeros(u.size)], axis=1)
    tri = grid_triangles(5, 4)
    mem = Membrane.from_mesh(nodes, tri, np.tile([1.0, 0.0, 0.0], (len(tri), 1)), 0.002)
    x = nodes @ np.array([[1.15, 0.0, 0.02], [0.1, 1.05, 0.0], [0.0, 0.0, 1.0]]).T
    x[:, 2] += 0.002 * np.sin(60.0 * nodes[:, 0])
    return mem, x + 2e-4 * rng.normal(size=x.shape)


@pytest.mark.parametrize("activation", [1.0, 0.0])
def test_forces_and_tangent_are_the_energys_derivatives(activation):
    mem, x = sheet()
    kernel = ElementKernel(Material())
    e, g, h = membrane_tangent(mem, kernel, x, activation)
    assert e == pytest.approx(membrane_energy(mem, kernel, x, activation), rel=1e-12)
    np.testing.assert_allclose(g, membrane_forces(mem, kernel, x, activation).ravel(), rtol=1e-12, atol=1e-12)
    forces, energy = membrane_forces_energy(mem, kernel, x, activation)
    assert energy == pytest.approx(e, rel=1e-12) and np.array_equal(forces.ravel(), g)
    step = 1e-7
    fd_g, fd_h = np.zeros(x.size), np.zeros((x.size, x.size))
    for k in range(x.size):
        xp, xm = x.copy(), x.copy()
        xp.reshape(-1)[k] += step
        xm.reshape(-1)[k] -= step
        fd_g[k] = (membrane_energy(mem, kernel, xp, activation) - membrane_energy(mem, kernel, xm, activation)) / (
            2 * step)
        fd_h[:, k] = (membrane_forces(mem, kernel, xp, activation) - membrane_forces(mem, kernel, xm, activation)
                      ).ravel() / (2 * step)
    scale_g, scale_h = np.abs(g).max(), np.abs(fd_h).max()
    assert scale_g > 0 and scale_h > 0
    np.testing.assert_allclose(g, fd_g, atol=1e-5 * scale_g)
    np.testing.assert_allclose(h.toarray(), fd_h, atol=1e-5 * scale_h)
    np.testing.assert_allclose(h.toarray(), h.toarray().T, atol=1e-9 * scale_h)  # a Hessian is symmetric


@pytest.mark.parametrize("activation", [1.0, 0.4, 0.0])
def test_closed_form_derivatives_match_autograd_on_every_branch(activation):
    """The kernel's closed-form dW/dc and d2W/dc2 against torch autograd of the same energy, at right Cauchy-Green
    tensors of random plane deformations: taut, wrinkled and slack background, the fibre on every piece of the passive
    and active curves."""
    rng = np.random.default_rng(1)
    f = np.eye(2) + 0.6 * rng.normal(size=(20000, 2, 2)) * rng.random((20000, 1, 1))
    cg = np.einsum("tki,tkj->tij", f, f)
    c = np.stack([cg[:, 0, 0], cg[:, 1, 1], cg[:, 0, 1]], axis=1)
    c = c[c[:, 0] * c[:, 1] - c[:, 2] ** 2 > 1e-3]
    material = Material()
    b, lh = material.background, np.sqrt(c[:, 0]) / material.fibre.lambda_ofl
    tr, s = c[:, 0] + c[:, 1], np.sqrt(c[:, 0] * c[:, 1] - c[:, 2] ** 2)
    u, r = np.sqrt(tr + 2 * s), np.sqrt(np.maximum(tr - 2 * s, 0.0))
    e1, e2 = 0.5 * (u + r) - 1.0, 0.5 * (u - r) - 1.0
    taut = e2 >= -b.poisson_ratio * e1
    for branch in (taut, ~taut & (e1 > 0), ~taut & (e1 <= 0), lh < 0.4, (lh > 0.6) & (lh < 1.0),
                   (lh > 1.0) & (lh < 1.4), (lh > 1.4) & (lh < 1.6), lh > 1.6):
        assert branch.sum() > 100
    w0, g0, h0 = autograd_derivatives(c, activation, material)
    w1, g1, h1 = ElementKernel(material).derivatives(c, activation)
    np.testing.assert_allclose(w1, w0, rtol=1e-12, atol=1e-12 * np.abs(w0).max())
    # per element, against its largest entry; second derivatives lose digits to cancellation where C is nearly
    # isotropic, both ways
    assert np.max(np.abs(g1 - g0) / (np.abs(g0).max(axis=1, keepdims=True) + 1e-9)) < 1e-11
    assert np.max(np.abs(h1 - h0) / (np.abs(h0).max(axis=(1, 2), keepdims=True) + 1e-9)) < 1e-7
    _, g2, none = ElementKernel(material).derivatives(c, activation, second=False)
    assert none is None and np.array_equal(g2, g1)
