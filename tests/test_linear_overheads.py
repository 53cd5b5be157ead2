"""The cheaper evaluations inside solve_linear against the ones they replace (each an independent second
way to the same numbers, equal to round-off)."""
from __future__ import annotations

import importlib
from dataclasses import replace

import numpy as np
import pytest

from ked_linear import LinearSettings, linkage_system
from ked_quasi.scene import Scene

from .conftest import MASS_MODEL_CASES

fq = importlib.import_module("ked_linear.floquet")
pe = importlib.import_module("ked_linear.periodic")


@pytest.mark.parametrize("direction", ["ccw", "cw"])
def test_whole_turn_stage_fields_by_fft_equal_basis_product(thesis, direction):
    # a whole turn of stage coefficients from the series by inverse real FFTs against the series' basis
    # product (its cos/sin table times the rows), the way partial chunks are evaluated: the same finite
    # trigonometric sum, so equal to round-off relative to each field's peak; both crank directions
    # (the grid runs backwards for cw) and both propagators' stage offsets (SDIRK2, Gauss-Legendre)
    scene = Scene(replace(thesis, direction=direction), MASS_MODEL_CASES["joints"], 100.0, 10.0)
    system = linkage_system(scene, LinearSettings(damping_ratio=0.02)).system
    series = fq._series(system)
    assert series is not None
    n = system.mass.size
    for steps in (64, 512):
        assert 2 * series.harmonics < steps  # the FFT path is the one taken
        for damped in (True, False):
            K, C = fq._stage_fields(system, series, steps, 0, steps, damped)
            c = fq._stage_offsets(damped, system.period / steps)
            E = series.basis(system.speed * c, np.sign(system.speed) * 2.0 * np.pi / steps, steps, np.arange(steps))
            ref = np.take(E @ series.rows, series.expand, axis=1).reshape(2, steps, 2, n, n)
            for got, want in ((K, ref[:, :, 0]), (C, ref[:, :, 1])):
                assert np.abs(got - want).max() <= 1e-13 * np.abs(want).max()


def test_dense_operator_equals_its_definition():
    # the dense collocation operator against its definition, G[b, a] = weight_b sum_j E[j, b] (s E1[j, a] X_j
    # + s^2 E2[j, a] Y_j) on the N collocation points (the trigonometric basis E and its derivatives),
    # for random X, Y: equal to round-off
    rng = np.random.default_rng(3)
    N, n, H, s = 32, 3, 7, -41.0
    X, Y = rng.standard_normal((N, n, n)), rng.standard_normal((N, n, n)) * 0.01
    theta = np.arange(N) * (2.0 * np.pi / N)
    E, E1, E2 = pe.trig_basis(theta, H)
    weight = np.r_[1.0, np.full(2 * H, 2.0)] / N
    want = np.einsum("b,jb,jaik->biak", weight, E, s * E1[:, :, None, None] * X[:, None] + s**2 * E2[:, :, None, None]
                     * Y[:, None])
    got = pe._dense_operator(s, X, Y, H)
    assert np.abs(got - want).max() <= 1e-12 * np.abs(want).max()


def test_floquet_levels_built_together_equal_level_by_level(thesis):
    # the first three step levels of the automatic Floquet plan built in one vectorized pass (a step length
    # per step) against each level's own monodromy: the same arithmetic per step, so equal to round-off
    scene = Scene(thesis, MASS_MODEL_CASES["joints"], 300.0, 10.0)
    system = linkage_system(scene, LinearSettings(damping_ratio=0.02)).system
    levels = [64, 128, 256]
    batch = fq._level_batch(system, levels, True)
    assert sorted(batch) == levels  # the batched path is the one tested
    for steps in levels:
        alone = fq.multipliers(system, steps, True)
        assert np.abs(batch[steps] - alone).max() <= 1e-12 * np.abs(alone).max()
    # undamped systems and levels beyond one chunk are not batched
    assert fq._level_batch(system, levels, False) == {}
    assert fq._level_batch(system, [64, 128, 10**6], True) == {}


@pytest.mark.parametrize("mass_model", ["tip", "joints"])
def test_undamped_read_from_the_samples_equals_the_probe(thesis, mass_model):
    # whether C = 0, read off the sampled interpolant's spectrum (tip: the flexibility form, joints: the
    # stiffness form), against the coefficients evaluated at 8 angles over the cycle
    for zeta in (0.0, 0.02):
        scene = Scene(thesis, MASS_MODEL_CASES[mass_model], 300.0, 10.0)
        system = linkage_system(scene, LinearSettings(damping_ratio=zeta)).system
        probe = not np.any(system.coefficients(np.linspace(0.0, 2.0 * np.pi, 8, endpoint=False)).damping)
        assert system.coefficients.interpolant is not None  # the spectrum is what is read
        assert fq.undamped(system) == probe == (zeta == 0.0)
