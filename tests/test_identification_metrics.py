"""Fit metrics of an identified model (ayotte-2015 identification): free-run against
one-step-ahead fit on a known ARX system, against their analytic values."""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("pandas")

A_, B_, SIGMA_U, SIGMA_E = 0.8, 1.0, 1.0, 0.5


def _arx(n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """y_k = a y_{k-1} + b u_{k-1} + e_k, u and e white Gaussian, stationary start."""
    rng = np.random.default_rng(seed)
    u = SIGMA_U * rng.standard_normal(n)
    e = SIGMA_E * rng.standard_normal(n)
    y = np.empty(n)
    y[0] = e[0]
    for k in range(1, n):
        y[k] = A_ * y[k - 1] + B_ * u[k - 1] + e[k]
    return u[:, None], y[:, None]


def _model():  # type: ignore[no-untyped-def]
    """The ARX system in innovations form: x⁺ = a x + b u + K e, y = x + e, K = a."""
    from controller.design.hexicon_identify import Identified

    k = A_
    cov = SIGMA_E**2 * np.array([[1.0, k], [k, k * k]])  # [[R, Sᵀ], [S, Q]], v = e, w = K e
    z = np.zeros(1)
    return Identified(
        np.array([[A_]]), np.array([[B_]]), np.array([[1.0]]), np.array([[0.0]]), 1, [], z, z, cov
    )


def test_free_run_and_one_step_fits_equal_their_analytic_values() -> None:
    """Stationary ARX: var y = (b²σ_u² + σ_e²)/(1 − a²). One step ahead the error is e:
    fit = 1 − σ_e/σ_y = 73.17 %. Free run the error is e filtered by 1/(1 − a q⁻¹), variance
    σ_e²/(1 − a²): fit = 1 − σ_e/√(b²σ_u² + σ_e²) = 55.28 %. 60 000 samples: within 0.6
    points (sampling error ~0.2). The gain from the noise covariance is K = a exactly."""
    from controller.design.hexicon_identify import (
        fit_percent,
        predict_one_step,
        predictor_gain,
        simulate,
    )

    m = _model()
    k = predictor_gain(m)
    assert k[0, 0] == pytest.approx(A_, abs=1e-9)
    u, y = _arx(60_000, 3)
    var_y = (B_**2 * SIGMA_U**2 + SIGMA_E**2) / (1.0 - A_**2)
    one_step = 100.0 * (1.0 - SIGMA_E / math.sqrt(var_y))
    free_run = 100.0 * (1.0 - SIGMA_E / math.sqrt(B_**2 * SIGMA_U**2 + SIGMA_E**2))
    assert one_step == pytest.approx(73.17, abs=0.01) and free_run == pytest.approx(55.28, abs=0.01)
    assert fit_percent(y, predict_one_step(m, k, u, y))[0] == pytest.approx(one_step, abs=0.6)
    assert fit_percent(y, simulate(m, u))[0] == pytest.approx(free_run, abs=0.6)
    # K = 0: the one-step predictor is the free run, sample for sample
    np.testing.assert_allclose(predict_one_step(m, np.zeros((1, 1)), u, y), simulate(m, u))


def test_predictor_gain_needs_a_noise_model() -> None:
    from controller.design.hexicon_identify import Identified, predictor_gain

    z = np.zeros(1)
    m = Identified(np.eye(1), np.eye(1), np.eye(1), np.zeros((1, 1)), 1, [], z, z)
    with pytest.raises(ValueError, match="no noise covariance"):
        predictor_gain(m)
