"""Sparse factorizations for the structural solver (the hot path of the simulator).

Two back ends for matrices that share one CSR sparsity pattern (the assembled shell
matrices):

* ``"banded"``: reverse Cuthill-McKee ordering (computed once per pattern) + LAPACK banded
  Cholesky (``scipy.linalg.cholesky_banded``) -- symmetric positive definite matrices only;
  the band is filled by a precomputed index map, so a refactorization costs only the
  factorization itself.
* ``"splu"``: SuperLU with a column ordering ``permc_spec`` (any nonsingular matrix).

``"auto"`` (default) tries the banded Cholesky and falls back to SuperLU when the matrix is
not positive definite (e.g. a tangent past a bifurcation); the returned factor tells which
happened (:attr:`Factor.positive_definite`). ``hypate bench structure`` measures the choices.
"""
from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from hypate.solvers.numerics.threads import single_threaded_blas
from numpy.typing import NDArray
from scipy.sparse.csgraph import reverse_cuthill_mckee

Array = NDArray[np.float64]

#: SuperLU column ordering used by the fallback (fastest measured on shell tangents).
DEFAULT_PERMC = "MMD_AT_PLUS_A"


@dataclass
class Factor:
    """A factorization of one matrix; ``solve(b)`` for b of shape (n,) or (n, k)."""

    method: str
    positive_definite: bool | None
    _solve: object = field(repr=False)

    def solve(self, b: Array) -> Array:
        return self._solve(b)  # type: ignore[operator]

    def __call__(self, b: Array) -> Array:
        return self.solve(b)


class PatternSolver:
    """Factorizations of matrices sharing the CSR pattern of ``pattern``.

    Parameters
    ----------
    pattern : scipy.sparse.csr_matrix of shape (n, n)
        Symmetric structure with sorted indices (only indptr/indices are used).
    method : {"auto", "banded", "splu"}
    permc_spec : str
        SuperLU column ordering for ``"splu"`` and the fallback.
    orderings : sequence of ndarray of shape (n,), optional
        Candidate permutations for the banded back end besides reverse Cuthill-McKee
        (e.g. the natural grid orderings); the one with the smallest bandwidth is used.
    """

    def __init__(self, pattern: sp.csr_matrix, method: str = "auto",
                 permc_spec: str = DEFAULT_PERMC,
                 orderings: Sequence[Array] | None = None) -> None:
        if method not in ("auto", "banded", "splu"):
            raise ValueError(f"unknown factorization method {method!r}")
        self.method = method
        self.permc_spec = permc_spec
        self.indptr = pattern.indptr
        self.indices = pattern.indices
        self.n = pattern.shape[0]
        self._band: tuple[Array, Array, Array, int] | None = None
        self._orderings = list(orderings) if orderings is not None else []

    def _band_map(self) -> tuple[Array, Array, Array, int]:
        """Best ordering (smallest bandwidth), CSR->band index maps and the bandwidth."""
        if self._band is None:
            n = self.n
            pat = sp.csr_matrix((np.ones(self.indices.size), self.indices, self.indptr),
                                shape=(n, n))
            rows = np.repeat(np.arange(n), np.diff(self.indptr))
            cands = [reverse_cuthill_mckee(pat, symmetric_mode=True).astype(np.int64)]
            cands += [np.asarray(o, dtype=np.int64) for o in self._orderings]
            best = None
            for perm in cands:
                iperm = np.empty(n, dtype=np.int64)
                iperm[perm] = np.arange(n)
                bw = int(np.max(np.abs(iperm[rows] - iperm[self.indices]))) if rows.size else 0
                if best is None or bw < best[1]:
                    best = (perm, bw, iperm)
            assert best is not None
            perm, bw, iperm = best
            pi, pj = iperm[rows], iperm[self.indices]
            lower = pi >= pj
            src = np.flatnonzero(lower)
            # Fortran-ordered (bw + 1, n) lower band storage: ab[i - j, j] = A[i, j]
            dest = (pi[lower] - pj[lower]) + pj[lower] * (bw + 1)
            self._band = (perm, src, dest, bw)
        return self._band

    @property
    def bandwidth(self) -> int:
        """Lower bandwidth after RCM ordering."""
        return self._band_map()[3]

    def banded(self, data: Array) -> Factor:
        """Banded Cholesky of the matrix with CSR values ``data``.

        Raises
        ------
        numpy.linalg.LinAlgError
            If the matrix is not positive definite.
        """
        perm, src, dest, bw = self._band_map()
        n = self.n
        ab = np.zeros((bw + 1) * n)
        ab[dest] = data[src]
        with single_threaded_blas():
            c = sla.cholesky_banded(ab.reshape((bw + 1, n), order="F"), lower=True,
                                    overwrite_ab=True, check_finite=False)

        def solve(b: Array) -> Array:
            b = np.asarray(b, dtype=float)
            x = np.empty_like(b)
            with single_threaded_blas():
                x[perm] = sla.cho_solve_banded((c, True), b[perm], check_finite=False)
            return x

        return Factor("banded", True, solve)

    def splu(self, data: Array, permc_spec: str | None = None,
             symmetric: bool = True) -> Factor:
        """SuperLU factorization of the matrix with CSR values ``data``.

        ``symmetric``: SuperLU's symmetric mode (diagonal pivots preferred, threshold
        1e-3), about 50x faster than the default partial pivoting with
        ``MMD_AT_PLUS_A`` on shell tangents (measured by ``hypate bench structure``).
        """
        A = sp.csc_matrix(sp.csr_matrix((data, self.indices, self.indptr),
                                        shape=(self.n, self.n)))
        spec = permc_spec or self.permc_spec
        if symmetric:
            lu = spla.splu(A, permc_spec=spec, diag_pivot_thresh=1e-3,
                           options={"SymmetricMode": True})
        else:
            lu = spla.splu(A, permc_spec=spec)
        return Factor(f"splu:{spec}" + (":symmetric" if symmetric else ""), None, lu.solve)

    def factor(self, K: sp.csr_matrix | Array) -> Factor:
        """Factorize ``K`` (a CSR matrix with this pattern, or its ``data`` array)."""
        data = K.data if sp.issparse(K) else np.asarray(K)
        if self.method == "splu":
            return self.splu(data)
        try:
            return self.banded(data)
        except np.linalg.LinAlgError:
            if self.method == "banded":
                raise
            f = self.splu(data)
            f.positive_definite = False
            return f


def is_positive_definite(solver: PatternSolver, K: sp.csr_matrix) -> bool:
    """True when the banded Cholesky of ``K`` succeeds."""
    try:
        solver.banded(K.data)
    except np.linalg.LinAlgError:
        return False
    return True


def gmres(matvec: Callable[[Array], Array], psolve: Callable[[Array], Array], b: Array,
          rtol: float, max_iter: int) -> tuple[Array, float, int]:
    """Right-preconditioned GMRES from ``x = 0`` without restarts, for a few iterations with
    a good preconditioner (a factor of a nearby matrix, Eq. 5.45).

    Solves ``A x = b`` by minimizing ``||b - A P^-1 y||`` over the Krylov space of
    ``A P^-1`` and ``x = P^-1 y``; the residual is the true one (not preconditioned).
    Classical Gram-Schmidt with one reorthogonalization (two matrix products per step,
    orthogonal to round-off), Givens rotations for the small least-squares problem.

    Parameters
    ----------
    matvec, psolve : callable
        ``A @ x`` and ``P^-1 @ x``.
    b : ndarray of shape (n,)
    rtol : float
        Stop once the (recurrence) residual norm is <= ``rtol ||b||``.
    max_iter : int

    Returns
    -------
    x, residual estimate relative to ``||b||``, iterations
    """
    b = np.asarray(b, dtype=float)
    beta = float(np.linalg.norm(b))
    if beta == 0.0:
        return np.zeros_like(b), 0.0, 0
    m = int(max_iter)
    V = np.empty((m + 1, b.size))
    Z = np.empty((m, b.size))
    R = np.zeros((m, m))              # the triangularized Hessenberg matrix
    cs, sn = np.zeros(m), np.zeros(m)
    g = np.zeros(m + 1)
    g[0] = beta
    V[0] = b / beta
    k = 0
    for j in range(m):
        Z[j] = psolve(V[j])
        w = matvec(Z[j])
        Vj = V[: j + 1]
        h = Vj @ w
        w = w - h @ Vj
        h2 = Vj @ w
        w -= h2 @ Vj
        h += h2
        hn = float(np.linalg.norm(w))
        for i in range(j):  # previous rotations on the new column (j <= max_iter scalars)
            h[i], h[i + 1] = cs[i] * h[i] + sn[i] * h[i + 1], -sn[i] * h[i] + cs[i] * h[i + 1]
        d = math.hypot(float(h[j]), hn)
        cs[j], sn[j] = (1.0, 0.0) if d == 0.0 else (h[j] / d, hn / d)
        h[j] = d
        R[: j + 1, j] = h
        g[j + 1] = -sn[j] * g[j]
        g[j] = cs[j] * g[j]
        k = j + 1
        if abs(g[k]) <= rtol * beta or hn == 0.0:
            break
        V[k] = w / hn
    y = sla.solve_triangular(R[:k, :k], g[:k], check_finite=False)
    return y @ Z[:k], abs(float(g[k])) / beta, k
