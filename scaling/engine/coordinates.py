"""Surrogate input coordinates: log-linear maps of positive designs (similarity axes).

The surrogates of a scaling problem see ``z = A ln x`` (:class:`LogLinearCoordinates`);
designs, bounds, cheap constraints and the acquisition search stay in ``x``
(:class:`WarpedModel` queries a model fitted in ``z`` with gradients in ``x``).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

__all__ = ["LogLinearCoordinates", "WarpedModel"]


@dataclass(frozen=True)
class LogLinearCoordinates:
    """Surrogate input coordinates ``z = A ln x`` of positive design variables.

    Kriging with one length scale per input (Eq. (A.3)) resolves a landscape whose valleys
    are aligned with the inputs. The objective of a scaling problem depends mainly on the
    similarity parameters, monomials ``Pi_i = c_i prod_j x_j^(A_ij)`` of the design
    (Sec. 6.1), so its valleys (``Pi_i = Pi_i^p``) are hyperplanes of ``ln x`` that are
    oblique to the axes (Sec. 9.1: ``h``, ``p_inf ~ h^3``, ``Delta T ~ h^2``). Rows of
    ``A`` that are the exponents of those parameters make them the axes. Only the
    surrogates see ``z``: designs, bounds, cheap constraints and the acquisition search
    stay in ``x`` (gradients by the chain rule).

    Parameters
    ----------
    matrix : ndarray of shape (d, d)
        Invertible; ``A = I`` gives plain log coordinates.
    """

    matrix: np.ndarray

    def __post_init__(self) -> None:
        A = np.asarray(self.matrix, dtype=float)
        if A.ndim != 2 or A.shape[0] != A.shape[1] or not np.all(np.isfinite(A)):
            raise ValueError(f"coordinate matrix must be square and finite, got shape {A.shape}")
        if np.linalg.cond(A) > 1e10:
            raise ValueError("coordinate matrix is singular: the rows must be independent")
        object.__setattr__(self, "matrix", A)

    @classmethod
    def log(cls, d: int) -> LogLinearCoordinates:
        """Plain log coordinates ``z = ln x`` of ``d`` variables."""
        return cls(np.eye(d))

    def __call__(self, X: np.ndarray) -> np.ndarray:
        """``z`` of designs ``X`` of shape (N, d) (all entries positive)."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        return np.log(X) @ self.matrix.T

    def jacobian(self, X: np.ndarray) -> np.ndarray:
        """``dz/dx = A diag(1/x)``, shape (N, d, d)."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        return self.matrix[None] / X[:, None, :]

    def box(self, bounds: np.ndarray) -> np.ndarray:
        """Bounding box (d, 2) of the image of the design box (the surrogates' unit box)."""
        b = np.log(np.asarray(bounds, dtype=float))
        lo = np.where(self.matrix > 0, self.matrix * b[:, 0], self.matrix * b[:, 1]).sum(axis=1)
        hi = np.where(self.matrix > 0, self.matrix * b[:, 1], self.matrix * b[:, 0]).sum(axis=1)
        return np.c_[lo, hi]


class InputCoordinates(Protocol):
    """What a warped surrogate needs of its input coordinates: ``z = coords(x)`` and the
    Jacobian ``dz/dx`` (:class:`LogLinearCoordinates`, or a categorical variable's
    :class:`~hypate.scaling.engine.mixed.MixedCoordinates`)."""

    def __call__(self, X: np.ndarray) -> np.ndarray: ...

    def jacobian(self, X: np.ndarray) -> np.ndarray: ...


class WarpedModel:
    """A surrogate fitted in ``z`` coordinates, queried (with gradients) in ``x``.

    Parameters
    ----------
    model : object
        Fitted on ``z = coords(x)``, with ``predict_moments``, ``predict_with_gradients``
        and ``condition`` (:class:`hypate.solvers.numerics.kriging.KrigingRegressor`).
    coords : InputCoordinates
    """

    def __init__(self, model: Any, coords: InputCoordinates) -> None:
        self.model = model
        self.coords = coords

    def predict_moments(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Mean and standard deviation at designs ``X`` (N, d), each of shape (N, m)."""
        return self.model.predict_moments(self.coords(X))

    def predict_with_gradients(
        self, X: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Moments (N, m) and their x-gradients (N, m, d), by the chain rule through ``z``."""
        mean, std, dmean, dstd = self.model.predict_with_gradients(self.coords(X))
        J = self.coords.jacobian(X)
        return (mean, std, np.einsum("nmk,nkd->nmd", dmean, J),
                np.einsum("nmk,nkd->nmd", dstd, J))

    def leave_one_out(self) -> tuple[np.ndarray, np.ndarray]:
        """Leave-one-out mean and std at the training points (n, m) (the points are the
        same in ``x`` and ``z``)."""
        return self.model.leave_one_out()

    def condition(self, X: np.ndarray, y: np.ndarray) -> WarpedModel:
        """The model conditioned on (fantasized) data ``X`` (n, d), ``y`` (n, m) in ``x``."""
        return WarpedModel(self.model.condition(self.coords(X), y), self.coords)
