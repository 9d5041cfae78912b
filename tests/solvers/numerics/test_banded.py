"""Banded factorizations of a fixed CSR pattern (solvers/numerics/banded.py)."""
from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from hypate.solvers.numerics.banded import BandedStorage, SparseLU


def _laplacian_2d(nx: int, ny: int, shift: float) -> sp.csr_matrix:
    """5-point Laplacian plus ``shift`` on the diagonal, natural (x fastest) numbering."""
    ex = sp.diags([-1.0, 2.0, -1.0], [-1, 0, 1], shape=(nx, nx))
    ey = sp.diags([-1.0, 2.0, -1.0], [-1, 0, 1], shape=(ny, ny))
    A = sp.kron(sp.identity(ny), ex) + sp.kron(ey, sp.identity(nx))
    A = (A + shift * sp.identity(nx * ny)).tocsr()
    A.eliminate_zeros()
    A.sort_indices()
    return A


def _storage(A: sp.csr_matrix, position: np.ndarray) -> BandedStorage:
    rows = np.repeat(np.arange(A.shape[0]), np.diff(A.indptr))
    return BandedStorage(position, rows, A.indices.astype(np.int64))


def test_banded_factors_solve_like_a_dense_solve_in_any_ordering() -> None:
    # oracle: dense solve; tolerance 1e-12 relative (condition number ~ 50 here)
    A = _laplacian_2d(5, 7, 0.1)
    n = A.shape[0]
    b = np.random.default_rng(0).standard_normal(n)
    x_ref = np.linalg.solve(A.toarray(), b)
    natural = np.arange(n)
    # and the y-fastest ordering of the 5 x 7 grid (half bandwidth 7 instead of 5)
    j, i = np.divmod(natural, 5)
    for position in (natural, i * 7 + j):
        st = _storage(A, position)
        chol = st.cholesky(A.data)
        assert chol is not None
        np.testing.assert_allclose(chol.solve(b), x_ref, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(st.lu(A.data).solve(b), x_ref, rtol=1e-12, atol=1e-12)
    assert _storage(A, natural).bw == 5 and _storage(A, i * 7 + j).bw == 7


def test_banded_cholesky_declines_an_indefinite_matrix_and_lu_takes_it() -> None:
    A = _laplacian_2d(4, 4, -1.0)          # eigenvalues of the Laplacian straddle 1
    st = _storage(A, np.arange(A.shape[0]))
    assert st.cholesky(A.data) is None
    b = np.ones(A.shape[0])
    np.testing.assert_allclose(st.lu(A.data).solve(b), np.linalg.solve(A.toarray(), b),
                               rtol=1e-10)
    np.testing.assert_allclose(SparseLU(A).solve(b), np.linalg.solve(A.toarray(), b),
                               rtol=1e-10)


def test_a_singular_matrix_raises_linalg_error() -> None:
    # the pure-Neumann Laplacian (rows sum to zero): the last pivot is round-off
    ex = sp.diags([-1.0, 2.0, -1.0], [-1, 0, 1], shape=(6, 6)).tolil()
    ex[0, 0] = ex[5, 5] = 1.0
    A = ex.tocsr()
    A.sort_indices()
    st = _storage(A, np.arange(6))
    with pytest.raises(np.linalg.LinAlgError):
        st.lu(A.data)
