"""The problem contract of the engine: a pymoo ``Problem`` plus cheap analytic constraints.

The optimizer accepts any ``pymoo.core.problem.Problem`` (objectives minimized, constraints
satisfied when ``G <= 0``, finite bounds ``xl``, ``xu``). Cheap analytic constraints
(:class:`CheapConstraint`, e.g. similarity-parameter equalities, Eqs. (6.10b)-(6.10c)) are
handed to the inner SLSQP exactly; expensive ones come from evaluations
(:func:`evaluate_design`, which never raises: a failure is a status).
"""
from __future__ import annotations

import contextlib
import dataclasses
import functools
import re
import time
import warnings
from collections import Counter
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from hypate.scaling.engine.child import call_in_child
from hypate.scaling.engine.faults import KilledItsWorker
from scipy.optimize import Bounds, minimize

__all__ = [
    "STATUS_OK",
    "CHEAP_TOL",
    "CheapConstraint",
    "cheap_violation",
    "scipy_constraints",
    "project_unit",
    "project_designs",
    "project_cheap",
    "Outcome",
    "evaluate_design",
    "MAX_WARNINGS",
    "MAX_WARNING_CHARS",
    "recorded_warnings",
    "summarize_warnings",
    "parse_warning",
    "tally_warnings",
]

#: Status of a successful evaluation; anything else is a failure.
STATUS_OK = "ok"
#: Feasibility tolerance of the cheap constraints at every proposal.
CHEAP_TOL = 1e-8
#: Distinct warnings kept per evaluation; the rest are counted in one last entry.
MAX_WARNINGS = 20
#: Characters kept of a warning's text ("Category: message").
MAX_WARNING_CHARS = 300


# ----------------------------------------------------------------- cheap constraints
@dataclass(frozen=True)
class CheapConstraint:
    """An analytic constraint enforced exactly inside the inner optimization.

    Parameters
    ----------
    fun : callable
        ``fun(x) -> ndarray of shape (k,)`` (or a scalar) for one design ``x`` of shape (d,).
    jac : callable
        ``jac(x) -> ndarray of shape (k, d)`` (or (d,)).
    kind : {"ineq", "eq"}
        ``"ineq"``: ``fun(x) <= 0`` (pymoo's convention); ``"eq"``: ``fun(x) == 0``
        (Eqs. (6.10b)-(6.10c)).
    """

    fun: Callable[[np.ndarray], Any]
    jac: Callable[[np.ndarray], Any]
    kind: Literal["ineq", "eq"] = "ineq"

    def __post_init__(self) -> None:
        if self.kind not in ("ineq", "eq"):
            raise ValueError(f"kind must be 'ineq' or 'eq', got {self.kind!r}")

    def violation(self, x: np.ndarray) -> float:
        """Largest violation at ``x`` (0 if satisfied)."""
        c = np.atleast_1d(np.asarray(self.fun(x), dtype=float))
        v = np.abs(c) if self.kind == "eq" else np.maximum(c, 0.0)
        return float(v.max(initial=0.0))


def cheap_violation(constraints: Sequence[CheapConstraint], x: np.ndarray) -> float:
    """Largest violation of any of ``constraints`` at ``x`` (0 if all hold)."""
    return max((c.violation(x) for c in constraints), default=0.0)


def scipy_constraints(constraints: Sequence[CheapConstraint], lo: np.ndarray,
                      span: np.ndarray) -> list[dict[str, Any]]:
    """Cheap constraints in unit coordinates ``x = lo + u span``, in scipy's form
    (``{"type", "fun", "jac"}`` dicts, inequalities ``fun >= 0``)."""
    out = []
    for c in constraints:
        sign = 1.0 if c.kind == "eq" else -1.0

        def fun(u, c=c, sign=sign):
            return sign * np.atleast_1d(np.asarray(c.fun(lo + u * span), dtype=float))

        def jac(u, c=c, sign=sign):
            J = np.atleast_2d(np.asarray(c.jac(lo + u * span), dtype=float))
            return sign * J * span

        out.append({"type": c.kind, "fun": fun, "jac": jac})
    return out


def project_unit(u0: np.ndarray, cons: Sequence[dict[str, Any]], tol: float = 1e-14) -> np.ndarray:
    """Closest point of the unit box to ``u0`` satisfying the scipy-form constraints
    ``cons`` (:func:`scipy_constraints`), by SLSQP."""
    d = len(u0)
    res = minimize(lambda u: (0.5 * np.sum((u - u0) ** 2), u - u0), u0, jac=True,
                   method="SLSQP", bounds=Bounds(np.zeros(d), np.ones(d)), constraints=cons,
                   options={"maxiter": 200, "ftol": tol})
    return np.clip(res.x, 0.0, 1.0)


def project_designs(X: np.ndarray, constraints: Sequence[CheapConstraint],
                    bounds: np.ndarray) -> np.ndarray:
    """Rows of ``X`` (designs within ``bounds`` (d, 2)) projected onto the cheap
    ``constraints`` (unchanged without any)."""
    if not constraints or not len(X):
        return X
    lo = bounds[:, 0]
    span = bounds[:, 1] - lo
    cons = scipy_constraints(constraints, lo, span)
    return np.array([lo + project_unit((x - lo) / span, cons) * span for x in X])


def project_cheap(problem: Any, x: np.ndarray) -> np.ndarray:
    """Clip ``x`` to the bounds of ``problem`` (a pymoo problem with ``cheap_constraints()``)
    and project it onto its cheap constraints (e.g. the Eq. 9.7 equality), as the optimizer
    does for its initial design, so that seeds satisfy them exactly."""
    lo, hi = np.asarray(problem.xl, float), np.asarray(problem.xu, float)
    x = np.clip(np.asarray(x, float), lo, hi)
    cons = problem.cheap_constraints()
    if not cons:
        return x
    span = hi - lo
    u = project_unit((x - lo) / span, scipy_constraints(cons, lo, span))
    return lo + u * span


# ------------------------------------------------------------------- evaluation
@dataclass(frozen=True)
class Outcome:
    """What one evaluation of a design returned (:func:`evaluate_design`).

    Attributes
    ----------
    F : ndarray of shape (m,)
        Objectives (NaN where the evaluation failed).
    G : ndarray of shape (k,)
        Inequality constraints, feasible where ``G <= 0``.
    status : str
        ``"ok"``, ``"error"`` (raised), ``"invalid"`` (NaN/inf) or ``"timeout"``.
    message : str
    seconds : float
        Wall time of the evaluation.
    warnings : tuple of str
        The Python warnings raised during the evaluation, aggregated
        (:func:`summarize_warnings`): ``"Category: message (N times)"`` in order of first
        occurrence.
    aux : dict
        The problem's auxiliary outputs (its output dictionary's ``"aux"`` entry for the
        design: JSON data, stored with the evaluation; empty when it gives none).
    """

    F: np.ndarray
    G: np.ndarray
    status: str = STATUS_OK
    message: str = ""
    seconds: float = 0.0
    warnings: tuple[str, ...] = ()
    aux: dict = dataclasses.field(default_factory=dict)

    @classmethod
    def failure(cls, m: int, k: int, status: str, message: str, seconds: float,
                warnings: tuple[str, ...] = ()) -> Outcome:
        """A failed evaluation of ``m`` objectives and ``k`` constraints (all NaN)."""
        return cls(np.full(m, np.nan), np.full(k, np.nan), status, message, seconds, warnings)

    @property
    def ok(self) -> bool:
        return self.status == STATUS_OK


# ------------------------------------------------------------------- warnings
@contextlib.contextmanager
def recorded_warnings() -> Iterator[list[warnings.WarningMessage]]:
    """Record every Python warning raised inside the block (each occurrence, none printed).

    Yields
    ------
    list of warnings.WarningMessage
        Filled while the block runs; :func:`summarize_warnings` aggregates it.
    """
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")  # count every occurrence, whatever the registry saw
        yield caught


def _warning_text(w: warnings.WarningMessage) -> str:
    text = f"{w.category.__name__}: {w.message}"
    return text if len(text) <= MAX_WARNING_CHARS else text[:MAX_WARNING_CHARS - 3] + "..."


def _times(n: int) -> str:
    return f"({n} time)" if n == 1 else f"({n} times)"


def summarize_warnings(caught: Iterable[warnings.WarningMessage]) -> tuple[str, ...]:
    """Recorded warnings aggregated: one ``"Category: message (N times)"`` per distinct text.

    Parameters
    ----------
    caught : iterable of warnings.WarningMessage
        As recorded by :func:`recorded_warnings`.

    Returns
    -------
    tuple of str
        In order of first occurrence (deterministic for a deterministic evaluation); texts
        cut at :data:`MAX_WARNING_CHARS`; beyond :data:`MAX_WARNINGS` distinct texts the
        rest are one last entry ``"Other warnings: K more kinds (N times)"``.
    """
    counts = Counter(_warning_text(w) for w in caught)  # insertion order = first occurrence
    items = list(counts.items())
    out = [f"{text} {_times(n)}" for text, n in items[:MAX_WARNINGS]]
    rest = items[MAX_WARNINGS:]
    if rest:
        out.append(f"Other warnings: {len(rest)} more kinds {_times(sum(n for _, n in rest))}")
    return tuple(out)


_ENTRY = re.compile(r"^(.*) \((\d+) times?\)$", re.DOTALL)


def parse_warning(entry: str) -> tuple[str, int]:
    """``(text, count)`` of one entry of :func:`summarize_warnings` (count 1 for a bare text).

    Parameters
    ----------
    entry : str
        ``"Category: message (N times)"``.

    Returns
    -------
    text : str
    count : int
    """
    m = _ENTRY.match(entry)
    return (m.group(1), int(m.group(2))) if m else (entry, 1)


def tally_warnings(attributed: Iterable[tuple[Any, Sequence[str]]]
                   ) -> list[tuple[str, list[Any], int]]:
    """Distinct warnings over many evaluations: where each occurred and how often.

    Parameters
    ----------
    attributed : iterable of (label, entries)
        A label (an evaluation id, ``"prototype"``...) and its :func:`summarize_warnings`
        entries.

    Returns
    -------
    list of (text, labels, count)
        One per distinct text, the labels in the order given (each once), the total count;
        most frequent first, ties in order of first occurrence.
    """
    where: dict[str, list[Any]] = {}
    counts: Counter[str] = Counter()
    for label, entries in attributed:
        for entry in entries:
            text, n = parse_warning(entry)
            labels = where.setdefault(text, [])
            if label not in labels:
                labels.append(label)
            counts[text] += n
    return [(text, where[text], n) for text, n in counts.most_common()]


def _numpy_invalid(caught: Sequence[warnings.WarningMessage]) -> str | None:
    """The first numpy "invalid value encountered in ..." message among ``caught``."""
    for w in caught:
        if issubclass(w.category, RuntimeWarning) and "invalid value" in str(w.message):
            return str(w.message)
    return None


def evaluate_design(problem: Any, x: np.ndarray, timeout: float | None = None,
                    eq_tol: float = 1e-4) -> Outcome:
    """Evaluate one design with a pymoo Problem; never raises (module level: picklable).

    Parameters
    ----------
    problem : pymoo Problem
    x : ndarray of shape (d,)
    timeout : float or None
        Seconds. With a limit the evaluation runs in a forked child of the evaluating
        process (in-process, in a pool worker or in a Dask worker alike) that is killed when
        the limit passes (status ``"timeout"``): nothing keeps computing afterwards. The
        limit counts from the start of the evaluation, not from its submission to a busy
        executor. A child that dies without a result (a signal from outside, or the design
        itself) is forked again; a design whose child died
        :data:`~hypate.scaling.engine.faults.SOLO_DEATHS` times is a failure (status
        ``"error"``, "worker died while evaluating this design alone ...").
    eq_tol : float
        Tolerance turning equality constraints ``H = 0`` into ``|H| - eq_tol <= 0``.

    Returns
    -------
    Outcome
        ``G`` holds the inequalities ``G <= 0``, then ``|H| - eq_tol`` for the equalities.
        The warnings raised by the evaluation are recorded on it (``warnings``), not
        printed, wherever it runs; an evaluation killed at its time limit has none. (The
        warnings machinery is process-wide: where one process evaluates several designs
        in threads at once, e.g. a Dask worker with several threads, a warning may be
        recorded by a concurrent evaluation; ``local:N`` workers have one thread.)
        Non-finite objectives are status ``"invalid"``, with numpy's "invalid value"
        message in ``message`` when numpy raised one.
    """
    if timeout is None:
        return _evaluate_here(problem, x, eq_tol)
    m = int(problem.n_obj)
    k = int(problem.n_ieq_constr) + int(problem.n_eq_constr)
    t0 = time.perf_counter()
    try:
        return call_in_child(functools.partial(_evaluate_here, problem, x, eq_tol), timeout)
    except TimeoutError:
        return Outcome.failure(m, k, "timeout", f"exceeded {timeout} s",
                               time.perf_counter() - t0)
    except KilledItsWorker as exc:
        return Outcome.failure(m, k, "error", str(exc), time.perf_counter() - t0)


def _evaluate_here(problem: Any, x: np.ndarray, eq_tol: float) -> Outcome:
    """:func:`evaluate_design` in the calling process, without a time limit."""
    m = int(problem.n_obj)
    k = int(problem.n_ieq_constr) + int(problem.n_eq_constr)
    t0 = time.perf_counter()
    with recorded_warnings() as caught:
        try:
            out = problem.evaluate(np.asarray(x, dtype=float)[None, :],
                                   return_as_dictionary=True)
        except Exception as exc:  # any failure of the user's model is recorded, not raised
            return Outcome.failure(m, k, "error", f"{type(exc).__name__}: {exc}",
                                   time.perf_counter() - t0, summarize_warnings(caught))
    seconds = time.perf_counter() - t0
    found = summarize_warnings(caught)
    try:
        outcome = _outcome(problem, out, m, k, eq_tol, seconds, caught)
    except (KeyError, TypeError, ValueError) as exc:
        return Outcome.failure(m, k, "error", f"{type(exc).__name__}: {exc}", seconds, found)
    return dataclasses.replace(outcome, warnings=found)


def _outcome(problem: Any, out: dict[str, Any], m: int, k: int, eq_tol: float,
             seconds: float, caught: Sequence[warnings.WarningMessage]) -> Outcome:
    """The Outcome of a problem's output dictionary ``out`` (without its warnings)."""
    F = np.asarray(out["F"], dtype=float).reshape(-1)
    parts = []
    if problem.n_ieq_constr:
        parts.append(np.asarray(out["G"], dtype=float).reshape(-1))
    if problem.n_eq_constr:
        parts.append(np.abs(np.asarray(out["H"], dtype=float).reshape(-1)) - eq_tol)
    G = np.concatenate(parts) if parts else np.zeros(0)
    if F.shape != (m,) or G.shape != (k,):
        return Outcome.failure(m, k, "error", f"expected {m} objectives and {k} constraints, "
                               f"got {F.size} and {G.size}", seconds)
    aux = _aux_of(out.get("aux"))
    if not (np.all(np.isfinite(F)) and np.all(np.isfinite(G))):
        why = _numpy_invalid(caught)
        return Outcome(F, G, "invalid", "non-finite objective or constraint"
                       + (f" (numpy: {why})" if why else ""), seconds, aux=aux)
    return Outcome(F, G, STATUS_OK, "", seconds, aux=aux)


def _aux_of(value: Any) -> dict:
    """The one design's auxiliary outputs from a problem's ``out["aux"]``: a dict, or a
    sequence holding one dict (pymoo passes the problem's list of per-row dicts on as an
    object array)."""
    if value is None:
        return {}
    if isinstance(value, dict):
        return value
    items = list(np.ravel(np.asarray(value, dtype=object)))
    if len(items) != 1 or not isinstance(items[0], dict):
        raise TypeError("a problem's 'aux' output must be one dict per design")
    return items[0]
