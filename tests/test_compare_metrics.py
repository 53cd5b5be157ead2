"""Comparison metrics on synthetic histories with known answers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from compare.metrics import (
    all_pairs,
    amplification,
    component_metrics,
    history_error,
    max_abs_error,
    pair_metrics,
    peak_angle,
    peak_error,
    phase_shift,
    rms_error,
    wrap_angle,
)

THETA = np.arange(72) * (2 * np.pi / 72)


def test_identical_histories_agree_perfectly():
    y = 1e-3 * np.sin(THETA)
    m = component_metrics("dx", THETA, y, y, tolerance=0.1)
    assert m.max_abs_error == 0 and m.rms_error == 0 and m.history_error == 0
    assert m.amplification == 1 and m.phase_shift == 0 and m.holds and m.units == "m"


def test_scaled_history():
    qs = 2e-3 * np.cos(THETA)
    dyn = 1.25 * qs
    assert max_abs_error(qs, dyn) == pytest.approx(0.5e-3)
    assert rms_error(qs, dyn) == pytest.approx(0.5e-3 / math.sqrt(2))
    assert history_error(qs, dyn) == pytest.approx(0.2)
    assert amplification(qs, dyn) == pytest.approx(1.25)
    m = component_metrics("dy", THETA, qs, dyn, tolerance=0.1)
    assert not m.holds
    assert component_metrics("dy", THETA, qs, dyn, tolerance=0.25).holds


def test_phase_shift_of_the_peak_subgrid_and_direction():
    lag = math.radians(7.0)  # not a multiple of the 5 deg grid
    qs = np.exp(np.cos(THETA - 1.0) * 3)
    dyn = np.exp(np.cos(THETA - 1.0 - lag) * 3)
    assert peak_angle(THETA, qs) == pytest.approx(1.0, abs=math.radians(0.3))
    assert phase_shift(THETA, qs, dyn) == pytest.approx(lag, abs=math.radians(0.5))
    # cw: the crank angle decreases with time, so a peak at a larger angle comes earlier
    assert phase_shift(THETA, qs, dyn, direction_sign=-1) == pytest.approx(-lag, abs=math.radians(0.5))


def test_phase_shift_wraps_across_zero():
    qs = np.cos(THETA - math.radians(355))
    dyn = np.cos(THETA - math.radians(5))
    assert phase_shift(THETA, np.maximum(qs, 0), np.maximum(dyn, 0)) == pytest.approx(math.radians(10), abs=1e-2)
    assert wrap_angle(3 * math.pi) == pytest.approx(math.pi)
    assert wrap_angle(-math.pi) == pytest.approx(math.pi)


def test_degenerate_peaks():
    zero = np.zeros_like(THETA)
    assert history_error(zero, zero) == 0.0
    assert amplification(zero, np.ones_like(THETA)) == math.inf
    assert history_error(np.ones_like(THETA), zero) == math.inf


def test_bad_inputs_are_rejected():
    with pytest.raises(ValueError, match="shape"):
        component_metrics("dx", THETA, np.zeros(3), np.zeros(3), 0.1)
    bad = np.zeros_like(THETA)
    bad[3] = np.nan
    with pytest.raises(ValueError, match="non-finite"):
        component_metrics("dx", THETA, bad, np.zeros_like(THETA), 0.1)


def test_scene_metrics_verdict_and_speed_ratio():
    qs = {"dx": np.sin(THETA), "rotation": np.cos(THETA)}
    dyn = {"dx": 1.05 * np.sin(THETA), "rotation": 1.5 * np.cos(THETA)}
    m = pair_metrics("quasi_static", "dynamic", THETA, qs, dyn, omega=-10.0, omega1_min=40.0, tolerance=0.1)
    assert m.speed_ratio == pytest.approx(0.25) and m.omega == 10.0
    assert [c.component for c in m.components] == ["dx", "rotation"]  # no vector without dy
    assert m.component("dx").holds and not m.component("rotation").holds
    # the rotation (|1 - 1.5| / 1.5 = 1/3) never enters the verdict: without dy it is dx's 0.05 / 1.05
    assert m.verdict_error == pytest.approx(0.05 / 1.05) and m.holds
    assert m.worst_component_error == pytest.approx(1 / 3)
    assert m.max_relative_error == pytest.approx(1 / 3)  # the old key keeps the old (worst-component) number
    assert m.max_amplification == pytest.approx(1.5)


def test_verdict_is_the_vector_error_and_ignores_the_rotation():
    # d_qs = (cos, sin), d_ref = 1.05 (cos, sin): |d_qs - d_ref| = 0.05, max |d_ref| = 1.05 -> 0.05 / 1.05
    # for the vector (and for dx, dy alone); a rotation 50 % off (|1 - 2| / 2) does not change the verdict
    a = {"dx": np.cos(THETA), "dy": np.sin(THETA), "rotation": np.cos(THETA)}
    b = {"dx": 1.05 * np.cos(THETA), "dy": 1.05 * np.sin(THETA), "rotation": 2.0 * np.cos(THETA)}
    m = pair_metrics("quasi_static", "dynamic", THETA, a, b, omega=1.0, omega1_min=10.0, tolerance=0.1)
    assert m.verdict_error == pytest.approx(0.05 / 1.05) and m.holds
    assert m.worst_component_error == pytest.approx(0.5) and not m.component("rotation").holds
    # a tolerance just below the vector error fails it
    tight = pair_metrics("quasi_static", "dynamic", THETA, a, b, omega=1.0, omega1_min=10.0, tolerance=0.04)
    assert not tight.holds


def test_vector_error_is_not_the_worst_component():
    # dx is small and far off, dy large and exact: dx alone is |0.01 - 0.02| / 0.02 = 50 % off its own
    # peak, the vector only 0.01 / |(0.02, 1)| ~ 1 % (the error relative to the peak of |d|)
    a = {"dx": 0.01 * np.ones_like(THETA), "dy": np.ones_like(THETA)}
    b = {"dx": 0.02 * np.ones_like(THETA), "dy": np.ones_like(THETA)}
    m = pair_metrics("quasi_static", "dynamic", THETA, a, b, omega=1.0, omega1_min=10.0, tolerance=0.1)
    assert m.component("dx").history_error == pytest.approx(0.5)
    assert m.verdict_error == pytest.approx(0.01 / math.hypot(0.02, 1.0)) and m.holds


def test_a_pair_without_translations_has_no_verdict():
    a, b = {"rotation": np.cos(THETA)}, {"rotation": np.cos(THETA)}
    m = pair_metrics("quasi_static", "dynamic", THETA, a, b, omega=1.0, omega1_min=10.0, tolerance=0.1)
    assert math.isnan(m.verdict_error) and not m.holds  # errs on the safe side


def test_vector_history_and_peak_errors_have_closed_forms():
    # a = (cos, sin) traces the unit circle; b is the same circle turned by 60 deg and scaled by 2:
    # |a - b| is constant, |a - b|^2 = 1 + 4 - 4 cos 60 deg = 3, peak |b| = 2 -> history error sqrt(3)/2,
    # peak error |1 - 2| / 2 = 1/2, amplification 2
    a = {"dx": np.cos(THETA), "dy": np.sin(THETA)}
    b = {"dx": 2 * np.cos(THETA + math.pi / 3), "dy": 2 * np.sin(THETA + math.pi / 3)}
    m = pair_metrics("quasi_static", "dynamic", THETA, a, b, omega=1.0, omega1_min=1.0, tolerance=0.1)
    v = m.component("vector")
    assert v.history_error == pytest.approx(math.sqrt(3) / 2) and v.peak_error == pytest.approx(0.5)
    assert v.amplification == pytest.approx(2.0) and v.units == "m"
    assert peak_error(np.ones(4), 1.25 * np.ones(4)) == pytest.approx(0.2)
    assert m.verdict_error == pytest.approx(math.sqrt(3) / 2) and not m.holds  # the vector's closed form


def test_every_pair_is_measured_against_the_higher_fidelity_solver():
    h = {"dynamic": {"dx": np.sin(THETA)}, "quasi_static": {"dx": 0.5 * np.sin(THETA)},
         "linear": {"dx": 0.9 * np.sin(THETA)}}
    pairs = all_pairs(THETA, h, {"quasi_static": 0, "linear": 5, "dynamic": 10}, omega=1.0, omega1_min=10.0,
                      tolerance=0.1)
    assert set(pairs) == {"quasi_static_vs_dynamic", "quasi_static_vs_linear", "linear_vs_dynamic"}
    assert pairs["quasi_static_vs_dynamic"].component("dx").history_error == pytest.approx(0.5)
