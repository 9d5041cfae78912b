"""LAPACK banded factorizations of matrices with one fixed CSR pattern (the thermal hot path).

:class:`BandedStorage` holds, for a given ordering of the unknowns, the scatter maps from
the CSR values to LAPACK band storage, so a refactorization costs only the factorization:
banded Cholesky (``dpbtrf``) for a symmetric positive definite matrix, banded LU
(``dgbtrf``) otherwise. :class:`SparseLU` (SuperLU) takes matrices outside the pattern.
Every factor solves in the original ordering (:class:`Factorization`). Imports nothing else
of ``solvers``: a singular matrix raises ``numpy.linalg.LinAlgError``, which the caller may
translate.
"""
from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from numpy.typing import NDArray
from scipy.linalg import lapack

Array = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: A pivot below this fraction of its diagonal entry marks a singular matrix.
PIVOT_RTOL = 1e-11


class Factorization(ABC):
    """A factorized matrix: ``solve(b)`` in the original ordering of the unknowns."""

    @abstractmethod
    def solve(self, b: Array) -> Array:
        """Solve with the factorized matrix."""


class BandedCholesky(Factorization):
    """Banded Cholesky factor ``c`` (LAPACK upper band storage) in the ordering ``perm``."""

    def __init__(self, c: Array, perm: IntArray) -> None:
        self.c, self.perm = c, perm

    def solve(self, b: Array) -> Array:
        x, info = lapack.dpbtrs(self.c, b[self.perm])
        out = np.empty_like(b)
        out[self.perm] = x
        return out


class BandedLU(Factorization):
    """Banded LU factor (``dgbtrf`` storage, pivots ``piv``, bandwidth ``kl``) in ``perm``."""

    def __init__(self, lu: Array, piv: NDArray[np.int32], kl: int, perm: IntArray) -> None:
        self.lu, self.piv, self.kl, self.perm = lu, piv, kl, perm

    def solve(self, b: Array) -> Array:
        x, info = lapack.dgbtrs(self.lu, self.kl, self.kl, b[self.perm], self.piv)
        out = np.empty_like(b)
        out[self.perm] = x
        return out


class SparseLU(Factorization):
    """SuperLU factor of any sparse matrix (``RuntimeError`` when exactly singular)."""

    def __init__(self, A: sp.spmatrix) -> None:
        self.lu = spla.splu(sp.csc_matrix(A), permc_spec="MMD_AT_PLUS_A")

    def solve(self, b: Array) -> Array:
        return self.lu.solve(b)


class BandedStorage:
    """Scatter maps from a fixed CSR pattern to LAPACK band storage.

    Parameters
    ----------
    position : ndarray of int of shape (n,)
        ``position[i]``: place of unknown ``i`` in the banded ordering (a permutation).
    rows, cols : ndarray of int of shape (nnz,)
        Row and column of every stored CSR entry (a structurally symmetric pattern).

    Attributes
    ----------
    bw : int
        Half bandwidth in the banded ordering.
    perm : ndarray of int of shape (n,)
        ``perm[pos]``: the unknown at place ``pos``.
    """

    def __init__(self, position: IntArray, rows: IntArray, cols: IntArray) -> None:
        self.position = np.asarray(position).astype(np.int64)
        self.perm = np.argsort(self.position, kind="stable")
        pr, pc = self.position[rows], self.position[cols]
        self.bw = int(np.max(np.abs(pr - pc))) if rows.size else 0
        self.n = int(self.position.size)
        bw = self.bw
        upper = pr <= pc
        self.chol_entries = np.flatnonzero(upper)
        self.chol_index = (bw + pr[upper] - pc[upper]) * self.n + pc[upper]
        self.lu_index = (2 * bw + pr - pc) * self.n + pc
        diag = np.flatnonzero(rows == cols)
        self.diag_entries = diag[np.argsort(self.position[rows[diag]], kind="stable")]

    def cholesky(self, data: Array) -> Factorization | None:
        """Banded Cholesky of the matrix with CSR values ``data``; None if not positive
        definite.

        Raises
        ------
        numpy.linalg.LinAlgError
            A pivot is negligible against its diagonal entry (:func:`check_pivots`).
        """
        ab = np.zeros((self.bw + 1) * self.n)
        ab[self.chol_index] = data[self.chol_entries]
        c, info = lapack.dpbtrf(ab.reshape(self.bw + 1, self.n), overwrite_ab=1)
        if info != 0:
            return None
        check_pivots(c[self.bw] ** 2, data[self.diag_entries])
        return BandedCholesky(c, self.perm)

    def lu(self, data: Array) -> Factorization:
        """Banded LU (partial pivoting) of the matrix with CSR values ``data``.

        Raises
        ------
        numpy.linalg.LinAlgError
            Singular, or a pivot negligible against its diagonal entry.
        """
        ab = np.zeros((3 * self.bw + 1) * self.n)
        ab[self.lu_index] = data
        lu, piv, info = lapack.dgbtrf(ab.reshape(3 * self.bw + 1, self.n), self.bw, self.bw,
                                      overwrite_ab=1)
        check_pivots(np.abs(lu[2 * self.bw]) if info == 0 else np.zeros(1),
                     data[self.diag_entries])
        return BandedLU(lu, piv, self.bw, self.perm)


def check_pivots(pivots: Array, diagonal: Array) -> None:
    """Raise ``LinAlgError`` if a pivot is negligible against its diagonal entry.

    Both in the banded ordering; for a singular matrix such as the pure-Neumann steady heat
    conduction problem the last pivot is at the round-off level of its diagonal entry.
    """
    if not np.all(np.abs(pivots) > PIVOT_RTOL * np.abs(diagonal)):
        raise np.linalg.LinAlgError("singular matrix: a pivot is negligible against its "
                                    "diagonal entry")
