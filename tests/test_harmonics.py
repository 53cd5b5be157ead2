"""Harmonic analysis and the one-mode error estimate, against closed forms."""

from __future__ import annotations

import numpy as np
import pytest

from ked_quasi import Scene, solve_quasi_static
from ked_quasi.harmonics import (
    harmonic_amplitudes,
    one_mode_dynamic_estimate,
    one_mode_error,
    predicted_validity_limit,
    significant_harmonic,
)

from .conftest import MASS_MODEL_CASES

THETA = np.arange(72) * 2 * np.pi / 72


def test_amplitudes_of_known_series():
    x = 1.5 + 2.0 * np.cos(THETA) + 0.5 * np.sin(3 * THETA + 0.3)
    a = harmonic_amplitudes(x)
    assert a[0] == pytest.approx(1.5)
    assert a[1] == pytest.approx(2.0)
    assert a[3] == pytest.approx(0.5)
    assert significant_harmonic(x, fraction=0.2) == 3
    assert significant_harmonic(x, fraction=0.3) == 1


def test_single_harmonic_amplification_closed_form():
    # SDOF steady state under a k-th harmonic load: amplitude ratio 1 / (1 - (k r)^2) without damping
    r, k = 0.2, 2
    x = np.cos(k * THETA)
    est = one_mode_dynamic_estimate(x, r)
    assert np.allclose(est, x / (1 - (k * r) ** 2), atol=1e-12)
    assert one_mode_error(x, r) == pytest.approx((k * r) ** 2)  # 1 - (1 - (kr)^2)
    # with damping the amplitude is 1/sqrt((1-x^2)^2 + (2 zeta x)^2)
    est = one_mode_dynamic_estimate(x, r, damping_ratio=0.05)
    xr = k * r
    assert harmonic_amplitudes(est)[k] == pytest.approx(1 / np.hypot(1 - xr**2, 2 * 0.05 * xr), rel=1e-12)


def test_validity_limit_single_harmonic():
    # error (k r)^2 = tol -> r = sqrt(tol) / k
    x = np.cos(2 * THETA)
    assert predicted_validity_limit(x, 0.05) == pytest.approx(np.sqrt(0.05) / 2, abs=2e-3)


def test_thesis_loads_have_few_significant_harmonics(thesis):
    # a crank-rocker's inertia loads are smooth: a handful of crank harmonics carry them
    scene = Scene(thesis, MASS_MODEL_CASES["tip"], 300.0, 5.0)
    res = solve_quasi_static(scene)
    k = significant_harmonic(res.loads, fraction=0.05)
    assert 2 <= k <= 8
