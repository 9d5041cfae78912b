"""Uncertainty propagation by polynomial chaos (Sec. 10.2's surrogate-based stochastic
collocation), on chaospy.

An uncertain input is a *factor* multiplying a nominal value: ``normal = s`` is N(1, s)
(relative standard deviation), ``uniform = w`` is U(1 - w, 1 + w) (relative half-width),
``lognormal = s`` is exp(N(0, s)). The engine knows no physics: it propagates any function
of the factors, ``f(F) -> (n, m)`` for ``F`` of shape ``(n, d)``.

* :func:`collocation_nodes` -- scrambled Sobol points mapped through the inverse CDF of the
  joint distribution (point collocation: the simulator runs at these);
* :class:`Expansion` -- an orthonormal polynomial chaos expansion of a vector output fitted
  by least squares on the nodes (``chaospy.fit_regression``); its moments and first-order
  Sobol indices are closed forms of the coefficients (what ``chaospy.Sens_m`` integrates);
* :func:`summary` -- mean, standard deviation and quantiles of samples of a scalar output.
"""
from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Literal

import chaospy
import numpy as np
from scipy.special import ndtr
from scipy.stats import qmc

#: Distribution families of an uncertain factor and what their width means.
DISTRIBUTIONS = {"normal": "relative standard deviation",
                 "uniform": "relative half-width",
                 "lognormal": "standard deviation of the log"}
#: Largest width per family: the factor stays positive (normal: the nodes lie within
#: :data:`NORMAL_TAIL` standard deviations, so the factor is at least 1 - 4 x 0.2 = 0.2).
MAX_WIDTH = {"normal": 0.2, "uniform": 0.9, "lognormal": 1.0}
#: Standard deviations a normal node may lie from its mean (the inverse CDF of the Sobol
#: points is clipped there: a truncation of probability 6e-5, and no negative thickness).
NORMAL_TAIL = 4.0
#: Quantiles reported with the mean and the standard deviation.
QUANTILES = {"q10": 0.10, "q50": 0.50, "q90": 0.90}
#: What a robust design minimizes per objective.
ROBUST_STATISTICS = ("mean", "mean+2std", "q90")


@dataclass(frozen=True)
class Uncertain:
    """One uncertain factor: ``name`` (what it multiplies), family and width."""

    name: str
    kind: str
    width: float

    def __post_init__(self) -> None:
        if self.kind not in DISTRIBUTIONS:
            raise ValueError(f"{self.name}: distribution must be one of "
                             f"{', '.join(DISTRIBUTIONS)}; got {self.kind!r}")
        top = MAX_WIDTH[self.kind]
        if not (math.isfinite(self.width) and 0.0 < self.width <= top):
            raise ValueError(f"{self.name}: {self.kind} width ({DISTRIBUTIONS[self.kind]}) "
                             f"must be in (0, {top:g}]; got {self.width:g}")

    def distribution(self) -> chaospy.Distribution:
        """The factor's distribution (mean 1 for normal and uniform, median 1 lognormal)."""
        if self.kind == "normal":
            return chaospy.Normal(1.0, self.width)
        if self.kind == "uniform":
            return chaospy.Uniform(1.0 - self.width, 1.0 + self.width)
        return chaospy.LogNormal(0.0, self.width)

    def support(self) -> tuple[float, float]:
        """The range every node lies in (:func:`collocation_nodes`: the distribution
        clipped at the probabilities of +-:data:`NORMAL_TAIL` standard normal deviations)."""
        tail = float(ndtr(-NORMAL_TAIL))
        lo, hi = self.distribution().inv(np.array([tail, 1.0 - tail]))
        return float(lo), float(hi)

    def describe(self) -> str:
        return f"{self.kind} {self.width:g} ({DISTRIBUTIONS[self.kind]})"


def joint(inputs: Sequence[Uncertain]) -> chaospy.Distribution:
    """Independent joint distribution of the factors."""
    return chaospy.J(*[u.distribution() for u in inputs])


def collocation_nodes(inputs: Sequence[Uncertain], n: int, seed: int = 0) -> np.ndarray:
    """``n`` scrambled Sobol points of the factors, shape ``(n, d)`` (inverse-CDF map)."""
    d = len(inputs)
    with warnings.catch_warnings():  # any n is a valid design; a power of two is balanced
        warnings.filterwarnings("ignore", "The balance properties", UserWarning)
        u = qmc.Sobol(d, scramble=True, seed=seed).random(n)
    # within NORMAL_TAIL standard deviations (the same clip for every family: u is uniform)
    tail = float(ndtr(-NORMAL_TAIL))
    u = np.clip(u, tail, 1.0 - tail)
    return np.atleast_2d(joint(inputs).inv(u.T)).T.reshape(n, d)


def expansion_terms(d: int, order: int) -> int:
    """Number of polynomials of total degree <= ``order`` in ``d`` variables."""
    return math.comb(d + order, order)


def default_samples(d: int, order: int) -> int:
    """Simulator runs for an order-``order`` expansion: twice its number of terms (the usual
    oversampling of point collocation), rounded up to a power of two (balanced Sobol)."""
    return 1 << max(0, math.ceil(math.log2(2 * expansion_terms(d, order))))


class Expansion:
    """Polynomial chaos expansion of a vector output, fitted by least squares.

    Parameters
    ----------
    inputs : sequence of Uncertain
    nodes : (n, d) array
        Factor values where the output was computed.
    values : (n, m) array
    order : int
        Total polynomial degree.
    """

    def __init__(self, inputs: Sequence[Uncertain], nodes: np.ndarray, values: np.ndarray,
                 order: int) -> None:
        nodes = np.asarray(nodes, float)
        values = np.asarray(values, float)
        if values.ndim == 1:
            values = values[:, None]
        terms = expansion_terms(len(inputs), order)
        if len(nodes) < terms:
            raise ValueError(f"samples: an order-{order} expansion in {len(inputs)} inputs "
                             f"has {terms} terms and needs at least as many samples; got "
                             f"{len(nodes)}")
        self.inputs = tuple(inputs)
        self.nodes, self.values = nodes, values
        self.dist = joint(inputs)
        self.order = order
        self.basis = chaospy.generate_expansion(order, self.dist, normed=True)
        # Orthonormal basis: coefficient 0 is the mean, the others' squares sum to the
        # variance (the closed forms of the moments).
        self.poly, self.coefficients = chaospy.fit_regression(
            self.basis, nodes.T, values, retall=1)
        self.coefficients = np.asarray(self.coefficients).reshape(terms, -1)
        # variables each basis polynomial depends on (its monomials' exponents)
        self.support = np.array([np.any(np.asarray(b.exponents) > 0, axis=0)
                                 for b in self.basis]).reshape(terms, len(inputs))

    def __call__(self, factors: np.ndarray) -> np.ndarray:
        """The expansion at ``factors`` (n, d) -> (n, m)."""
        B = np.atleast_2d(self.basis(*np.asarray(factors, float).T))
        return (self.coefficients.T @ B).T

    def leave_one_out(self) -> np.ndarray:
        """Each node's value predicted by the expansion fitted without it, (n, m): the
        closed form of least squares, ``y_i - e_i / (1 - h_ii)`` (hat-matrix diagonal)."""
        A = np.atleast_2d(self.basis(*self.nodes.T)).T             # (n, terms)
        Q, _ = np.linalg.qr(A)
        h = np.minimum(np.sum(Q * Q, axis=1), 1.0 - 1e-12)
        e = self.values - A @ self.coefficients
        return self.values - e / (1.0 - h)[:, None]

    @property
    def mean(self) -> np.ndarray:
        return self.coefficients[0]

    @property
    def std(self) -> np.ndarray:
        return np.sqrt(np.sum(self.coefficients[1:] ** 2, axis=0))

    def first_order_sobol(self) -> np.ndarray:
        """First-order Sobol indices, shape ``(d, m)``: the variance of the terms in one
        variable only over the total variance (the closed form of an orthonormal chaos;
        ``chaospy.Sens_m`` integrates the same by quadrature, orders of magnitude slower)."""
        c2 = self.coefficients ** 2
        only = self.support & (self.support.sum(axis=1, keepdims=True) == 1)  # (terms, d)
        var = np.sum(c2[1:], axis=0)
        return (only.T.astype(float) @ c2) / np.where(var > 0.0, var, 1.0)


def expand(fun: Callable[[np.ndarray], np.ndarray], inputs: Sequence[Uncertain],
           order: int = 2, samples: int | None = None, seed: int = 0) -> Expansion:
    """Fit an expansion of ``fun`` on ``samples`` collocation nodes (``fun`` sees all)."""
    n = default_samples(len(inputs), order) if samples is None else int(samples)
    nodes = collocation_nodes(inputs, n, seed)
    return Expansion(inputs, nodes, fun(nodes), order)


def summary(values: np.ndarray) -> dict[str, float]:
    """``mean``, ``std`` and the :data:`QUANTILES` of scalar samples. An infinite sample (a
    failure) makes the mean and std infinite and the quantiles the samples' own order
    statistics (no interpolation towards infinity)."""
    v = np.asarray(values, float).reshape(-1)
    method: Literal["linear", "inverted_cdf"]
    if np.all(np.isfinite(v)):
        out = {"mean": float(np.mean(v)), "std": float(np.std(v, ddof=1))}
        method = "linear"
    else:
        out, method = {"mean": math.inf, "std": math.inf}, "inverted_cdf"
    out.update({k: float(np.quantile(v, q, method=method)) for k, q in QUANTILES.items()})
    return out


def robust_value(stats: dict[str, float], statistic: str) -> float:
    """The robust statistic of :func:`summary`'s output (:data:`ROBUST_STATISTICS`)."""
    if statistic == "mean":
        return stats["mean"]
    if statistic == "mean+2std":
        return stats["mean"] + 2.0 * stats["std"]
    if statistic == "q90":
        return stats["q90"]
    raise ValueError(f"statistic must be one of {', '.join(ROBUST_STATISTICS)}")


__all__ = [
    "DISTRIBUTIONS",
    "QUANTILES",
    "ROBUST_STATISTICS",
    "Expansion",
    "Uncertain",
    "collocation_nodes",
    "default_samples",
    "expand",
    "expansion_terms",
    "joint",
    "robust_value",
    "summary",
]
