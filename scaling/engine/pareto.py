"""Pareto dominance, hypervolume and the box decomposition of the non-dominated region.

All objectives are minimized. The hypervolume ``H`` of a set (Fig. 6.3) is the measure of
the region dominated by the set and bounded by a reference point; the hypervolume
improvement of a new point is Eq. (6.23). Exact in 2-D by a sweep; for more objectives
:func:`hypervolume` calls pymoo.

The non-dominated region below the reference point is decomposed into disjoint boxes
``[lower_c, upper_c]`` (lower bounds may be ``-inf``). The hypervolume improvement of a
point ``y`` is then ``sum_c prod_j (upper_cj - max(lower_cj, y_j))^+``, which the
hypervolume acquisitions (Eqs. (6.25)-(6.28)) integrate in closed form. In 2-D the
decomposition is the ``k + 1`` vertical strips of the staircase; for more objectives the
grid spanned by the Pareto coordinates is used (``(k + 1)^m`` cells, merged nothing).
"""
from __future__ import annotations

import numpy as np
from pymoo.indicators.hv import HV

__all__ = [
    "dominates",
    "non_dominated_mask",
    "pareto_front",
    "pareto_order",
    "hypervolume",
    "hypervolume_2d",
    "nondominated_boxes",
    "hypervolume_improvement",
]


def dominates(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a`` Pareto-dominates ``b`` (no worse everywhere, better somewhere); broadcasts
    over leading axes of arrays of shape (..., m)."""
    return np.all(a <= b, axis=-1) & np.any(a < b, axis=-1)


def non_dominated_mask(F: np.ndarray) -> np.ndarray:
    """Mask of the non-dominated rows of ``F`` (duplicates are all kept).

    Parameters
    ----------
    F : ndarray of shape (n, m)

    Returns
    -------
    ndarray of bool, shape (n,)
    """
    F = np.asarray(F, dtype=float)
    n = F.shape[0]
    if n == 0:
        return np.zeros(0, dtype=bool)
    if F.shape[1] == 2:
        # sweep: in lexicographic order, a point is dominated iff an earlier *distinct*
        # point has f2 <= its f2 (O(n log n), duplicates kept)
        order = np.lexsort((F[:, 1], F[:, 0]))
        Fs = F[order]
        new = np.r_[True, np.any(np.diff(Fs, axis=0) != 0, axis=1)]
        group = np.cumsum(new) - 1
        before = np.r_[np.inf, np.minimum.accumulate(Fs[new, 1])[:-1]]
        mask = np.empty(n, dtype=bool)
        mask[order] = ~(before[group] <= Fs[:, 1])
        return mask
    mask = np.ones(n, dtype=bool)
    for start in range(0, n, 512):  # blocks bound the (n, block, m) comparison
        blk = F[start:start + 512]
        mask[start:start + 512] = ~np.any(dominates(F[:, None, :], blk[None, :, :]), axis=0)
    return mask


def pareto_front(F: np.ndarray, *, unique: bool = True) -> np.ndarray:
    """Non-dominated rows of ``F``, sorted by the first objective.

    Parameters
    ----------
    F : ndarray of shape (n, m)
    unique : bool
        Drop duplicate rows.
    """
    F = np.atleast_2d(np.asarray(F, dtype=float))
    P = F[non_dominated_mask(F)]
    if unique and len(P):
        P = np.unique(P, axis=0)
    return P[np.lexsort(P.T[::-1])] if len(P) else P


def pareto_order(F: np.ndarray) -> np.ndarray:
    """Indices of the non-dominated rows of ``F`` in the order of every Pareto table of
    hypate: by the first objective, ties by the next objectives, then by row (stable).

    Unlike :func:`pareto_front` no duplicate is dropped, so ``X[idx]`` and ``F[idx]`` stay
    row-aligned: the design of row ``i`` has the objectives of row ``i``.

    Parameters
    ----------
    F : ndarray of shape (n, m)

    Returns
    -------
    ndarray of int, shape (k,)
    """
    F = np.atleast_2d(np.asarray(F, dtype=float))
    idx = np.flatnonzero(non_dominated_mask(F)) if F.shape[0] else np.zeros(0, int)
    # np.lexsort sorts by its last key first, and is stable
    return idx[np.lexsort(F[idx].T[::-1])] if len(idx) else idx


def _front_below(F: np.ndarray, ref_point: np.ndarray) -> np.ndarray:
    F = np.asarray(F, dtype=float)
    if F.size == 0:
        return np.zeros((0, len(ref_point)))
    F = F[np.all(F < ref_point, axis=1)]
    return pareto_front(F) if len(F) else F


def hypervolume_2d(F: np.ndarray, ref_point: np.ndarray) -> float:
    """Exact 2-D hypervolume by a sweep over the staircase (Fig. 6.3).

    Parameters
    ----------
    F : ndarray of shape (n, 2)
    ref_point : ndarray of shape (2,)
    """
    r = np.asarray(ref_point, dtype=float)
    P = _front_below(F, r)
    if len(P) == 0:
        return 0.0
    # sorted by f1 ascending => f2 descending; strip i spans [f1_i, f1_{i+1}] x [f2_i, r2]
    x_next = np.r_[P[1:, 0], r[0]]
    return float(np.sum((x_next - P[:, 0]) * (r[1] - P[:, 1])))


def hypervolume(F: np.ndarray, ref_point: np.ndarray) -> float:
    """Hypervolume of ``F`` w.r.t. ``ref_point``: exact sweep in 2-D, pymoo otherwise.

    Parameters
    ----------
    F : ndarray of shape (n, m)
    ref_point : ndarray of shape (m,)
    """
    r = np.asarray(ref_point, dtype=float)
    if r.size == 2:
        return hypervolume_2d(F, r)
    if r.size == 1:
        F = np.asarray(F, dtype=float).ravel()
        return float(max(0.0, r[0] - F.min())) if F.size else 0.0
    P = _front_below(F, r)
    if len(P) == 0:
        return 0.0

    return float(HV(ref_point=r)(P))


def nondominated_boxes(
    front: np.ndarray, ref_point: np.ndarray, *, max_cells: int = 200_000
) -> tuple[np.ndarray, np.ndarray] | None:
    """Disjoint boxes covering the region below ``ref_point`` not dominated by ``front``.

    Parameters
    ----------
    front : ndarray of shape (k, m)
        Current Pareto set (dominated rows and rows not below the reference are ignored).
    ref_point : ndarray of shape (m,)
    max_cells : int
        For ``m > 2``: give up (return ``None``) when the grid has more cells than this.

    Returns
    -------
    lower, upper : ndarray of shape (B, m)
        Box bounds; ``lower`` may hold ``-inf``. ``None`` if the grid is too large.
    """
    r = np.asarray(ref_point, dtype=float)
    m = r.size
    P = _front_below(np.asarray(front, dtype=float).reshape(-1, m), r)
    k = len(P)
    if k == 0:
        return np.full((1, m), -np.inf), r[None, :].copy()
    if m == 2:
        # strips [x_{i-1}, x_i] x [-inf, y_{i-1}], x_{-1} = -inf, y_{-1} = r2, x_k = r1
        xl = np.r_[-np.inf, P[:, 0]]
        xu = np.r_[P[:, 0], r[0]]
        yu = np.r_[r[1], P[:, 1]]
        lower = np.c_[xl, np.full(k + 1, -np.inf)]
        upper = np.c_[xu, yu]
        keep = xu > xl
        return lower[keep], upper[keep]
    if (k + 1) ** m > max_cells:
        return None
    # grid cells: per axis the sorted unique Pareto coordinates split (-inf, r_j]
    edges = [np.r_[-np.inf, np.unique(P[:, j]), r[j]] for j in range(m)]
    idx = np.meshgrid(*[np.arange(len(e) - 1) for e in edges], indexing="ij")
    lo = np.stack([edges[j][idx[j].ravel()] for j in range(m)], axis=1)
    up = np.stack([edges[j][idx[j].ravel() + 1] for j in range(m)], axis=1)
    # a cell is dominated iff some Pareto point is <= its lower corner
    dominated = np.zeros(len(lo), dtype=bool)
    for p in P:  # loop over Pareto points (k), vectorized over cells
        dominated |= np.all(p <= lo, axis=1)
    keep = ~dominated & np.all(up > lo, axis=1)
    return lo[keep], up[keep]


def hypervolume_improvement(
    Y: np.ndarray, lower: np.ndarray, upper: np.ndarray, *, gradient: bool = False
) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """Exact hypervolume improvement Eq. (6.23) of each row of ``Y`` over a box decomposition.

    ``I_H(y) = sum_c prod_j (upper_cj - max(lower_cj, y_j))^+``.

    Parameters
    ----------
    Y : ndarray of shape (N, m)
    lower, upper : ndarray of shape (B, m)
        From :func:`nondominated_boxes`.
    gradient : bool
        Also return ``dI_H/dy`` of shape (N, m).

    Returns
    -------
    hvi : ndarray of shape (N,)
    grad : ndarray of shape (N, m), only if ``gradient``
    """
    Y = np.atleast_2d(Y)
    side = np.maximum(upper[None] - np.maximum(lower[None], Y[:, None, :]), 0.0)  # (N,B,m)
    vol = np.prod(side, axis=2)
    hvi = vol.sum(axis=1)
    if not gradient:
        return hvi
    m = Y.shape[1]
    # d side_j / d y_j = -1 where lower_j < y_j < upper_j, else 0
    active = (Y[:, None, :] > lower[None]) & (Y[:, None, :] < upper[None])
    grad = np.empty_like(Y)
    for j in range(m):  # loop over objectives only
        others = np.prod(np.delete(side, j, axis=2), axis=2)
        grad[:, j] = -np.sum(others * active[:, :, j], axis=1)
    return hvi, grad
