"""Grey-box (histories) surrogates and the success classifier (scaling.engine.histories,
.failures): exact composition, FD gradients, the believer, calibration (issue 41)."""
from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import assert_matches_richardson, richardson_jacobian
from hypate.scaling.engine.failures import SuccessModel, held_out_calibration
from hypate.scaling.engine.histories import (
    ENERGY,
    Composition,
    HistoriesModel,
    HistoryBasis,
    normal_samples,
)
from hypate.scaling.engine.surrogate import fit_surrogate

T = np.linspace(0.0, 1.0, 6)
BOUNDS = np.array([[0.0, 1.0], [0.5, 2.0]])


def _histories(X: np.ndarray) -> np.ndarray:
    """Two smooth groups of histories of a 2-D design: a growth and a decay over T."""
    a, b = X[:, :1], X[:, 1:2]
    u = np.sin(2.0 * a) * T + b * T**2
    v = np.exp(-b * T) + 0.3 * a
    return np.hstack([u, v])


def _composition() -> Composition:
    target = _histories(np.array([[0.4, 1.2]]))[0]
    g = (np.arange(6), 6 + np.arange(6))
    inv = [1.0 / np.sum(target[k] ** 2) for k in g]
    return Composition(targets=target, groups=g,
                       weights=np.array([[inv[0], 0.0], [0.0, inv[1]]]))


def _model(n: int = 14, seed: int = 0, transform: str = "none") -> HistoriesModel:
    rng = np.random.default_rng(seed)
    X = BOUNDS[:, 0] + rng.random((n, 2)) * (BOUNDS[:, 1] - BOUNDS[:, 0])
    comp = _composition()
    H = _histories(X)
    basis = HistoryBasis.fit(H, comp)
    A = basis.coefficients(H, comp)
    gp = fit_surrogate(X, A, BOUNDS, rng=seed)
    return HistoriesModel(gp, basis, comp, transform, normal_samples(128, A.shape[1], 1),
                          X, A)


def test_composition_is_the_relative_rms_error() -> None:
    comp = _composition()
    H = _histories(np.array([[0.1, 0.7], [0.4, 1.2]]))
    J = comp(H)
    t = comp.targets
    expected = np.linalg.norm(H[0, :6] - t[:6]) / np.linalg.norm(t[:6])
    assert J[0, 0] == pytest.approx(expected, rel=1e-14)
    np.testing.assert_allclose(J[1], 0.0, atol=1e-15)  # the target itself


def test_pod_reconstructs_and_the_composed_mean_interpolates_the_data() -> None:
    m = _model()
    H = _histories(m.X)
    comp = m.composition
    rec = np.hstack([mu + m.A[:, sl] @ Phi.T for mu, Phi, sl in
                     zip(m.basis.means, m.basis.modes, m.basis.slices)])
    for g, mu in zip(comp.groups, m.basis.means):  # the kept energy: 1 - 1e-6
        dropped = np.linalg.norm(rec[:, g] - H[:, g]) ** 2
        assert dropped <= (1.0 - ENERGY) * np.linalg.norm(H[:, g] - mu) ** 2 * (1 + 1e-9)
    mean, std = m.predict_moments(m.X)
    # at a training design the coefficients' kriging has (almost) no variance: the J of
    # the reconstructed histories (the nugget 1e-8 of the standardized outputs)
    np.testing.assert_allclose(mean, comp(rec), rtol=1e-5)
    assert np.all(std < 1e-4)  # sqrt(nugget) of the coefficients, composed


@pytest.mark.parametrize("transform", ["none", "log"])
def test_gradients_match_finite_differences(transform: str) -> None:
    m = _model(transform=transform)
    X = np.array([[0.23, 0.81], [0.77, 1.63]])
    _, _, dmean, dstd = m.predict_with_gradients(X)
    for k, x in enumerate(X):
        for value, analytic in ((0, dmean[k]), (1, dstd[k])):
            fd, bound = richardson_jacobian(
                lambda z, v=value: m.predict_moments(z[None])[v][0], x, 1e-3)
            assert_matches_richardson(analytic, fd, bound, f"output {value} at {x}")


def test_the_composed_mean_learns_the_valley_better_than_kriging_j() -> None:
    """Where the histories cross the target J has a kink (a V); the histories are smooth.
    On 14 designs the composed prediction of J near the target beats kriging J itself
    (measured: mean absolute error 0.005 against 0.03 on this function)."""
    m = _model()
    rng = np.random.default_rng(5)
    Xt = np.array([0.4, 1.2]) + 0.08 * (rng.random((30, 2)) - 0.5) * [1.0, 1.5]
    truth = m.composition(_histories(Xt))
    composed = m.predict_moments(Xt)[0]
    direct = fit_surrogate(m.X, m.composition(_histories(m.X)), BOUNDS, rng=0)
    plain = direct.predict_moments(Xt)[0]
    err_c = np.mean(np.abs(composed - truth))
    err_p = np.mean(np.abs(plain - truth))
    assert err_c < 0.5 * err_p


def test_the_believer_keeps_the_model_and_adds_the_predicted_coefficients() -> None:
    m = _model()
    x_new = np.array([[0.55, 1.4]])
    a_before = m.coefficients.predict_moments(x_new)[0]
    c = m.condition(np.vstack([m.X, x_new]), np.zeros((len(m.X) + 1, 2)))
    a_after, a_std = c.coefficients.predict_moments(x_new)
    np.testing.assert_allclose(a_after, a_before, rtol=1e-6, atol=1e-9)  # the means stay
    assert np.all(a_std < 1e-3 * np.abs(a_before).max())                # the variance goes
    # the believed J: the composition of the predicted coefficients, spread gone
    h = np.hstack([mu + a_before[:, sl] @ Phi.T for mu, Phi, sl in
                   zip(m.basis.means, m.basis.modes, m.basis.slices)])
    mean_after, std_after = c.predict_moments(x_new)
    np.testing.assert_allclose(mean_after, m.composition(h), rtol=1e-4)
    assert np.all(std_after < 1e-4)
    with pytest.raises(ValueError, match="extends"):
        m.condition(m.X[::-1], np.zeros((len(m.X), 2)))


def test_leave_one_out_of_the_composition() -> None:
    m = _model(n=20)
    mean, std = m.leave_one_out()
    truth = m.composition(_histories(m.X))
    assert mean.shape == truth.shape and np.all(std > 0)
    z = (truth - mean) / std
    assert np.median(np.abs(z)) < 3.0  # the held-out values are within the bands


# -- the success classifier -----------------------------------------------------------------
def _failures(n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    X = rng.random((n, 2))
    return X, ~((X[:, 0] > 0.6) & (X[:, 1] > 0.4))  # a failing corner


def test_success_model_separates_a_failing_region_and_its_gradient() -> None:
    X, ok = _failures(40, 0)
    box = np.array([[0.0, 1.0], [0.0, 1.0]])
    m = SuccessModel(X, ok, box)
    p = m.probability(np.array([[0.2, 0.2], [0.9, 0.9]]))
    assert p[0] > 0.75 and p[1] < 0.35
    x = np.array([0.6, 0.5])
    fd, bound = richardson_jacobian(lambda z: m(z[None])[0], x, 1e-2)
    # the model's own central difference (step 1e-4) against Richardson's: the O(h^2)
    # truncation of a step 1e-4 on a unit-length-scale process is ~1e-8 of the slope
    np.testing.assert_allclose(m.jacobian(x[None])[0], fd, rtol=1e-5, atol=1e-6)
    assert m(np.array([[0.2, 0.2]]))[0, 0] < 0.0 < m(np.array([[0.9, 0.9]]))[0, 0]


def test_success_model_is_calibrated_on_held_out_evaluations() -> None:
    X, ok = _failures(40, 1)
    cal = held_out_calibration(X, ok, np.array([[0.0, 1.0], [0.0, 1.0]]))
    assert cal.brier < 0.5 * cal.base_rate_brier  # far better than the base rate
    # the held-out evaluations predicted likely to fail mostly did, those predicted
    # likely to succeed mostly did
    pred = cal.predicted
    assert cal.observed[pred < 0.5].mean() < 0.35 and cal.observed[pred > 0.5].mean() > 0.9


# -- the design-point (min-max) acquisitions -------------------------------------------------
@pytest.mark.parametrize("name", ["mmei", "mmlcb", "mmlogei"])
@pytest.mark.parametrize("joint", [True, False])
def test_min_max_acquisitions_and_their_gradients(name: str, joint: bool) -> None:
    """Both on the joint samples of a histories model and on independent normal samples of
    a kriging model's moments: the value is the samples' statistic of max_j J_j, and the
    gradient matches finite differences (common random numbers: smooth in x)."""
    from hypate.scaling.engine.acquisition import ACQUISITIONS

    m = _model()
    model = m if joint else fit_surrogate(m.X, m.composition(_histories(m.X)), BOUNDS, rng=0)
    cls = ACQUISITIONS[name]
    acq = (cls(model, 0.05, rng=0) if name == "mmei" else cls(model, 1.0, rng=0)
           if name == "mmlcb" else cls(model, 0.05, 1e-3, rng=0))
    X = np.array([[0.23, 0.81], [0.45, 1.25], [0.7, 1.9]])
    val, grad = acq.value_and_gradient(X)
    for k, x in enumerate(X):
        fd, bound = richardson_jacobian(lambda z: acq(z[None]), x, 1e-4)
        assert_matches_richardson(grad[k], fd[0], bound[0], f"{name} at {x}", safety=8.0)
    if name == "mmei":
        # EI of max(J) over b: zero where every sample is worse, positive near the target
        assert np.all(val >= 0.0)
        best = cls(model, 10.0, rng=0)(X)  # a bar every sample beats: b - E[max J]
        Y = (model.sample_with_gradients(X)[0] if joint else None)
        if Y is not None:
            np.testing.assert_allclose(best, 10.0 - Y.max(axis=2).mean(axis=1), rtol=1e-12)


def test_min_max_log_ei_is_log_ei_where_it_improves_and_smooth_where_it_does_not() -> None:
    """mmlogei = log(mean_s softplus_tau(b - c_s)) (c_s = max_j J_j of sample s): its
    gradient matches finite differences near and far from any improvement; with a bar every
    sample beats by >> tau it is log(b - E[c]) (the EI's log); with a bar no sample reaches
    it is log tau + max_s (b - c_s) / tau (finite, where the EI is exactly 0), to 1e-9."""
    from hypate.scaling.engine.acquisition import MinMaxEI, MinMaxLogEI

    m = _model()
    X = np.array([[0.23, 0.81], [0.45, 1.25], [0.7, 1.9]])
    c = m.sample_with_gradients(X)[0].max(axis=2)  # (N, S)
    tau = 1e-3
    for b in (0.05, float(c.min()) - 0.01, float(c.max()) + 10.0):
        acq = MinMaxLogEI(m, b, tau, rng=0)
        val, grad = acq.value_and_gradient(X)
        for k, x in enumerate(X):
            fd, bound = richardson_jacobian(lambda z: acq(z[None]), x, 1e-5)  # noqa: B023
            assert_matches_richardson(grad[k], fd[0], bound[0], f"mmlogei b={b} at {x}",
                                      safety=8.0)
        z = (b - c) / tau
        with np.errstate(divide="ignore"):
            direct = np.log(np.mean(tau * np.logaddexp(0.0, z), axis=1))
        finite = np.isfinite(direct)  # the direct formula underflows far from any gain
        assert finite.any() or b < float(c.min())
        np.testing.assert_allclose(val[finite], direct[finite], rtol=1e-9)
    generous = MinMaxLogEI(m, float(c.max()) + 10.0, tau, rng=0)(X)
    np.testing.assert_allclose(generous, np.log(MinMaxEI(m, float(c.max()) + 10.0, rng=0)(X)),
                               rtol=1e-9)
    # no admissible design yet (b = inf): the mean criterion, MinMaxEI's +inf everywhere
    val, grad = MinMaxLogEI(m, math.inf, tau, rng=0).value_and_gradient(X)
    np.testing.assert_allclose(val, -c.mean(axis=1), rtol=1e-12)
    assert np.all(np.isfinite(grad))
    b = float(c.min()) - 5.0  # no sample improves: the EI is 0 everywhere
    assert np.all(MinMaxEI(m, b, rng=0)(X) == 0.0)
    np.testing.assert_allclose(MinMaxLogEI(m, b, tau, rng=0)(X),
                               np.log(tau) + (b - c).max(axis=1) / tau
                               + np.log(np.sum(np.exp((c.min(axis=1, keepdims=True) - c) / tau),
                                               axis=1) / c.shape[1]), rtol=1e-9)


# -- the stopping rule -----------------------------------------------------------------------
def test_stopping_rule_needs_all_three_tests() -> None:
    from hypate.scaling.engine.stopping import StoppingRule, check

    rule = StoppingRule(min_iterations=2, patience=2, tolerance=0.01, z_max=2.0, gain=0.01)
    F = np.array([[0.2, 0.3], [0.1, 0.12], [0.1, 0.11], [0.3, 0.1]])
    its = np.array([0, 1, 3, 4])
    feas = np.ones(4, bool)
    loo = (F + 0.001, np.full(F.shape, 0.01))        # z = -0.1 at every row
    stop, ev = check(rule, 6, F, feas, its, loo, 2, 0.0005)
    assert stop and ev["stalled"] and ev["surrogate_knows_it"] and ev["no_promise_left"]
    assert ev["improvement"] == 0.0 and ev["z"] == pytest.approx([-0.1, -0.1])
    # before iteration 5 the best was 0.12 (iterations < 3): improved by 9 %, not stalled
    assert not check(rule, 5, F, feas, its, loo, 2, 0.0005)[0]
    # the surrogate did not expect the design point
    far = (F + 0.1, np.full(F.shape, 0.01))
    assert not check(rule, 6, F, feas, its, far, 2, 0.0005)[0]
    # the acquisition still promises 5 %
    assert not check(rule, 6, F, feas, its, loo, 2, 0.0055)[0]
    # never before min_iterations
    assert not check(StoppingRule(min_iterations=6), 6, F, feas, its, loo, 2, 0.0)[0]
