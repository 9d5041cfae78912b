"""Sparse linear algebra of the hot path: the preconditioned GMRES (Eq. 5.45), the
fixed-pattern triple product and the free-block factor."""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from hypate.solvers.numerics.sparse import FreePattern, gmres, triple_product_operator


def _system(n: int = 300, seed: int = 0) -> tuple[sp.csc_matrix, np.ndarray]:
    """A nonsymmetric, diagonally dominant sparse matrix and a right-hand side."""
    rng = np.random.default_rng(seed)
    A = sp.random(n, n, density=0.02, random_state=seed, format="csc")
    A = A - A.T * 0.5 + sp.identity(n, format="csc") * 4.0
    return A.tocsc(), rng.standard_normal(n)


def test_gmres_with_a_nearby_factor_matches_the_direct_solution() -> None:
    A, b = _system()
    rng = np.random.default_rng(1)
    # preconditioner: the factor of A with 1 % perturbed entries (the previous step's matrix)
    P = A.copy()
    P.data *= 1.0 + 0.01 * rng.standard_normal(P.nnz)
    lu = spla.splu(P.tocsc())
    x, est, its = gmres(A.__matmul__, lu.solve, b, rtol=1e-11, max_iter=30)
    direct = spla.splu(A).solve(b)
    # converged: the recurrence estimate is the true residual (right preconditioning)
    res = np.linalg.norm(A @ x - b) / np.linalg.norm(b)
    assert est <= 1e-11 and its < 30
    assert abs(res - est) <= 1e-12
    assert np.linalg.norm(x - direct) <= 1e-9 * np.linalg.norm(direct)


def test_gmres_exact_preconditioner_converges_in_one_iteration() -> None:
    A, b = _system(seed=3)
    lu = spla.splu(A)
    x, est, its = gmres(A.__matmul__, lu.solve, b, rtol=1e-12, max_iter=10)
    # A P^-1 = I: the Krylov space of dimension one holds the solution
    assert its == 1
    assert np.linalg.norm(A @ x - b) <= 1e-12 * np.linalg.norm(b)


def test_gmres_terminates_in_n_steps_and_reports_the_unconverged_residual() -> None:
    # unpreconditioned on a 12 x 12 system: exact after at most n iterations (finite
    # termination of GMRES); with fewer the estimate equals the true residual
    rng = np.random.default_rng(5)
    A = rng.standard_normal((12, 12)) + 6.0 * np.eye(12)
    b = rng.standard_normal(12)
    x, est, its = gmres(A.__matmul__, lambda v: v, b, rtol=1e-14, max_iter=12)
    assert its <= 12
    assert np.linalg.norm(A @ x - b) <= 1e-12 * np.linalg.norm(b)
    x3, est3, its3 = gmres(A.__matmul__, lambda v: v, b, rtol=1e-14, max_iter=3)
    assert its3 == 3
    assert abs(np.linalg.norm(A @ x3 - b) / np.linalg.norm(b) - est3) <= 1e-12
    assert est3 > 1e-6  # three Krylov vectors cannot solve this well-spread system


def test_gmres_zero_right_hand_side() -> None:
    A, _ = _system()
    x, est, its = gmres(A.__matmul__, lambda v: v, np.zeros(A.shape[0]), 1e-10, 5)
    assert its == 0 and est == 0.0 and not np.any(x)


def test_triple_product_operator_gives_the_data_of_L_diag_d_R() -> None:
    rng = np.random.default_rng(2)
    L = sp.random(40, 25, density=0.1, random_state=3, format="csr")
    R = sp.random(25, 30, density=0.1, random_state=4, format="csr")
    d = rng.standard_normal(25)
    T, indptr, indices = triple_product_operator(L, R)
    ref = (L @ sp.diags(d) @ R).toarray()
    got = sp.csr_matrix((T @ d, indices, indptr), shape=ref.shape).toarray()
    # the same sums in another order: round-off of the entries (1e-14 of their scale)
    np.testing.assert_allclose(got, ref, rtol=0.0, atol=1e-14 * np.max(np.abs(ref)))
    # on a larger given pattern (the full one): the same matrix, zeros elsewhere
    full = sp.csr_matrix(np.ones(ref.shape))
    T2, ip2, ix2 = triple_product_operator(L, R, (full.indptr, full.indices))
    got2 = sp.csr_matrix((T2 @ d, ix2, ip2), shape=ref.shape).toarray()
    np.testing.assert_allclose(got2, ref, rtol=0.0, atol=1e-14 * np.max(np.abs(ref)))


def test_free_pattern_factor_solves_the_free_block() -> None:
    A, b = _system(120, seed=5)
    A = sp.csr_matrix(A + A.T.multiply(1e-3))  # structurally symmetric, nearly symmetric
    A.sort_indices()
    free = np.setdiff1d(np.arange(120), [0, 7, 50])
    fp = FreePattern(A.indptr, A.indices, 120, free)
    block = A.data[fp.sel]
    Aff = A[free][:, free]
    np.testing.assert_array_equal(fp.csc_from_block(block).toarray(), Aff.toarray())
    x = fp.factor(block).solve(b[free])
    assert np.linalg.norm(Aff @ x - b[free]) <= 1e-10 * np.linalg.norm(b[free])
