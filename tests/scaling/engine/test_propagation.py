"""Polynomial chaos propagation (scaling.engine.propagation) against closed forms: the
Ishigami function's mean, variance and first-order Sobol indices, a linear function of
normal factors, the least-squares leave-one-out identity, and the summary's failure rule."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypate.scaling.engine.propagation import (
    Expansion,
    Uncertain,
    collocation_nodes,
    default_samples,
    expand,
    robust_value,
    summary,
)

W = 0.5  # uniform factors U(0.5, 1.5) mapped to x in [-pi, pi]
A, B = 7.0, 0.1


def ishigami(F: np.ndarray) -> np.ndarray:
    x = np.pi * (F - 1.0) / W
    return np.sin(x[:, 0]) + A * np.sin(x[:, 1]) ** 2 + B * x[:, 2] ** 4 * np.sin(x[:, 0])


def test_ishigami_moments_and_sobol_indices_match_closed_forms():
    # Closed forms (Ishigami & Homma 1990): mean a/2; V = a^2/8 + b pi^4/5 + b^2 pi^8/18 + 1/2;
    # V1 = (1 + b pi^4/5)^2 / 2, V2 = a^2/8, V3 = 0. Order 8 on 512 Sobol nodes: measured
    # within 0.2 % (mean 0.03 %, std 0.005 %, S1 0.15 %, S2 0.17 %); asked 1 %.
    inputs = [Uncertain(f"x{i}", "uniform", W) for i in range(3)]
    e = expand(ishigami, inputs, order=8, samples=512)
    var = A**2 / 8 + B * math.pi**4 / 5 + B**2 * math.pi**8 / 18 + 0.5
    S = e.first_order_sobol()[:, 0]
    assert e.mean[0] == pytest.approx(A / 2, rel=0.01)
    assert e.std[0] == pytest.approx(math.sqrt(var), rel=0.01)
    assert S[0] == pytest.approx(0.5 * (1 + B * math.pi**4 / 5) ** 2 / var, rel=0.01)
    assert S[1] == pytest.approx(A**2 / 8 / var, rel=0.01)
    assert abs(S[2]) < 0.01 * S[0]


def test_linear_function_of_normal_factors_is_exact():
    # y = 2 F_p - 3 F_q, F ~ N(1, s): mean -1, std sqrt((2 s_p)^2 + (3 s_q)^2),
    # S_p = (2 s_p)^2 / var: an order-1 chaos represents it exactly (to rounding).
    inputs = [Uncertain("p", "normal", 0.03), Uncertain("q", "normal", 0.05)]
    e = expand(lambda F: 2 * F[:, 0] - 3 * F[:, 1], inputs, order=1, samples=8)
    var = (2 * 0.03) ** 2 + (3 * 0.05) ** 2
    assert e.mean[0] == pytest.approx(-1.0, rel=1e-10)
    assert e.std[0] == pytest.approx(math.sqrt(var), rel=1e-10)
    assert e.first_order_sobol()[:, 0] == pytest.approx([0.0036 / var, 0.0225 / var],
                                                         rel=1e-8)


def test_lognormal_factor_moments():
    # F = exp(N(0, s)): E F = exp(s^2/2), Var F = (exp(s^2) - 1) exp(s^2); order 4 on 64
    # nodes within 0.1 % (measured 1e-5).
    s = 0.2
    e = expand(lambda F: F[:, 0], [Uncertain("k", "lognormal", s)], order=4, samples=64)
    assert e.mean[0] == pytest.approx(math.exp(s * s / 2), rel=1e-3)
    assert e.std[0] == pytest.approx(math.sqrt((math.exp(s * s) - 1) * math.exp(s * s)),
                                     rel=1e-3)


def test_leave_one_out_equals_refitting_without_the_node():
    inputs = [Uncertain("a", "normal", 0.1), Uncertain("b", "uniform", 0.2)]
    nodes = collocation_nodes(inputs, 16, seed=3)
    values = np.c_[np.exp(nodes[:, 0]) * nodes[:, 1], np.sin(3 * nodes[:, 1])]
    e = Expansion(inputs, nodes, values, order=2)
    loo = e.leave_one_out()
    for i in (0, 7, 15):
        keep = np.arange(16) != i
        refit = Expansion(inputs, nodes[keep], values[keep], order=2)
        assert refit(nodes[i:i + 1])[0] == pytest.approx(loo[i], rel=1e-8, abs=1e-12)


def test_nodes_follow_the_distributions():
    # 4096 scrambled Sobol nodes: sample mean within 1e-3 of 1, std within 1 % of the width
    u = [Uncertain("n", "normal", 0.03), Uncertain("u", "uniform", 0.02)]
    F = collocation_nodes(u, 4096, seed=0)
    assert F.shape == (4096, 2)
    assert np.mean(F, axis=0) == pytest.approx([1.0, 1.0], abs=1e-3)
    assert np.std(F[:, 0]) == pytest.approx(0.03, rel=0.01)
    assert np.std(F[:, 1]) == pytest.approx(0.02 / math.sqrt(3), rel=0.01)
    assert np.all(np.abs(F[:, 1] - 1.0) <= 0.02)


def test_default_samples_oversample_the_terms_twice_as_a_power_of_two():
    assert default_samples(5, 2) == 64   # 21 terms -> 42 -> 64
    assert default_samples(2, 1) == 8    # 3 terms -> 6 -> 8


def test_too_few_samples_and_bad_widths_are_refused():
    with pytest.raises(ValueError, match="needs at least"):
        expand(lambda F: F[:, 0], [Uncertain("a", "normal", 0.1)] * 2, order=3, samples=5)
    with pytest.raises(ValueError, match=r"must be in \(0, 0.2\]"):
        Uncertain("p0", "normal", 0.5)
    with pytest.raises(ValueError, match="must be one of"):
        Uncertain("p0", "gamma", 0.1)


def test_summary_counts_a_failure_as_infinite():
    ok = summary(np.arange(1.0, 11.0))
    assert ok["mean"] == 5.5 and ok["q50"] == 5.5 and robust_value(ok, "mean+2std") == \
        pytest.approx(5.5 + 2 * np.std(np.arange(1.0, 11.0), ddof=1))
    failed = summary(np.r_[np.arange(1.0, 10.0), np.inf])
    assert failed["mean"] == math.inf and failed["q50"] == 5.0 and failed["q90"] == 9.0
    assert summary(np.r_[np.arange(1.0, 9.0), np.inf, np.inf])["q90"] == math.inf
