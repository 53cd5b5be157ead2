"""Failure classes from the evidence of the cycles (exudyn_models.failure), on sequences of cycle changes
whose decay is known by construction (a geometric sequence: its contraction and the cycles it needs to
fall below a tolerance are closed forms)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from exudyn_models.failure import (
    SETTLE_LIMIT,
    Evidence,
    Extension,
    classify,
    contraction_fit,
    cycles_to_grant,
)


def _evidence(changes, growth=1.0, nonharmonic=0.0) -> Evidence:
    c, s, trend, window = contraction_fit(list(changes))
    return Evidence(growth=growth, contraction=c, nonharmonic=nonharmonic, change=float(changes[-1]),
                    cycles=len(changes) + 1, peak_m=0.1, scatter=s, trend=trend, window=window)


def test_geometric_decay_is_measured_and_its_settling_predicted():
    """changes 0.5 * 0.9^k: contraction 0.9, and log(tol / change) / log(0.9) cycles to settle."""
    changes = 0.5 * 0.9 ** np.arange(30)
    ev = _evidence(changes)
    assert ev.contraction == pytest.approx(0.9, rel=1e-9) and ev.decays
    expected = math.log(2e-3 / changes[-1]) / math.log(0.9)
    assert ev.cycles_to_settle(2e-3) == pytest.approx(expected, rel=1e-6)
    predicted, grant = cycles_to_grant(ev, 2e-3)
    assert 0 < predicted <= grant <= SETTLE_LIMIT
    cls, reason = classify(ev, 2e-3, Extension(ev, predicted, grant, False, "refine=False"))
    assert cls == "undecided" and "not granted" in reason


def test_beating_decay_is_seen_through_the_beats():
    """A decay at 0.97 per cycle modulated by a beat of period 10 cycles (two close modes): the fit over
    the last half of 80 changes recovers the decay within 0.01 and predicts settling."""
    k = np.arange(80)
    changes = 0.5 * 0.97**k * (1.2 + np.cos(2 * np.pi * k / 10.0))
    ev = _evidence(changes, nonharmonic=1e-3)
    assert abs(ev.contraction - 0.97) < 0.01 and ev.decays
    assert cycles_to_grant(ev, 2e-3)[1] > 0


def test_changes_that_jump_without_decay_and_off_harmonic_energy_are_physical():
    """Changes jumping between 0.6 and 2 with no trend, 50 % of the energy off the crank harmonics (the
    thesis joints scene at r = 1): no decay, a quasi-periodic response."""
    rng = np.random.default_rng(1)
    changes = np.exp(rng.uniform(np.log(0.6), np.log(2.0), 39)) * np.linspace(1.0, 1.2, 39)
    ev = _evidence(changes, nonharmonic=0.5)
    assert not ev.decays and ev.stuck(2e-3)
    assert classify(ev, 2e-3)[0] == "physical"


def test_growth_is_physical_and_a_stall_at_the_noise_floor_numerical():
    assert classify(_evidence(np.full(20, 0.5) * 1.05 ** np.arange(20), growth=1.05), 2e-3)[0] == "physical"
    stalled = 1e-5 * (1.0 + 0.3 * np.sin(np.arange(20)))
    assert classify(_evidence(stalled), 1e-7)[0] == "numerical"


def test_too_few_cycles_and_an_unclear_trend_are_undecided():
    assert classify(_evidence([0.5, 0.3]), 2e-3)[0] == "undecided"
    rng = np.random.default_rng(2)
    noisy = 0.05 * 0.99 ** np.arange(12) * np.exp(rng.normal(0.0, 0.5, 12))
    ev = _evidence(noisy, nonharmonic=1e-3)
    if not ev.stuck(2e-3):  # a slope without significance: neither decay nor evidence against one
        assert classify(ev, 2e-3)[0] == "undecided"


def test_a_decay_confirmed_by_the_granted_cycles_is_numerical_and_an_unconfirmed_one_physical():
    """Before: 0.9 per cycle at cycle 20. Granted cycles that ran: if the change kept falling at 0.9 but
    not below the tolerance, more cycles would settle it (numerical); if the changes stopped falling
    (contraction ~1, still large) the predicted settling did not happen (physical)."""
    before = _evidence(0.5 * 0.9 ** np.arange(20))
    predicted, grant = cycles_to_grant(before, 1e-6)
    ext = Extension(before, predicted, grant, True)
    after = _evidence(0.5 * 0.9 ** np.arange(20 + grant))
    assert classify(after, 1e-9, ext)[0] == "numerical"
    flat = np.concatenate([0.5 * 0.9 ** np.arange(20), np.full(grant, 0.06) * (1 + 0.1 * np.sin(np.arange(grant)))])
    assert classify(_evidence(flat), 1e-6, ext)[0] == "physical"
