"""The Newton systems' free-dof matrix in its fixed layouts (shoulder_bench/authoring/fem/assembly.py) against the
sparse tangent it replaces (membrane tangent + regularisation + contact, free rows and columns sliced out), on a
footprint band pressing on its wrap sphere (3 dofs per node) and a length-keyed sheet (2, in-plane)."""
from __future__ import annotations

import signal
import warnings

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.sparse as sp

from shoulder_bench import full_arm
from shoulder_bench.authoring.fem import footprint, full
from shoulder_bench.authoring.fem.assembly import BANDED, LAYOUTS, Assembly
from shoulder_bench.authoring.fem.membrane import element_dofs, membrane_tangent
from shoulder_bench.authoring.fem.shells import grid_triangles
from shoulder_bench.authoring.fem.v2_sheet import SheetProblem


def sliced(problem, x, activation):
    """(energy, dense free-dof tangent) the way Newton built them before the fixed layouts."""
    e, _, h = membrane_tangent(problem.mem, problem.kernel, x, activation)
    u = (x - problem.X).ravel()
    ec, _, blocks = problem._contact(x)
    n = problem.mem.n_nodes
    rows = (3 * np.arange(n)[:, None, None] + np.arange(3)[None, :, None]).repeat(3, axis=2)
    hc = sp.csr_matrix((blocks.ravel(), (rows.ravel(), rows.transpose(0, 2, 1).ravel())), shape=(3 * n, 3 * n))
    fd = problem.free_dofs
    free = (h + problem.reg_matrix + hc).tocsr()[fd][:, fd].toarray()
    return e + 0.5 * float(u @ (problem.reg_matrix @ u)) + ec, free


@pytest.fixture(scope="module")
def problems():
    band = footprint.FootprintSheet("ssp", "coarse", pose=full_arm.Pose(), rest="pose")
    band.solve((0.0, 10.0, 0.0))  # places the band pressing on its sphere
    rng = np.random.default_rng(0)
    sheet = SheetProblem(full.specs()["ssp"], "coarse")
    x_sheet = sheet.X + 1e-4 * rng.normal(size=sheet.X.shape)
    x_sheet[:, 2] = 0.0
    return [(band.problem, band.problem.X + 1e-4 * rng.normal(size=band.problem.X.shape)), (sheet, x_sheet)]


@pytest.mark.parametrize("layout", LAYOUTS)
def test_the_assembled_matrix_is_the_sliced_tangent_and_solves_as_it(layout, problems, monkeypatch):
    for problem, x in problems:
        monkeypatch.setattr(type(problem), "layout", layout)
        e, h = problem.newton_system(x, 1.0)
        e0, h0 = sliced(problem, x, 1.0)
        scale = np.abs(h0).max()
        assert e == pytest.approx(e0, rel=1e-12) and h.finite()
        np.testing.assert_allclose(h.sparse().toarray(), h0, rtol=0, atol=1e-13 * scale)
        assert h.mean_abs_diagonal() == pytest.approx(np.mean(np.abs(np.diag(h0))), rel=1e-12)
        rhs = np.random.default_rng(1).normal(size=len(h0))
        for shift in (0.0, 0.01 * scale):
            want = np.linalg.solve(h0 + shift * np.eye(len(h0)), rhs)
            np.testing.assert_allclose(h.solve(rhs, shift), want, rtol=0, atol=1e-9 * np.abs(want).max())
        if layout in BANDED:  # the sheets number their nodes row by row: banded as numbered, symmetric pattern
            assembly = problem._assembly()
            assert assembly.lower == assembly.upper < len(h0) // 3


def test_banded_solves_by_cholesky_where_positive_definite_and_by_lu_where_not(problems, monkeypatch):
    """BANDED: LAPACK's banded Cholesky on a positive definite matrix, its banded LU on an indefinite one (a shift
    below the smallest eigenvalue), each equal to a dense solve; BANDED_LU: LU alone."""
    problem, x = problems[0]
    monkeypatch.setattr(type(problem), "layout", "BANDED")
    _, h = problem.newton_system(x, 1.0)
    h0 = h.sparse().toarray()
    eig = np.linalg.eigvalsh(h0)
    rhs = np.random.default_rng(2).normal(size=len(h0))
    calls = []
    for name in ("solveh_banded", "solve_banded"):
        real = getattr(sla, name)
        monkeypatch.setattr(sla, name, lambda *a, real=real, name=name, **k: calls.append(name) or real(*a, **k))
    for shift, used in ((1e-3 * eig[-1] - eig[0], ["solveh_banded"]),
                        (-0.5 * (eig[0] + eig[-1]), ["solveh_banded", "solve_banded"])):
        calls.clear()
        want = np.linalg.solve(h0 + shift * np.eye(len(h0)), rhs)
        np.testing.assert_allclose(h.solve(rhs, shift), want, rtol=0, atol=1e-8 * np.abs(want).max())
        assert calls == used
    monkeypatch.setattr(type(problem), "layout", "BANDED_LU")
    _, h = problem.newton_system(x, 1.0)
    calls.clear()
    h.solve(rhs, 1e-3 * eig[-1] - eig[0])
    assert calls == ["solve_banded"]


def test_a_singular_matrix_solves_to_none_or_not_finite_and_a_bad_layout_is_refused(problems):
    problem, x = problems[0]
    for layout in LAYOUTS:
        a = Assembly(problem.free_dofs, element_dofs(problem.mem), problem.mem.n_nodes, 0 * problem.reg_matrix, layout)
        h = a.matrix(np.zeros((len(problem.mem.triangles), 9, 9)), np.zeros((problem.mem.n_nodes, 3, 3)))
        with warnings.catch_warnings():  # SuperLU warns of the singular matrix and returns NaN
            warnings.simplefilter("ignore")
            p = h.solve(np.ones(a.m))
        assert p is None or not np.all(np.isfinite(p))
    with pytest.raises(ValueError, match="unknown layout 'LU'"):
        Assembly(problem.free_dofs, element_dofs(problem.mem), problem.mem.n_nodes, problem.reg_matrix, "LU")



def _worker_state():
    from threadpoolctl import threadpool_info

    blas = [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]
    return blas, signal.getsignal(signal.SIGTERM) == signal.SIG_DFL


def test_a_build_worker_takes_one_blas_thread_and_sigterm_ends_it():
    """`fem.worker_init`: the parallel builds' workers factorise with one BLAS thread each (not N processes x
    OpenBLAS's threads on N cores), and a SIGTERM ends a worker instead of becoming the CLI's KeyboardInterrupt,
    which the pool would return as a task's error and go on."""
    from concurrent.futures import ProcessPoolExecutor

    from shoulder_bench.authoring.fem import worker_init

    previous = signal.signal(signal.SIGTERM, lambda *a: None)  # as the CLI installs it, inherited through fork
    try:
        with ProcessPoolExecutor(1, initializer=worker_init) as pool:
            blas, default_sigterm = pool.submit(_worker_state).result()
    finally:
        signal.signal(signal.SIGTERM, previous)
    assert blas and all(n == 1 for n in blas) and default_sigterm


def test_a_sheets_connectivity_is_worked_out_once_per_mesh_and_attachment_lines(monkeypatch):
    """`solver.sheet_topology`'s cache gives what the problem worked out before (L^T L, the harmonic weight), keyed on
    the attachment lines too: the same mesh with the insertion line moved gets its own weight."""
    from shoulder_bench.authoring.fem import solver

    monkeypatch.setattr(solver, "TOPOLOGY_CACHE", {})
    tri, n = grid_triangles(6, 4), 24
    ends = [(np.arange(4), np.arange(20, 24)), (np.arange(4), np.arange(16, 20))]
    for origin, insertion in ends * 2:
        lap = sp.kron(solver._umbrella(tri, n), sp.identity(3)).tocsr()
        lap_squared, weight = solver.sheet_topology(tri, n, origin, insertion)
        assert abs(lap_squared - lap.T @ lap).max() == 0.0
        np.testing.assert_array_equal(weight, solver._harmonic_weight(tri, n, origin, insertion))
        assert not weight.flags.writeable and weight[insertion].min() == 1.0
    assert len(solver.TOPOLOGY_CACHE) == 2
