"""A user's constraints, sorted into the engine's two kinds: expensive and cheap.

The engine knows two kinds of constraint (DESIGN.md, "Problem"):

* **expensive** -- computed by the evaluation itself, like the objectives (a stress from the
  same simulation, a measured temperature). Each evaluated design has its value; the
  engine models each such constraint by kriging and asks of every proposal a predicted
  probability of feasibility of at least ``p_feasible`` (pymoo's ``G <= 0``;
  :class:`~hypate.scaling.engine.surrogate.ProbabilisticConstraint`). A design that
  violates it is evaluated all the same and kept out of the Pareto set.
* **cheap** -- an analytic function of the design with its Jacobian
  (:class:`~hypate.scaling.engine.problem.CheapConstraint`, e.g. the studies' Eq. 9.7
  equality): handed to the inner SLSQP exactly, so every proposal (and the initial design,
  projected) satisfies it to SLSQP's precision (:data:`~hypate.scaling.engine.problem.CHEAP_TOL`
  with its Jacobian; a finite-difference Jacobian loses about a digit). It costs no
  evaluation. Equalities must be cheap: a surrogate's proposals cannot meet ``h(x) = 0``.

:func:`sort_constraints` reads what a user passes as ``constraints`` (one list, three
forms) and returns the two kinds:

=========================================  ===========================  ======================
given as                                   feasible where               kind
=========================================  ===========================  ======================
a callable ``g(x) -> float``               ``g(x) <= 0``                expensive
``CheapConstraint(fun, jac, kind)``        ``fun(x) <= 0`` / ``== 0``   cheap
scipy's dict ``{"type", "fun", "jac",      ``fun(x) >= 0`` (``"ineq"``) cheap with ``"jac"`` or
"args", "cheap"}``                         / ``== 0`` (``"eq"``)        ``"cheap": True``,
                                                                        else expensive
=========================================  ===========================  ======================

A scipy dict keeps scipy's sign convention (``fun(x) >= 0`` is feasible, as in
``scipy.optimize.minimize``); it is converted to the engine's ``g = -fun <= 0``. A cheap dict
without ``"jac"`` gets a forward-difference Jacobian (step :data:`FD_STEP` of each
variable's range: ``scipy.optimize.approx_fprime``).
"""
from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from hypate.scaling.engine.problem import CheapConstraint
from scipy.optimize import approx_fprime

__all__ = ["ConstraintSet", "ExpensiveConstraint", "FD_STEP", "sort_constraints"]

#: Forward-difference step of a cheap constraint given without a Jacobian, as a fraction
#: of each variable's range (about the square root of the float64 epsilon).
FD_STEP = 1.5e-8
#: Keys a scipy-style constraint dict may have.
DICT_KEYS = frozenset(("type", "fun", "jac", "args", "cheap"))


@dataclass(frozen=True)
class ExpensiveConstraint:
    """One expensive inequality, evaluated with the objectives: feasible where
    ``sign * fun(x, *args) <= 0``.

    Parameters
    ----------
    fun : callable
        ``fun(x, *args) -> float`` for one design ``x`` of shape (d,).
    args : tuple
        Extra arguments of ``fun`` (scipy's ``"args"``).
    sign : float
        ``1`` (the engine's ``g <= 0``) or ``-1`` (scipy's ``fun >= 0``).
    """

    fun: Callable[..., Any]
    args: tuple = ()
    sign: float = 1.0

    def __call__(self, x: np.ndarray) -> float:
        value = np.asarray(self.fun(x, *self.args), dtype=float)
        if value.size != 1:
            raise ValueError(f"a constraint must return one number; got shape {value.shape}")
        return self.sign * float(value.reshape(()))


@dataclass(frozen=True)
class _ScipyCheap:
    """A scipy-style cheap constraint in the engine's sign (picklable, unlike a closure)."""

    fun: Callable[..., Any]
    jac: Callable[..., Any] | None
    args: tuple
    sign: float
    step: np.ndarray

    def value(self, x: np.ndarray) -> np.ndarray:
        return self.sign * np.atleast_1d(np.asarray(self.fun(x, *self.args), dtype=float))

    def gradient(self, x: np.ndarray) -> np.ndarray:
        if self.jac is None:
            return np.atleast_2d(approx_fprime(np.asarray(x, float), self.value, self.step))
        return self.sign * np.atleast_2d(np.asarray(self.jac(x, *self.args), dtype=float))


@dataclass(frozen=True)
class ConstraintSet:
    """A user's constraints sorted by kind (:func:`sort_constraints`).

    Attributes
    ----------
    expensive : tuple of ExpensiveConstraint
        Evaluated with the objectives, one column ``g_i`` each.
    cheap : tuple of CheapConstraint
        Enforced exactly in every proposal.
    """

    expensive: tuple[ExpensiveConstraint, ...] = ()
    cheap: tuple[CheapConstraint, ...] = ()


def _from_dict(i: int, c: Mapping[str, Any], span: np.ndarray
               ) -> ExpensiveConstraint | CheapConstraint:
    name = f"constraints[{i}]"
    unknown = sorted(set(c) - DICT_KEYS)
    if unknown:
        raise ValueError(f"{name}: unknown key(s) {unknown}; a constraint dict has "
                         f"{sorted(DICT_KEYS)}")
    kind = c.get("type")
    if kind not in ("ineq", "eq"):
        raise ValueError(f"{name}: 'type' must be 'ineq' or 'eq'; got {kind!r}")
    fun, jac = c.get("fun"), c.get("jac")
    if not callable(fun):
        raise TypeError(f"{name}: 'fun' must be a callable fun(x, *args)")
    if jac is not None and not callable(jac):
        raise TypeError(f"{name}: 'jac' must be a callable jac(x, *args) (scipy's jac=True "
                        "is not supported: give the Jacobian as its own function)")
    cheap = c.get("cheap", jac is not None)
    if not isinstance(cheap, bool):
        raise TypeError(f"{name}: 'cheap' must be True or False; got {cheap!r}")
    args = tuple(c.get("args", ()))
    # scipy: an inequality holds where fun >= 0; the engine's holds where g = -fun <= 0
    sign = -1.0 if kind == "ineq" else 1.0
    if not cheap:
        if kind == "eq":
            raise ValueError(f"{name}: an equality constraint must be cheap (give its 'jac', "
                             "or 'cheap': True for a finite-difference Jacobian): the "
                             "proposals of a surrogate cannot meet h(x) = 0")
        return ExpensiveConstraint(fun, args, sign)
    part = _ScipyCheap(fun, jac, args, sign, FD_STEP * span)
    return CheapConstraint(fun=part.value, jac=part.gradient, kind=kind)


def sort_constraints(constraints: Sequence[Any] | None, bounds: np.ndarray) -> ConstraintSet:
    """Sort a user's ``constraints`` into expensive and cheap ones (module docstring).

    Parameters
    ----------
    constraints : sequence of callable, CheapConstraint or dict, or None
        A callable ``g`` is an expensive inequality ``g(x) <= 0``; a
        :class:`~hypate.scaling.engine.problem.CheapConstraint` is cheap; a scipy-style dict
        ``{"type": "ineq" | "eq", "fun": f, "jac": J, "args": (...), "cheap": bool}``
        (``f(x) >= 0`` or ``f(x) == 0`` feasible) is cheap when it has ``"jac"`` or
        ``"cheap": True``, else an expensive inequality.
    bounds : ndarray of shape (d, 2)
        The design box (the finite-difference steps scale with its ranges).

    Returns
    -------
    ConstraintSet

    Raises
    ------
    TypeError
        An entry of none of the three forms (the message names ``constraints[i]``).
    ValueError
        A dict with an unknown key or type, or an expensive equality.
    """
    if constraints is None:
        return ConstraintSet()
    if isinstance(constraints, (Mapping, CheapConstraint)) or callable(constraints):
        constraints = [constraints]  # one constraint given alone, as scipy allows
    b = np.asarray(bounds, dtype=float)
    span = b[:, 1] - b[:, 0]
    expensive: list[ExpensiveConstraint] = []
    cheap: list[CheapConstraint] = []
    for i, c in enumerate(constraints):
        if isinstance(c, CheapConstraint):
            cheap.append(c)
        elif isinstance(c, Mapping):
            part = _from_dict(i, c, span)
            if isinstance(part, CheapConstraint):
                cheap.append(part)
            else:
                expensive.append(part)
        elif callable(c):
            expensive.append(ExpensiveConstraint(c))
        else:
            raise TypeError(f"constraints[{i}]: must be a callable g(x) (feasible where "
                            "g(x) <= 0), a CheapConstraint or a scipy-style dict; got "
                            f"{type(c).__name__}")
    return ConstraintSet(tuple(expensive), tuple(cheap))
