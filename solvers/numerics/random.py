"""Optimal Latin hypercube (OLH) designs (Sec. 6.3.3) on a box.

Initial designs use scipy's Latin hypercube optimized for centered discrepancy
(``optimization="random-cd"``). Inner-optimization starting points are needed every
iteration, where re-optimizing a few hundred points would cost about a second; they are
drawn as a random *symmetry* of one cached optimized design: permuting the columns and
reflecting coordinates (``u -> 1 - u``) maps a Latin hypercube to a Latin hypercube and
leaves the centered discrepancy unchanged, so every draw is an OLH, at no cost.

The one home of random sampling: the optimization engine (initial designs, inner-loop
starts, Monte-Carlo base samples) and the fluid ROM (sample plans, kriging restarts) draw
through :func:`as_rng` and these designs.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np
from scipy.stats import qmc

__all__ = ["as_rng", "latin_hypercube", "raw_latin_hypercube", "scale_to_bounds"]


def as_rng(rng: np.random.Generator | int | None) -> np.random.Generator:
    """A Generator from a Generator, a seed or ``None``."""
    return rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)


def scale_to_bounds(U: np.ndarray, bounds: np.ndarray) -> np.ndarray:
    """Map unit-box points ``U`` (n, d) to the box ``bounds`` (d, 2)."""
    b = np.asarray(bounds, dtype=float)
    return b[:, 0] + U * (b[:, 1] - b[:, 0])


def latin_hypercube(
    n: int,
    bounds: np.ndarray,
    rng: np.random.Generator | int | None = None,
    *,
    optimization: str | None = "random-cd",
) -> np.ndarray:
    """An (optimal) Latin hypercube of ``n`` points in ``bounds``.

    Parameters
    ----------
    n : int
    bounds : ndarray of shape (d, 2)
    rng : numpy.random.Generator, int or None
    optimization : {"random-cd", "lloyd", None}
        scipy.stats.qmc.LatinHypercube optimization; ``None`` for a plain LHS.

    Returns
    -------
    ndarray of shape (n, d)
    """
    d = np.asarray(bounds).shape[0]
    if n <= 0:
        return np.zeros((0, d))
    sampler = qmc.LatinHypercube(d, optimization=optimization if n > 1 else None,
                                 rng=as_rng(rng))
    return scale_to_bounds(sampler.random(n), bounds)


@lru_cache(maxsize=16)
def _cached_olh(n: int, d: int) -> np.ndarray:
    U = qmc.LatinHypercube(d, optimization="random-cd", rng=np.random.default_rng(12345)).random(n)
    U.setflags(write=False)
    return U


def raw_latin_hypercube(
    n: int, bounds: np.ndarray, rng: np.random.Generator | int | None = None
) -> np.ndarray:
    """A random symmetry (column permutation + reflections) of a cached OLH of ``n`` points.

    Parameters
    ----------
    n : int
    bounds : ndarray of shape (d, 2)
    rng : numpy.random.Generator, int or None

    Returns
    -------
    ndarray of shape (n, d)
    """
    rng = as_rng(rng)
    d = np.asarray(bounds).shape[0]
    U = _cached_olh(n, d)[:, rng.permutation(d)]
    flip = rng.random(d) < 0.5
    U = np.where(flip, 1.0 - U, U)
    return scale_to_bounds(U[rng.permutation(n)], bounds)
