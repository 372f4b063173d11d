"""The membrane's nodal forces and tangent are the derivatives of its energy (shoulder_bench/authoring/fem/membrane.py):
central finite differences on a small fibre sheet, stretched taut and sheared, at full and no activation."""
from __future__ import annotations

import numpy as np
import pytest

from shoulder_bench.authoring.fem.material import Material
from shoulder_bench.authoring.fem.membrane import (
    ElementKernel,
    Membrane,
    membrane_energy,
    membrane_forces,
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
