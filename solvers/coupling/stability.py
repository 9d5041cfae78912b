"""Linearized stability analysis (LSA), Sec. 5.4.2 and 5.4.4.

About a converged quasi-steady state the unsteady response obeys
``[lambda_p^2 M + lambda_p (C - C_A) + (K - K_A)] u = 0`` (PEP, Eq. 5.33); without
damping terms it reduces to the GEP ``(K - K_A) u = lambda_g M u``, ``lambda_g = -lambda_p^2``
(Eq. 5.35), solved for the few eigenvalues nearest zero by shift-invert Arnoldi (ARPACK,
Eq. 5.36). Damping and frequency are ``zeta = Re(lambda_p)``, ``omega = Im(lambda_p)``
(Eq. 5.37), classified per Table 5.1.

The aerodynamic stiffness K_A may be sparse (analytic aerodynamics: it has the sparsity of
the shell stencil) or low rank ``K_A = U V^T`` (a ROM, Eq. 5.43). For a low-rank K_A the
shifted solves use either an exact Woodbury update of the symmetric structural factor or
GMRES preconditioned by it (Eqs. 5.44-5.45); both give the same result as a direct solve.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from hypate.solvers.numerics.threads import single_threaded_blas
from numpy.typing import NDArray

Array = NDArray[np.float64]
CArray = NDArray[np.complex128]

#: Relative imaginary part of lambda_g above which a mode counts as complex (flutter).
COMPLEX_TOL = 1e-6


@dataclass(frozen=True, eq=False)
class LowRank:
    """A low-rank matrix ``U @ V.T`` (n x n), never formed densely."""

    U: Array
    V: Array

    @property
    def shape(self) -> tuple[int, int]:
        return (self.U.shape[0], self.V.shape[0])

    def __matmul__(self, x: Array) -> Array:
        return self.U @ (self.V.T @ x)

    def toarray(self) -> Array:
        return self.U @ self.V.T


def woodbury_solver(factor_solve, low_rank: LowRank):
    """Solver of ``(A - U V^T) x = b`` given a solver of ``A`` (exact Woodbury identity).

    Costs r extra solves once (r = rank), then one solve and a small dense product per call.
    """
    AU = factor_solve(low_rank.U)
    AU = AU.reshape(low_rank.U.shape)
    cap = np.eye(low_rank.U.shape[1]) - low_rank.V.T @ AU
    cap_lu = np.linalg.inv(cap)

    def solve(b: Array) -> Array:
        y = factor_solve(b)
        return y + AU @ (cap_lu @ (low_rank.V.T @ y))

    return solve


def gmres_solver(A: sp.spmatrix, factor_solve, low_rank: LowRank | sp.spmatrix,
                 rtol: float = 1e-12, maxiter: int = 200):
    """Solver of ``(A - K_A) x = b`` by GMRES preconditioned with the factor of A (Eq. 5.45)."""
    n = A.shape[0]
    op = spla.LinearOperator((n, n), matvec=lambda x: A @ x - low_rank @ x, dtype=float)
    prec = spla.LinearOperator((n, n), matvec=factor_solve, dtype=float)

    def solve(b: Array) -> Array:
        x, info = spla.gmres(op, b, M=prec, rtol=rtol, atol=0.0, restart=min(n, 60),
                             maxiter=maxiter)
        if info != 0:
            raise RuntimeError(f"GMRES did not converge (info={info})")
        return x

    return solve


@dataclass(frozen=True)
class StabilityResult:
    """Eigenvalues of the LSA and their classification (Table 5.1).

    Attributes
    ----------
    lambda_p : ndarray of complex, shape (k,)
        Eigenvalues lambda_p with Im >= 0 (one of each conjugate pair), sorted by frequency.
    damping, frequency : ndarray of shape (k,)
        zeta = Re(lambda_p), omega = Im(lambda_p), rad/s (Eq. 5.37).
    status : {"stable", "neutral", "flutter", "divergence"}
        The worst mode's class.
    critical : int
        Index of the mode that decides ``status``.
    warm_start : bool
        The Arnoldi iteration started from a given vector (:func:`start_vector` of the
        modes of a nearby, e.g. the previous step's, problem) instead of a random one.
    """

    lambda_p: CArray
    damping: Array
    frequency: Array
    status: str
    critical: int
    warm_start: bool = False

    @property
    def unstable(self) -> bool:
        return self.status in ("flutter", "divergence")


def classify(lambda_p: CArray, rel_tol: float = COMPLEX_TOL) -> tuple[str, int]:
    """Table 5.1: flutter (zeta > 0, omega != 0), divergence (omega = 0 with zeta > 0),
    neutral (zeta = 0), stable (zeta < 0). Tolerances relative to |lambda_p|."""
    scale = np.maximum(np.abs(lambda_p), 1e-300)
    zeta, omega = lambda_p.real / scale, lambda_p.imag / scale
    divergence = (np.abs(omega) <= rel_tol) & (zeta > rel_tol)
    flutter = (np.abs(omega) > rel_tol) & (zeta > rel_tol)
    if np.any(divergence):
        i = int(np.argmax(np.where(divergence, lambda_p.real, -np.inf)))
        return "divergence", i
    if np.any(flutter):
        i = int(np.argmax(np.where(flutter, lambda_p.real, -np.inf)))
        return "flutter", i
    if np.any(zeta >= -rel_tol):
        return "neutral", int(np.argmax(lambda_p.real))
    return "stable", int(np.argmax(lambda_p.real))


def _from_lambda_g(lam_g: CArray) -> CArray:
    """lambda_p = sqrt(-lambda_g), the root with Re >= 0 (the unstable one of each pair)."""
    lam_p = np.sqrt(-lam_g.astype(complex))
    lam_p = np.where(lam_p.real < 0, -lam_p, lam_p)
    # a real positive lambda_g gives a neutral pair +-i omega: report Im >= 0
    return np.where(np.abs(lam_p.real) <= COMPLEX_TOL * np.abs(lam_p),
                    1j * np.abs(lam_p.imag), lam_p)


def _result(lam_p: CArray, warm_start: bool = False) -> StabilityResult:
    order = np.argsort(np.abs(lam_p.imag) + 1e-9 * np.abs(lam_p.real), kind="stable")
    lam_p = lam_p[order]
    status, crit = classify(lam_p)
    return StabilityResult(lambda_p=lam_p, damping=lam_p.real, frequency=lam_p.imag,
                           status=status, critical=crit, warm_start=warm_start)


def gep(K: sp.spmatrix, M: sp.spmatrix, K_A: sp.spmatrix | LowRank | None = None,
        count: int = 6, sigma: float | None = None, solver: str = "direct",
        free: NDArray[np.intp] | None = None, rng: np.random.Generator | int | None = 0,
        on_factor=None) -> StabilityResult:
    """LSA by the GEP ``(K - K_A) u = lambda_g M u`` (Eq. 5.35), eigenvalues nearest ``sigma``.

    Parameters
    ----------
    K, M : sparse (n, n)
        Tangent stiffness (symmetric) and mass at the quasi-steady state.
    K_A : sparse, LowRank or None
        Aerodynamic stiffness dF_S/du (Eq. 5.34).
    count : int
        Number of eigenvalues.
    sigma : float, optional
        Shift (rad^2/s^2); default a tiny negative multiple of the spectrum scale so the
        shifted matrix stays regular at a bifurcation.
    solver : {"direct", "woodbury", "gmres"}
        Shifted solves: sparse LU of K - K_A - sigma M, or the structural factor of
        K - sigma M with a Woodbury update / preconditioned GMRES for a low-rank K_A.
    free : ndarray of int, optional
        DOFs kept (the rest are constrained and removed); default all.
    on_factor : callable, optional
        Receives the sparse LU of the shifted matrix (direct solver), so a caller can reuse
        it (e.g. as a preconditioner of the next Newton solves).
    """
    if free is not None:
        K = K[free][:, free]
        M = M[free][:, free]
        if isinstance(K_A, LowRank):
            K_A = LowRank(K_A.U[free], K_A.V[free])
        elif K_A is not None:
            K_A = sp.csr_matrix(K_A)[free][:, free]
    if sigma is None:
        scale = float(np.mean(np.abs(K.diagonal()) / np.maximum(np.abs(M.diagonal()), 1e-300)))
        sigma = -1e-9 * scale
    shifted = (K - sigma * M).tocsc()
    if K_A is None or solver == "direct":
        A = shifted if K_A is None else (shifted - (sp.csc_matrix(K_A.toarray()) if isinstance(
            K_A, LowRank) else sp.csc_matrix(K_A))).tocsc()
        lu = spla.splu(A)
        solve = lu.solve
        if on_factor is not None:
            on_factor(lu)
    else:
        lu = spla.splu(shifted)
        if solver == "woodbury":
            if not isinstance(K_A, LowRank):
                raise ValueError("the Woodbury solver needs a LowRank K_A")
            solve = woodbury_solver(lu.solve, K_A)
        elif solver == "gmres":
            solve = gmres_solver(shifted, lu.solve, K_A)
        else:
            raise ValueError(f"unknown solver {solver!r}")
    return shift_invert_gep(solve, M, sigma, count, rng)


def shift_invert_gep(solve, M: sp.spmatrix, sigma: float, count: int = 6,
                     rng: np.random.Generator | int | None = 0,
                     ncv: int | None = None, v0: Array | None = None,
                     on_vectors: Callable[[CArray], None] | None = None) -> StabilityResult:
    """The ARPACK part of :func:`gep`: eigenvalues of ``(K - K_A) u = lambda_g M u`` nearest
    ``sigma`` given ``solve``, a solver of ``(K - K_A - sigma M) x = b`` (Eq. 5.36).

    ``ncv``: Arnoldi vectors (ARPACK default ``max(2 k + 1, 20)``). ``v0``: Arnoldi start
    vector (default random from ``rng``); :func:`start_vector` of the eigenvectors of a
    nearby problem saves about a fifth of the shifted solves. ``on_vectors``: receives the
    eigenvectors, complex (n, k) (then computed; the eigenvalues are the same to ARPACK's
    tolerance either way)."""
    n = M.shape[0]
    op = spla.LinearOperator((n, n), matvec=lambda x: solve(M @ x), dtype=float)
    k = min(count, n - 2)
    warm = v0 is not None and v0.shape == (n,) and bool(np.any(v0))
    if not warm:
        v0 = np.random.default_rng(rng).standard_normal(n)
    if ncv is not None:
        ncv = min(max(ncv, 2 * k + 1), n)
    # one BLAS thread: ARPACK's dense work is small, and with OpenBLAS threads on a busy
    # machine the eigenvector extraction alone took 50 ms instead of 1 ms (measured)
    with single_threaded_blas():
        if on_vectors is None:
            mu = spla.eigs(op, k=k, which="LM", v0=v0, return_eigenvectors=False, tol=1e-12,
                           ncv=ncv)
        else:
            mu, vectors = spla.eigs(op, k=k, which="LM", v0=v0, return_eigenvectors=True,
                                    tol=1e-12, ncv=ncv)
            on_vectors(vectors)
    lam_g = sigma + 1.0 / mu  # spectral transformation, Eq. (5.36)
    return _result(_from_lambda_g(lam_g), warm_start=warm)


def start_vector(vectors: CArray) -> Array:
    """An Arnoldi start vector for the next of a sequence of nearby eigenproblems: the sum
    of the real and imaginary parts of the (normalized) eigenvectors ``vectors`` (n, k)
    wanted last time -- a vector in their invariant subspace with a component along each.
    """
    V = vectors / np.maximum(np.linalg.norm(vectors, axis=0), 1e-300)
    return np.sum(V.real + V.imag, axis=1)


def pep(K: sp.spmatrix, M: sp.spmatrix, C: sp.spmatrix | None = None,
        K_A: sp.spmatrix | None = None, C_A: sp.spmatrix | None = None, count: int = 6,
        sigma: complex | None = None, free: NDArray[np.intp] | None = None,
        rng: np.random.Generator | int | None = 0) -> StabilityResult:
    """LSA by the PEP (Eq. 5.33), linearized to first order and solved by shift-invert.

    With ``x = [u, lambda u]``: ``A x = lambda B x``, ``A = [[0, I], [-(K-K_A), -(C-C_A)]]``,
    ``B = diag(I, M)``. The shifted solve reduces to ``(K-K_A) + s (C-C_A) + s^2 M``.
    """
    if free is not None:
        def sub(A):
            return None if A is None else sp.csr_matrix(A)[free][:, free]
        K, M, C, K_A, C_A = (sub(A) for A in (K, M, C, K_A, C_A))
    n = K.shape[0]
    Keff = sp.csr_matrix(K) - (sp.csr_matrix(K_A) if K_A is not None else 0)
    Ceff = (sp.csr_matrix(C) if C is not None else sp.csr_matrix((n, n))) - (
        sp.csr_matrix(C_A) if C_A is not None else 0)
    if sigma is None:
        scale = float(np.mean(np.abs(K.diagonal()) / np.maximum(np.abs(M.diagonal()), 1e-300)))
        sigma = -1e-5 * np.sqrt(scale)
    s = complex(sigma)
    P = (Keff + s * Ceff + s * s * M).astype(complex).tocsc()
    lu = spla.splu(P)

    def matvec(x: CArray) -> CArray:
        # (A - s B)^-1 B x with x = [a; b]: solve [[-sI, I], [-Keff, -Ceff - sM]] y = [a; M b]
        a, b = x[:n], x[n:]
        rhs = M @ b
        # from row 1: y2 = a + s y1; row 2: -Keff y1 - (Ceff + s M)(a + s y1) = M b
        y1 = lu.solve(-(rhs + Ceff @ a + s * (M @ a)))
        return np.concatenate([y1, a + s * y1])

    op = spla.LinearOperator((2 * n, 2 * n), matvec=matvec, dtype=complex)
    gen = np.random.default_rng(rng)
    k = min(2 * count, 2 * n - 2)
    mu = spla.eigs(op, k=k, which="LM", v0=gen.standard_normal(2 * n).astype(complex),
                   return_eigenvectors=False, tol=1e-12)
    lam_p = s + 1.0 / mu
    keep = lam_p.imag >= -COMPLEX_TOL * np.abs(lam_p)  # one of each conjugate pair
    lam_p = lam_p[keep]
    # complex conjugate duplicates of real roots may both survive: keep unique
    lam_p = lam_p[np.argsort(np.abs(lam_p), kind="stable")][:count]
    return _result(lam_p)
