"""The aeroelastic Newton step's linear algebra (Eq. 5.42) and its failure.

:func:`solve_free_block` solves ``(K - K_A)_ff x = b`` on the free DOFs: GMRES
preconditioned by the factor of a nearby matrix (the LSA's factor of the previous step),
else a fresh sparse LU; :func:`gmres_on_factor` is that GMRES on its own (the pointwise
path of :class:`hypate.solvers.coupling.model.PanelModel` builds the block by index maps
and calls it directly); :func:`scaled_operator` scales a matrix-free aerodynamic
stiffness (a ROM, Eq. 5.43) by the load factor. :class:`EquilibriumError` is raised when
the static aeroelastic equilibrium (Eq. 5.31b) is not found.
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from hypate.solvers.numerics.sparse import gmres
from numpy.typing import NDArray

Array = NDArray[np.float64]


class EquilibriumError(RuntimeError):
    """The static aeroelastic equilibrium did not converge (e.g. past a snap-through)."""


def solve_free_block(K: sp.csr_matrix, K_A: sp.spmatrix | spla.LinearOperator, b: Array,
                     free: NDArray[np.intp], precond=None,
                     on_factor: Callable[[spla.SuperLU], None] | None = None) -> Array:
    """Solve ``(K - K_A)_ff x = b`` on the free DOFs: the Newton step of the aeroelastic
    equilibrium (Eq. 5.42).

    GMRES preconditioned by ``precond``, the factor of a nearby Jacobian (the LSA's factor
    of the previous step, Eqs. 5.44-5.45 with a better preconditioner than K alone), when
    it reaches 1e-6 relative in at most 20 iterations; otherwise the current matrix is
    factorized (sparse LU) and handed to ``on_factor`` (the caller keeps it as the next
    preconditioner). A low-rank/operator ``K_A`` (a ROM, Eq. 5.43) is applied matrix-free:
    the factor is then of ``K_ff`` alone and preconditions GMRES on ``K - K_A``.

    Parameters
    ----------
    K : csr_matrix of shape (n_dof, n_dof)
        Structural tangent (N/m).
    K_A : sparse matrix or LinearOperator of shape (n_dof, n_dof)
        Aerodynamic stiffness (N/m), already scaled by the load factor.
    b : ndarray of shape (n_free,)
        Right-hand side on the free DOFs (N).
    free : ndarray of int, shape (n_free,)
        The free DOFs (``StructuralModel.free_dofs``).
    precond : object with ``solve(b)`` and ``shape``, optional
        The factor of a nearby matrix on the same free DOFs; ``None``: factorize.
    on_factor : callable, optional
        Receives each new factorization.

    Returns
    -------
    ndarray of shape (n_free,)

    Raises
    ------
    EquilibriumError
        GMRES on a matrix-free ``K_A`` did not converge.
    """
    Kff = K[free][:, free]
    if sp.issparse(K_A):
        A = (Kff - K_A[free][:, free]).tocsc()
        matvec = A.__matmul__
    else:
        A = Kff.tocsc()
        n_all = K.shape[0]

        def matvec(x: Array) -> Array:
            full = np.zeros(n_all)
            full[free] = x
            return Kff @ x - (K_A @ full)[free]
    x = gmres_on_factor(matvec, precond, b)
    if x is not None:
        return x
    lu = spla.splu(A)
    if on_factor is not None:
        on_factor(lu)
    if sp.issparse(K_A):
        return lu.solve(b)
    n = b.size
    x, info = spla.gmres(spla.LinearOperator((n, n), matvec=matvec, dtype=float), b,
                         M=spla.LinearOperator((n, n), matvec=lu.solve, dtype=float),
                         rtol=1e-11, atol=0.0, restart=80, maxiter=3)
    if info != 0:
        raise EquilibriumError("GMRES for the aeroelastic Newton step did not converge")
    return x


def gmres_on_factor(matvec: Callable[[Array], Array], precond, b: Array) -> Array | None:
    """GMRES preconditioned by the kept factor ``precond`` (an object with ``solve`` and
    ``shape``; at most 20 iterations of :func:`hypate.solvers.numerics.sparse.gmres`) on the
    matrix applied by ``matvec``; None when the factor is missing or too weak."""
    if precond is None or precond.shape[0] != b.size:
        return None
    # (a hand-rolled GMRES: scipy's costs 0.1 ms per iteration more in Python overhead,
    # a third of each iteration here)
    x, _, _ = gmres(matvec, precond.solve, b, rtol=1e-11, max_iter=20)
    # an inexact Newton step is enough: accept 1e-6 relative (GMRES may stagnate near
    # 1e-8 on these badly scaled shell systems)
    if np.linalg.norm(matvec(x) - b) <= 1e-6 * np.linalg.norm(b):
        return x
    return None


def scaled_operator(op: spla.LinearOperator, factor: float) -> spla.LinearOperator:
    """``factor * op`` as an operator (a matrix-free K_A times the load factor)."""
    return spla.LinearOperator(op.shape, matvec=lambda x: factor * (op @ x), dtype=float)


