"""Linearized stability analysis: GEP/PEP eigenvalues, classification, low-rank solvers."""
from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from hypate.solvers.coupling.stability import (
    LowRank,
    classify,
    gep,
    pep,
    shift_invert_gep,
    start_vector,
)


def _system(n: int = 40, c: float = 0.0):
    """K = diag(k) with a skew coupling c between the two lowest modes (K_A), M = I."""
    k = np.linspace(1.0, 5.0, n) ** 2 * 100.0
    K = sp.diags(k).tocsr()
    M = sp.identity(n, format="csr")
    KA = sp.lil_matrix((n, n))
    KA[0, 1], KA[1, 0] = -c, c
    return K, M, KA.tocsr(), k


def test_gep_matches_dense_eigenvalues_and_classifies() -> None:
    K, M, KA, k = _system(c=0.0)
    res = gep(K, M, None, count=4)
    assert res.status == "neutral"
    assert np.allclose(np.sort(res.frequency), np.sqrt(k[:4]), rtol=1e-10)
    # skew coupling beyond half the frequency gap -> coalescence (flutter)
    gap = 0.5 * (k[1] - k[0])
    K, M, KA, k = _system(c=1.5 * gap)
    res = gep(K, M, KA, count=4)
    dense = sla.eigvals((K - KA).toarray())
    lam_p = np.sqrt(-dense.astype(complex))
    assert res.status == "flutter"
    assert np.max(res.damping) == pytest.approx(np.max(np.abs(lam_p.real)), rel=1e-8)


def test_divergence_when_stiffness_negative() -> None:
    K, M, KA, k = _system()
    K = (K - sp.diags(np.r_[2 * k[0], np.zeros(k.size - 1)])).tocsr()  # first mode -k0
    res = gep(K, M, None, count=3)
    assert res.status == "divergence"
    assert res.lambda_p[res.critical].real == pytest.approx(np.sqrt(k[0]), rel=1e-10)


def test_pep_without_damping_equals_gep() -> None:
    K, M, KA, k = _system(c=0.8 * 0.5 * (4.0 ** 2 - 1.0) * 0)  # no coupling
    g = gep(K, M, None, count=4)
    p = pep(K, M, None, None, None, count=4)
    # acceptance (issue 6): GEP and PEP frequencies agree within 0.1 %; here exact
    assert np.allclose(np.sort(p.frequency), np.sort(g.frequency), rtol=1e-8)


def test_pep_with_damping_matches_dense_quadratic_eigenvalues() -> None:
    K, M, KA, k = _system(n=12, c=0.0)
    C = sp.diags(np.full(12, 0.5)).tocsr()
    res = pep(K, M, C, None, None, count=3)
    # dense companion form
    n = 12
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-K.toarray(), -C.toarray()]])
    ev = np.linalg.eigvals(A)
    ev = ev[ev.imag > 0]
    ev = ev[np.argsort(ev.imag)][:3]
    assert np.allclose(res.lambda_p, ev, rtol=1e-10)
    assert res.status == "stable" and np.allclose(res.damping, -0.25)


def test_low_rank_solvers_agree_with_direct() -> None:
    rng = np.random.default_rng(5)
    K, M, _, k = _system(n=60)
    U, V = rng.normal(0, 3.0, (60, 3)), rng.normal(0, 3.0, (60, 3))
    KA = LowRank(U, V)
    direct = gep(K, M, sp.csr_matrix(KA.toarray()), count=5, solver="direct")
    wood = gep(K, M, KA, count=5, solver="woodbury")
    gm = gep(K, M, KA, count=5, solver="gmres")
    # acceptance (issue 6): the low-rank paths equal the direct path to 1e-8 relative
    for other in (wood, gm):
        assert np.allclose(other.lambda_p, direct.lambda_p, rtol=1e-8, atol=1e-8 * np.abs(direct.lambda_p).max())


def test_classify_table_5_1() -> None:
    assert classify(np.array([-0.1 + 10j]))[0] == "stable"
    assert classify(np.array([0.0 + 10j]))[0] == "neutral"
    assert classify(np.array([0.3 + 10j, -0.1 + 5j]))[0] == "flutter"
    assert classify(np.array([2.0 + 0j, 0.3 + 10j]))[0] == "divergence"


def test_shift_invert_warm_start_gives_the_same_eigenpairs() -> None:
    # a nonsymmetric GEP (skew coupling below coalescence) and a nearby one (2 % stiffer):
    # the eigenvectors of the first start the Arnoldi process of the second (Eq. 5.36)
    rng = np.random.default_rng(4)
    n = 200
    k = np.linspace(1.0, 8.0, n) ** 2 * 100.0
    M = sp.diags(rng.uniform(1.0, 2.0, n)).tocsr()
    KA = sp.random(n, n, density=0.02, random_state=4, format="csr") * 5.0
    KA = (KA - KA.T).tocsr()
    sigma = -1e-6
    found: list[np.ndarray] = []
    first = shift_invert_gep(spla.splu((sp.diags(k) - KA - sigma * M).tocsc()).solve, M, sigma,
                             count=6, on_vectors=found.append)
    V = found[0]
    K2 = sp.diags(1.02 * k) - KA
    solve2 = spla.splu((K2 - sigma * M).tocsc()).solve
    cold = shift_invert_gep(solve2, M, sigma, count=6)
    warm = shift_invert_gep(solve2, M, sigma, count=6, v0=start_vector(V))
    assert np.allclose(warm.lambda_p, cold.lambda_p, rtol=1e-11, atol=0.0)
    # the vectors handed out are eigenvectors of the first problem: with
    # lambda_g = -lambda_p^2 (Eq. 5.35), ||(K - K_A) v - lambda_g M v|| <= 1e-9 ||K v||
    lam_g = np.sort_complex(-first.lambda_p ** 2)
    K1 = (sp.diags(k) - KA).tocsr()
    for j in range(V.shape[1]):
        v = V[:, j]
        rq = (v.conj() @ (K1 @ v)) / (v.conj() @ (M @ v))
        assert np.min(np.abs(lam_g - rq)) <= 1e-9 * abs(rq)
        assert np.linalg.norm(K1 @ v - rq * (M @ v)) <= 1e-9 * np.linalg.norm(K1 @ v)


def test_start_vector_lies_in_the_span_of_the_modes() -> None:
    rng = np.random.default_rng(6)
    V = rng.standard_normal((50, 4)) + 1j * rng.standard_normal((50, 4))
    v0 = start_vector(V)
    basis = np.hstack([V.real, V.imag])
    coef, *_ = np.linalg.lstsq(basis, v0, rcond=None)
    assert v0.dtype == np.float64
    assert np.linalg.norm(basis @ coef - v0) <= 1e-12 * np.linalg.norm(v0)
