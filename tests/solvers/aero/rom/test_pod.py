"""POD and POD-kriging (solvers/aero/rom/pod.py): Eq. (A.14) energy criterion,
interpolation, Eq. (2.59) Jacobian against finite differences."""
from __future__ import annotations

import numpy as np
import pytest
from conftest import assert_matches_richardson, richardson_jacobian
from hypate.solvers.aero.rom.pod import PodBasis, PodKriging


def test_pod_energy_criterion_picks_fewest_modes() -> None:
    rng = np.random.default_rng(0)
    basis = np.linalg.qr(rng.normal(size=(80, 6)))[0]
    coef = rng.normal(size=(200, 6)) * np.array([100, 30, 10, 1, 0.1, 0.01])
    Y = 5.0 + coef @ basis.T
    pod = PodBasis(0.005).fit(Y)
    s2 = pod.singular_values_**2
    tail = np.sqrt(1 - np.cumsum(s2) / s2.sum())
    # Eq. (A.14): the chosen N_p is the first with eps_POD < 0.5 %, N_p - 1 is not
    assert pod.error_ < 0.005 and tail[pod.modes_.shape[1] - 2] >= 0.005
    # reconstruction error equals the discarded energy (Eq. A.14 identity, 1e-10)
    E = Y - pod.reconstruct(pod.project(Y))
    Yc = Y - Y.mean(0)
    assert np.linalg.norm(E) / np.linalg.norm(Yc) == pytest.approx(pod.error_, rel=1e-10)


def test_pod_kriging_interpolates_and_jacobian_matches_fd() -> None:
    rng = np.random.default_rng(1)
    D = rng.uniform(-1, 1, size=(40, 3))
    x = np.linspace(0, 1, 20)
    Y = np.sin(np.outer(D[:, 0], 3 * x)) + np.outer(D[:, 1] ** 2, x) + 0.3 * D[:, 2:3]
    pk = PodKriging(1e-6, trend="linear", n_restarts=0, rng=0).fit(D, Y)
    # a GP interpolates its data (invariant): POD truncation 1e-6 and nugget 1e-8 bound it
    rel = np.abs(pk.predict(D) - Y).max() / np.abs(Y).max()
    assert rel < 1e-4
    d0 = np.array([0.1, -0.3, 0.4])
    _, J = pk.predict_jacobian(d0)
    fd, bound = richardson_jacobian(lambda d: pk.predict(d[None])[0], d0, 2e-3)
    # Eq. (2.59) vs extrapolated central differences, within their measured error
    assert_matches_richardson(J, fd, bound, "dy/dd")
