"""The Newton systems' matrix on a sheet's free degrees of freedom, in a layout fixed once (docs/fem.md "Newton").

A sheet's stiffness has the same non-zeros at every iteration (the elements' blocks, the nodes' contact blocks, the
regularisation), so where each contribution lands is worked out once (`Assembly`); an iteration sums the values into
place with one `np.bincount` instead of building a sparse matrix from coordinates, adding three and slicing out the
free rows and columns. Layouts (`LAYOUTS`, `MuscleProblem.layout`): BANDED, the nodes' own order for sheets numbered
row by row, whose matrix is banded as numbered (SciPy has no banded sparse solver, hence the layout here), solved by
LAPACK's banded Cholesky where the matrix is positive definite (most Newton steps; ~2.5 x cheaper than LU) and its
banded LU with partial pivoting where not (`scipy.linalg.solveh_banded`, `solve_banded`; the default); BANDED_LU,
the same by LU alone; or SuperLU's compressed columns in its column ordering, COLAMD (SciPy's default) or the nodes'
own (NATURAL), as the sheets were solved before.
"""
from __future__ import annotations

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

LAYOUTS = ("COLAMD", "NATURAL", "BANDED", "BANDED_LU")
BANDED = ("BANDED", "BANDED_LU")


class Assembly:
    """Where each element block entry (T, 9, 9), node contact block entry (N, 3, 3) and regularisation entry lands in
    the free-dof matrix of `layout`; the regularisation's share is summed once."""

    def __init__(self, free_dofs: np.ndarray, element_dofs: np.ndarray, n_nodes: int, reg_matrix, layout: str):
        if layout not in LAYOUTS:
            raise ValueError(f"unknown layout {layout!r}; choose from {', '.join(LAYOUTS)}")
        self.layout = layout
        self.m = m = len(free_dofs)
        pos = np.full(3 * n_nodes, -1, np.int64)
        pos[free_dofs] = np.arange(m)
        nodes = 3 * np.arange(n_nodes)[:, None] + np.arange(3)
        reg = reg_matrix.tocoo()
        parts = [(np.repeat(element_dofs, 9, axis=1).ravel(), np.tile(element_dofs, (1, 9)).ravel()),
                 (np.repeat(nodes, 3, axis=1).ravel(), np.tile(nodes, (1, 3)).ravel()), (reg.row, reg.col)]
        self.keep, places = [], []
        for rows, cols in parts:
            pr, pc = pos[rows], pos[cols]
            keep = (pr >= 0) & (pc >= 0)
            self.keep.append(keep)
            places.append((pr[keep], pc[keep]))
        pr, pc = (np.concatenate(v) for v in zip(*places))
        if layout in BANDED:
            self.lower, self.upper = int(np.max(pr - pc)), int(np.max(pc - pr))
            index, self.size = (self.upper + pr - pc) * m + pc, (self.lower + self.upper + 1) * m
            self.diagonal = self.upper * m + np.arange(m)
        else:
            keys, index = np.unique(pc * m + pr, return_inverse=True)  # column-major: compressed columns
            self.size, self.indices = len(keys), keys % m
            self.indptr = np.searchsorted(keys // m, np.arange(m + 1))
            self.diagonal = np.searchsorted(keys, np.arange(m) * (m + 1))
            if not np.array_equal(keys[self.diagonal], np.arange(m) * (m + 1)):
                raise ValueError("a free degree of freedom has no diagonal entry")
        n_var = int(self.keep[0].sum() + self.keep[1].sum())
        self.index = index[:n_var]
        self.constant = np.bincount(index[n_var:], weights=reg.data[self.keep[2]], minlength=self.size)

    def matrix(self, element_blocks: np.ndarray, contact_blocks: np.ndarray) -> FreeMatrix:
        values = np.concatenate([element_blocks.ravel()[self.keep[0]], contact_blocks.ravel()[self.keep[1]]])
        return FreeMatrix(self, np.bincount(self.index, weights=values, minlength=self.size) + self.constant)


class FreeMatrix:
    """The assembled free-dof matrix: its finiteness, mean |diagonal| and solves with a Levenberg shift."""

    def __init__(self, assembly: Assembly, data: np.ndarray):
        self.assembly, self.data = assembly, data

    def finite(self) -> bool:
        return bool(np.all(np.isfinite(self.data)))

    def mean_abs_diagonal(self) -> float:
        return float(np.mean(np.abs(self.data[self.assembly.diagonal])))

    def sparse(self) -> sp.csc_matrix:
        """As a SciPy matrix (compressed columns), whatever the layout."""
        a = self.assembly
        if a.layout not in BANDED:
            return sp.csc_matrix((self.data, a.indices, a.indptr), shape=(a.m, a.m))
        ab = self.data.reshape(a.lower + a.upper + 1, a.m)
        return sp.dia_matrix((ab, a.upper - np.arange(len(ab))), shape=(a.m, a.m)).tocsc()

    def solve(self, rhs: np.ndarray, shift: float = 0.0) -> np.ndarray | None:
        """(A + shift I)^-1 rhs; None where the factorisation finds the matrix singular."""
        a, data = self.assembly, self.data.copy()
        data[a.diagonal] += shift
        try:
            if a.layout in BANDED:
                ab = data.reshape(a.lower + a.upper + 1, a.m)
                if a.layout == "BANDED":
                    try:  # the upper band's rows are the upper triangle in LAPACK's symmetric band storage
                        return sla.solveh_banded(ab[:a.upper + 1], rhs, check_finite=False)
                    except np.linalg.LinAlgError:  # not positive definite: LU
                        pass
                return sla.solve_banded((a.lower, a.upper), ab, rhs, overwrite_ab=True, check_finite=False)
            return spla.spsolve(sp.csc_matrix((data, a.indices, a.indptr), shape=(a.m, a.m)), rhs,
                                permc_spec=a.layout)
        except (RuntimeError, np.linalg.LinAlgError):
            return None
