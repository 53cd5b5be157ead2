"""Fatigue safety factors against Shigley's worked problems and the criteria's own limits.

Source: Shigley's Mechanical Engineering Design (Budynas & Nisbett), chapter 6, solutions to the end-of-chapter
problems on fluctuating stress with S_e = 276 MPa, S_y = 413 MPa, S_ut = 551 MPa:
* von Mises alternating 172 MPa, mean sqrt(3) 103 = 178.4 MPa: Goodman n_f = 1.06, Gerber 1.31,
  ASME-elliptic 1.32;
* fully reversed 358.5 MPa (mean 0): n_f = S_e / sigma_a = 276 / 358.5 = 0.77 for all three criteria.
"""

import math

import numpy as np
import pytest

from ked_quasi.fatigue import Material, link_fatigue, mean_alternating, safety_factor

MPA = 1e6
SHIGLEY = Material(ultimate_strength=551 * MPA, endurance_limit=276 * MPA, yield_strength=413 * MPA)


@pytest.mark.parametrize(("criterion", "expected"), [("goodman", 1.06), ("gerber", 1.31), ("asme-elliptic", 1.32)])
def test_shigley_fluctuating(criterion, expected):
    n = safety_factor(math.sqrt(3) * 103 * MPA, 172 * MPA, SHIGLEY, criterion)
    assert float(n) == pytest.approx(expected, abs=0.005)


@pytest.mark.parametrize("criterion", ["goodman", "gerber", "asme-elliptic"])
def test_shigley_fully_reversed(criterion):
    assert float(safety_factor(0.0, 358.5 * MPA, SHIGLEY, criterion)) == pytest.approx(0.77, abs=0.005)


def test_compressive_mean_fails_at_endurance_limit():
    """Shigley: for a compressive midrange stress failure occurs when sigma_a = S_e."""
    for c in ("goodman", "gerber", "asme-elliptic"):
        assert float(safety_factor(-200 * MPA, 138 * MPA, SHIGLEY, c)) == pytest.approx(2.0)


def test_static_limit_is_ultimate_strength():
    """No alternating stress: Goodman and Gerber both meet the mean axis at S_ut."""
    for c in ("goodman", "gerber"):
        assert float(safety_factor(275.5 * MPA, 0.0, SHIGLEY, c)) == pytest.approx(2.0)


def test_mean_alternating_of_a_sine():
    """sigma = 50 + 30 sin: mean 50, amplitude 30 (the definitions)."""
    t = np.linspace(0, 2 * np.pi, 73)[:-1]
    sm, sa = mean_alternating(50 + 30 * np.sin(t))
    assert (sm, sa) == pytest.approx((50.0, 30.0))


def test_link_fatigue_takes_the_critical_fibre():
    """A link whose moment alternates +-M about zero with a steady tension N: the worst point has
    sigma_m = N/A, sigma_a = M c/I (Goodman by hand)."""
    from ked_quasi.stress import LinkStress

    t = np.linspace(0, 2 * np.pi, 37)[:-1]
    A, I, c, N, M = 1e-4, 1e-9, 0.005, 5e3, 20.0
    link = LinkStress(link="crank", s0=np.array([0.0]), s1=np.array([1.0]), axial=np.full((t.size, 1), N),
                      moment=np.stack([M * np.sin(t), 0 * t], -1)[:, None, :], area=A, second_moment=I, fibre=c)
    lf = link_fatigue(link, SHIGLEY)
    sm, sa = N / A, M * c / I
    assert lf.sigma_m == pytest.approx(sm) and lf.sigma_a == pytest.approx(sa)
    assert lf.safety_factor == pytest.approx(1.0 / (sa / (276 * MPA) + sm / (551 * MPA)))


@pytest.mark.parametrize(("kwargs", "name"), [
    ({"ultimate_strength": 400e6, "endurance_limit": 500e6}, "endurance_limit"),
    ({"ultimate_strength": -1.0, "endurance_limit": 1.0}, "ultimate_strength"),
    ({"ultimate_strength": 400e6, "endurance_limit": 0.0}, "endurance_limit"),
    ({"ultimate_strength": 400e6, "endurance_limit": 200e6, "yield_strength": float("nan")}, "yield_strength"),
    ({"ultimate_strength": 400e6, "endurance_limit": 200e6, "yield_strength": 500e6}, "yield_strength"),
])
def test_material_refusals_name_the_parameter(kwargs, name):
    with pytest.raises(ValueError, match=f"Material.{name}"):
        Material(**kwargs)


def test_asme_needs_yield_and_unknown_criterion_refused():
    with pytest.raises(ValueError, match="yield_strength"):
        safety_factor(1e6, 1e6, Material(4e8, 2e8), "asme-elliptic")
    with pytest.raises(ValueError, match="criterion"):
        safety_factor(1e6, 1e6, SHIGLEY, "soderberg-ish")
