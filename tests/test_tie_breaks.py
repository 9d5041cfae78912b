"""Tie-breaks are explicit (issue 21, machine independence).

numpy's default ``argsort`` (``kind="quicksort"``) dispatches by CPU to a SIMD sort
(x86-simd-sort: AVX-512, AVX2, or the scalar introsort), and the three order equal keys
differently: on the AMD EPYC here an array of 40-fold repeated values sorts its ties one way
with AVX2 and another with ``NPY_DISABLE_CPU_FEATURES="AVX512_ICL X86_V4 X86_V3"``. Where a
choice follows from an order (the exploitation starts among tied infeasible designs, the
Pareto points an HVEI keeps, degenerate eigenvalues, report rows), the order must not be
the CPU's: every index sort in the package is stable (ties keep their index order).
"""
from __future__ import annotations

import ast

from conftest import REPO

#: Calls whose order of equal keys is the CPU's unless ``kind="stable"``.
ORDER_CALLS = {"argsort", "sort_values"}
PACKAGES = ("scaling", "solvers", "studies")


def _unstable_calls() -> list[str]:
    found = []
    for package in PACKAGES:
        for path in sorted((REPO / package).rglob("*.py")):
            tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
            for node in ast.walk(tree):
                if (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
                        and node.func.attr in ORDER_CALLS):
                    kinds = [k.value for k in node.keywords if k.arg == "kind"]
                    if not (kinds and isinstance(kinds[0], ast.Constant)
                            and kinds[0].value == "stable"):
                        found.append(f"{path.relative_to(REPO)}:{node.lineno}")
    return found


def test_every_index_sort_breaks_ties_by_index():
    assert _unstable_calls() == []

