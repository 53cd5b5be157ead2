"""Fatigue safety factors against Shigley's worked example and the criteria's closed forms.

Shigley's Mechanical Engineering Design (Budynas, Nisbett, 9th ed.), Example 6-10: a 1.5 in AISI 1050 CD bar,
S_ut = 100 kpsi, S_y = 84 kpsi, S_e = 0.797 * 0.85 * 50 = 33.9 kpsi (Marin factors), K_f = 1.85, tensile load
0..16 kip -> sigma_a = sigma_m = 1.85 * 8 kip / (pi 1.5^2 / 4 in^2) = 8.38 kpsi; the book's answers: Gerber
n_f = 3.66 (eq. 6-47), ASME-elliptic n_f = 3.75 (eq. 6-48).  Goodman (eq. 6-46) by hand from the same data:
1 / (8.38/33.9 + 8.38/100) = 3.02.
"""

from __future__ import annotations

import numpy as np
import pytest

from ked_quasi.fatigue import FatigueMaterial, link_safety_factor, mean_alternating, safety_factor
from ked_quasi.linkage import Section
from ked_quasi.stress import link_stress

KPSI = 6.894757e6  # Pa
SHIGLEY = FatigueMaterial(ultimate_strength=100 * KPSI, endurance_limit=33.9 * KPSI, yield_strength=84 * KPSI)
SIGMA = 8.38 * KPSI


@pytest.mark.parametrize("criterion, book", [("gerber", 3.66), ("asme-elliptic", 3.75), ("goodman", 3.02)])
def test_shigley_example_6_10(criterion, book):
    """Book answers to the printed three digits (Goodman: the same data by hand)."""
    n = float(safety_factor(SIGMA, SIGMA, SHIGLEY, criterion))
    assert n == pytest.approx(book, abs=0.006)


def test_fully_reversed_and_static_limits():
    """sigma_m = 0: every criterion gives S_e/sigma_a; sigma_a = 0: Goodman and Gerber give S_ut/sigma_m,
    ASME-elliptic S_y/sigma_m; a compressive mean counts as zero (Shigley section 6-12)."""
    for c in ("goodman", "gerber", "asme-elliptic"):
        assert float(safety_factor(0.0, 1e8, SHIGLEY, c)) == pytest.approx(SHIGLEY.endurance_limit / 1e8)
        assert float(safety_factor(-3e8, 1e8, SHIGLEY, c)) == pytest.approx(SHIGLEY.endurance_limit / 1e8)
    assert float(safety_factor(1e8, 0.0, SHIGLEY, "goodman")) == pytest.approx(SHIGLEY.ultimate_strength / 1e8)
    assert float(safety_factor(1e8, 0.0, SHIGLEY, "gerber")) == pytest.approx(SHIGLEY.ultimate_strength / 1e8)
    assert float(safety_factor(1e8, 0.0, SHIGLEY, "asme-elliptic")) == pytest.approx(SHIGLEY.yield_strength / 1e8)
    assert float(safety_factor(0.0, 0.0, SHIGLEY)) == np.inf


def test_goodman_is_the_most_conservative_of_the_three():
    """Goodman's line lies inside Gerber's parabola (Shigley fig. 6-27) for any tensile mean."""
    sm, sa = np.linspace(1e7, 3e8, 7), np.full(7, 5e7)
    g = safety_factor(sm, sa, SHIGLEY, "goodman")
    assert np.all(g < safety_factor(sm, sa, SHIGLEY, "gerber"))


def test_mean_alternating_of_a_sine():
    t = np.linspace(0, 2 * np.pi, 73)
    sm, sa = mean_alternating(3e7 + 2e7 * np.sin(t)[:, None])
    assert sm[0] == pytest.approx(3e7) and sa[0] == pytest.approx(2e7)


def test_link_factor_uses_signed_fibres():
    """A pure moment +-M (no axial force) cycles each fibre fully reversed: sigma_a = M c/I, sigma_m = 0,
    n = S_e I /(M c); with |M| (unsigned) the mean would wrongly be M c/I / 2."""
    sec = Section(youngs_modulus=2e11, area=1e-4, second_moment=1e-9, density=7800.0, fibre_distance=0.005)
    M = np.array([10.0, -10.0, 0.0])
    forces = np.zeros((3, 1, 3))
    forces[:, 0, 2] = M
    ls = link_stress("crank", sec, 0.1, np.array([0.0]), np.array([1.0]), forces)
    n = link_safety_factor(ls, SHIGLEY)
    assert n == pytest.approx(SHIGLEY.endurance_limit / (10.0 * 0.005 / 1e-9))


@pytest.mark.parametrize("kw, word", [
    (dict(ultimate_strength=4e8, endurance_limit=5e8), "endurance_limit"),
    (dict(ultimate_strength=400.0, endurance_limit=2e8), "MPa"),
    (dict(ultimate_strength=4e8, endurance_limit=2e8, yield_strength=5e8), "yield_strength"),
    (dict(ultimate_strength=4e8, endurance_limit=-1.0), "endurance_limit"),
])
def test_nonsensical_materials_are_refused(kw, word):
    with pytest.raises(ValueError, match=word):
        FatigueMaterial(**kw)


def test_asme_needs_yield_and_unknown_criterion_refused():
    m = FatigueMaterial(ultimate_strength=4e8, endurance_limit=2e8)
    with pytest.raises(ValueError, match="yield_strength"):
        safety_factor(1e7, 1e7, m, "asme-elliptic")
    with pytest.raises(ValueError, match="criterion"):
        safety_factor(1e7, 1e7, m, "soderberg")
