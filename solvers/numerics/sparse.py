"""Sparse linear algebra of the simulator (its hot path): factorizations with pattern reuse.

Matrices that share one CSR sparsity pattern (the assembled shell matrices) are factored by

* :class:`PatternSolver` (structure): ``"banded"`` -- reverse Cuthill-McKee ordering
  (computed once per pattern) + LAPACK banded Cholesky (``scipy.linalg.cholesky_banded``),
  symmetric positive definite matrices only, the band filled by a precomputed index map so a
  refactorization costs only the factorization itself; ``"splu"`` -- SuperLU with a column
  ordering ``permc_spec`` (any nonsingular matrix). ``"auto"`` (default) tries the banded
  Cholesky and falls back to SuperLU when the matrix is not positive definite (e.g. a
  tangent past a bifurcation); the returned factor tells which happened
  (:attr:`Factor.positive_definite`). ``hypate bench structure`` measures the choices.
* :class:`FreePattern` (coupled solvers): the free-DOF block of a structurally symmetric
  pattern by index maps, factored by SuperLU's symmetric mode on the block pre-permuted by
  its minimum-degree ordering (computed once), with a check solve and a fallback
  (:class:`PermutedLU`) -- the nonsymmetric ``K - K_A`` of the aeroelastic Newton and LSA.

Both use the one set of SuperLU symmetric-mode options, :func:`splu_symmetric`. Besides:
:func:`triple_product_operator` (the data of ``L diag(d) R`` on a fixed pattern as one
sparse mat-vec), :class:`DeferredMatrix` (a matrix formed on first use) and a small
right-preconditioned :func:`gmres`.
"""
from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import cast

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from hypate.solvers.numerics.banded import Factorization
from hypate.solvers.numerics.threads import single_threaded_blas
from numpy.typing import NDArray
from scipy.sparse.csgraph import reverse_cuthill_mckee

Array = NDArray[np.float64]
IndexArray = NDArray[np.integer]

#: SuperLU column ordering used by the fallback (fastest measured on shell tangents).
DEFAULT_PERMC = "MMD_AT_PLUS_A"


@dataclass
class Factor(Factorization):
    """A factorization of one matrix (the :class:`~hypate.solvers.numerics.banded.Factorization`
    interface, as the thermal solver's banded factors): ``solve(b)`` for b of shape (n,) or
    (n, k); ``method`` says which kernel made it."""

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
                 orderings: Sequence[IndexArray] | None = None) -> None:
        if method not in ("auto", "banded", "splu"):
            raise ValueError(f"unknown factorization method {method!r}")
        self.method = method
        self.permc_spec = permc_spec
        self.indptr = pattern.indptr
        self.indices = pattern.indices
        self.n = pattern.shape[0]
        self._band: tuple[IndexArray, IndexArray, IndexArray, int] | None = None
        self._orderings = list(orderings) if orderings is not None else []

    def _band_map(self) -> tuple[IndexArray, IndexArray, IndexArray, int]:
        """Best ordering (smallest bandwidth), CSR->band index maps and the bandwidth."""
        if self._band is None:
            n = self.n
            pat = sp.csr_matrix((np.ones(self.indices.size), self.indices, self.indptr),
                                shape=(n, n))
            rows = csr_rows(self.indptr)
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
            lu = splu_symmetric(A, spec)
        else:
            lu = spla.splu(A, permc_spec=spec)
        return Factor(f"splu:{spec}" + (":symmetric" if symmetric else ""), None, lu.solve)

    def factor(self, K: sp.csr_matrix | Array) -> Factor:
        """Factorize ``K`` (a CSR matrix with this pattern, or its ``data`` array)."""
        # (scipy has no types: issparse does not narrow K)
        data = cast(Array, K.data) if sp.issparse(K) else np.asarray(K)
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


def splu_symmetric(A: sp.csc_matrix, permc_spec: str) -> spla.SuperLU:
    """SuperLU in its symmetric mode: diagonal pivots preferred (threshold 1e-3), column
    ordering ``permc_spec`` applied symmetrically -- for structurally symmetric, nearly
    symmetric matrices (shell tangents, ``K - K_A``), about 50x faster than the default
    partial pivoting with ``MMD_AT_PLUS_A`` on shell tangents (``hypate bench structure``).

    Raises
    ------
    RuntimeError
        If SuperLU finds the matrix (numerically) singular.
    """
    return spla.splu(A, permc_spec=permc_spec, diag_pivot_thresh=1e-3,
                     options={"SymmetricMode": True})


# -- fixed-pattern products -----------------------------------------------------------
def csr_rows(indptr: NDArray[np.integer]) -> NDArray[np.int64]:
    """The row index of every stored entry of a CSR pattern, in storage order."""
    return np.repeat(np.arange(indptr.size - 1, dtype=np.int64), np.diff(indptr))


def _pattern_keys(indptr: NDArray[np.integer], indices: NDArray[np.integer],
                  n_cols: int) -> NDArray[np.int64]:
    """``row * n_cols + column`` of every stored entry (sorted for sorted indices)."""
    return csr_rows(indptr) * n_cols + indices.astype(np.int64)


def triple_product_operator(L: sp.spmatrix, R: sp.spmatrix,
                            pattern: tuple[NDArray, NDArray] | None = None
                            ) -> tuple[sp.csr_matrix, NDArray, NDArray]:
    """The linear map ``d -> data of L diag(d) R`` on a fixed CSR pattern.

    ``L`` is (m, n_f), ``R`` (n_f, k). Returns ``(T, indptr, indices)`` with ``T`` sparse of
    shape (nnz, n_f), so ``csr_matrix((T @ d, indices, indptr), (m, k))`` equals
    ``L @ diag(d) @ R`` (up to round-off: the products are summed in another order). The
    pattern is ``pattern = (indptr, indices)`` when given (it must contain every entry of
    the product), else the product's own. The data of a pointwise aerodynamic Jacobian
    transferred to the structure is linear in the pointwise derivatives, so it costs one
    sparse mat-vec instead of two sparse matrix products per evaluation.
    """
    Lc = sp.coo_matrix(L)
    Rr = sp.csr_matrix(R)
    Rr.sort_indices()
    m, k = Lc.shape[0], Rr.shape[1]
    counts = np.diff(Rr.indptr)[Lc.col]
    rep = np.repeat(np.arange(Lc.nnz), counts)
    start = np.repeat(Rr.indptr[Lc.col], counts)
    offs = np.arange(rep.size) - np.repeat(np.cumsum(counts) - counts, counts)
    ridx = start + offs
    keys = Lc.row[rep].astype(np.int64) * k + Rr.indices[ridx].astype(np.int64)
    vals = Lc.data[rep] * Rr.data[ridx]
    f = Lc.col[rep]
    if pattern is None:
        uniq = np.unique(keys)
        rows = uniq // k
        indices = (uniq % k).astype(np.int32)
        indptr = np.concatenate([[0], np.cumsum(np.bincount(rows, minlength=m))]).astype(
            np.int32)
        pkeys = uniq
    else:
        indptr, indices = pattern
        pkeys = _pattern_keys(indptr, indices, k)
    pos = np.minimum(np.searchsorted(pkeys, keys), pkeys.size - 1)
    if not np.all(pkeys[pos] == keys):
        raise ValueError("the product has entries outside the given pattern")
    T = sp.csr_matrix((vals, (pos, f)), shape=(pkeys.size, Lc.shape[1]))
    T.sum_duplicates()
    return T, indptr, indices


# -- the free-DOF block of the coupled solvers -----------------------------------------
class FreePattern:
    """The free-DOF block of matrices on the structural CSR pattern, by index maps.

    ``sel`` picks the free-free entries (in CSR order of the block), ``tpos`` reorders the
    block's CSR data into CSC data (the pattern is structurally symmetric), so
    ``A[free][:, free]`` in CSR or CSC costs one gather; ``diag`` picks the block's
    diagonal from its CSR data.
    """

    def __init__(self, indptr: NDArray, indices: NDArray, n: int, free: NDArray) -> None:
        newpos = np.full(n, -1, dtype=np.int64)
        newpos[free] = np.arange(free.size)
        rows = csr_rows(indptr)
        r, c = newpos[rows], newpos[indices]
        keep = (r >= 0) & (c >= 0)
        self.sel = np.flatnonzero(keep)
        r, c = r[keep], c[keep]
        self.n = int(free.size)
        self.indices = c.astype(np.int32)
        self.indptr = np.concatenate([[0], np.cumsum(np.bincount(r, minlength=self.n))]
                                     ).astype(np.int32)
        keys = r * self.n + c
        tkeys = c * self.n + r
        self.tpos = np.searchsorted(keys, tkeys)
        self.diag = np.flatnonzero(r == c)  # the diagonal entries, in row order
        if not np.array_equal(keys[self.tpos], tkeys):
            raise ValueError("the structural pattern is not structurally symmetric")
        self._perm: tuple[NDArray, NDArray, NDArray, NDArray] | None = None

    def csc_from_block(self, block: Array) -> sp.csc_matrix:
        """CSC of the block with CSR data ``block``: column j holds the entries (i, j), and
        with the symmetric pattern its row indices are the CSR column indices of row j."""
        return sp.csc_matrix((block[self.tpos], self.indices, self.indptr),
                             shape=(self.n, self.n))

    def _ordering(self) -> tuple[NDArray, NDArray, NDArray, NDArray]:
        """The minimum-degree ordering of ``A^T + A`` (SuperLU's ``MMD_AT_PLUS_A``) and the
        CSC pattern of the permuted block ``A[p][:, p]`` with the gather map from the
        block's CSR data, computed once (the ordering depends on the pattern only)."""
        if self._perm is None:
            n, nnz = self.n, self.indices.size
            # a diagonally dominant matrix on the pattern: no pivoting, so perm_c is MMD's
            ones = self.csc_from_block(np.ones(nnz)) + n * sp.identity(n, format="csc")
            perm_c = splu_symmetric(ones.tocsc(), "MMD_AT_PLUS_A").perm_c
            p = np.argsort(perm_c, kind="stable")  # perm_c[old] = new, p[new] = old
            # entry positions (1-based: no entry may vanish) carried through the permutation
            pos = sp.csr_matrix((np.arange(1.0, nnz + 1.0), self.indices, self.indptr),
                                shape=(n, n))
            P = pos[p][:, p].tocsc()
            P.sort_indices()
            self._perm = (p, P.data.astype(np.int64) - 1, P.indices, P.indptr)
        return self._perm

    def factor(self, block: Array) -> PermutedLU | spla.SuperLU:
        """Sparse LU of the block with CSR data ``block`` (e.g. ``(K - K_A (- sigma M))_ff``).

        :func:`splu_symmetric` with the minimum-degree ordering of ``A^T + A`` -- the
        pattern is structurally symmetric and the matrix close to symmetric: 3 ms and 2.5x
        fewer nonzeros than the default COLAMD with partial pivoting (8 ms) on the 8 x 8
        shell (measured) -- applied beforehand, so SuperLU skips its ordering (``NATURAL``):
        the same factor as ``splu_symmetric(A, "MMD_AT_PLUS_A")``, 20 % faster (measured).
        The factor is checked on one solve (relative residual <= 1e-10); when the symmetric
        mode reports a singular factor or fails the check (a pivot the threshold let
        through), the default LU is used. Returns an object with ``solve`` and ``shape``.
        """
        p, gather, indices, indptr = self._ordering()
        B = sp.csc_matrix((block[gather], indices, indptr), shape=(self.n, self.n))
        try:
            lu = PermutedLU(splu_symmetric(B, "NATURAL"), p)
        except RuntimeError:
            return spla.splu(self.csc_from_block(block))
        A = sp.csr_matrix((block, self.indices, self.indptr), shape=(self.n, self.n))
        if _factor_ok(lu, A):
            return lu
        return spla.splu(self.csc_from_block(block))


class PermutedLU:
    """A sparse LU ``lu`` of ``A[p][:, p]`` used as a solver of ``A``: ``A x = b`` is
    ``(A[p][:, p]) x[p] = b[p]``."""

    def __init__(self, lu: spla.SuperLU, p: NDArray) -> None:
        self.lu, self.p = lu, p
        self.shape = lu.shape

    def solve(self, b: Array) -> Array:
        x = np.empty_like(b, dtype=float)
        x[self.p] = self.lu.solve(np.asarray(b, dtype=float)[self.p])
        return x


def _factor_ok(lu: PermutedLU | spla.SuperLU, A: sp.spmatrix) -> bool:
    """One check solve (relative residual <= 1e-10): catches a pivot the symmetric mode's
    threshold let through."""
    b = np.cos(np.arange(A.shape[0], dtype=float))  # a fixed, nowhere-special vector
    x = lu.solve(b)
    return bool(np.all(np.isfinite(x))
                and np.linalg.norm(A @ x - b) <= 1e-10 * np.linalg.norm(b))


# -- lazy matrices and Krylov ---------------------------------------------------------
class DeferredMatrix:
    """A sparse matrix formed on first use: calling it returns the matrix, built once (the
    thermal Newton resolves a flux derivative only when it needs the Jacobian); ``@``,
    ``toarray()`` and ``tocsr()`` act on the matrix."""

    def __init__(self, build: Callable[[], sp.csr_matrix], shape: tuple[int, int]) -> None:
        self._build = build
        self._matrix: sp.csr_matrix | None = None
        self.shape = shape

    def __call__(self) -> sp.csr_matrix:
        if self._matrix is None:
            self._matrix = self._build()
        return self._matrix

    def __matmul__(self, x: Array) -> Array:
        return self() @ x

    def toarray(self) -> Array:
        return self().toarray()

    def tocsr(self) -> sp.csr_matrix:
        return self()


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
