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


# Shigley's Mechanical Engineering Design (Budynas, Nisbett, 9th ed.), Example 6-10: a 1.5 in AISI 1050 CD bar,
# S_ut = 100 kpsi, S_y = 84 kpsi, S_e = 0.797 * 0.85 * 50 = 33.9 kpsi (Marin factors), K_f = 1.85, tensile load
# 0..16 kip -> sigma_a = sigma_m = 1.85 * 8 kip / (pi 1.5^2 / 4 in^2) = 8.38 kpsi; the book's answers: Gerber
# n_f = 3.66, ASME-elliptic n_f = 3.75.  Goodman from the same data by hand: 1 / (8.38/33.9 + 8.38/100) = 3.02.
KPSI = 6.894757e6  # Pa
EXAMPLE_6_10 = Material(ultimate_strength=100 * KPSI, endurance_limit=33.9 * KPSI, yield_strength=84 * KPSI)


@pytest.mark.parametrize(("criterion", "book"), [("gerber", 3.66), ("asme-elliptic", 3.75), ("goodman", 3.02)])
def test_shigley_example_6_10(criterion, book):
    n = float(safety_factor(8.38 * KPSI, 8.38 * KPSI, EXAMPLE_6_10, criterion))
    assert n == pytest.approx(book, abs=0.006)


def test_goodman_is_the_most_conservative():
    """Goodman's line lies inside Gerber's parabola for any tensile mean (Shigley fig. 6-27)."""
    sm, sa = np.linspace(1e7, 3e8, 7), np.full(7, 5e7)
    assert np.all(safety_factor(sm, sa, SHIGLEY, "goodman") < safety_factor(sm, sa, SHIGLEY, "gerber"))


def test_a_moment_that_changes_sign_is_fully_reversed():
    """A pure moment +-M (no axial force) cycles each fibre through +-M c/I: sigma_m = 0, sigma_a = M c/I,
    n = S_e I/(M c) (an unsigned |M| would give a spurious tensile mean M c/(2 I))."""
    from ked_quasi.stress import LinkStress

    M = np.array([10.0, -10.0, 0.0])
    link = LinkStress(link="crank", s0=np.array([0.0]), s1=np.array([1.0]), axial=np.zeros((3, 1)),
                      moment=np.stack([M, M], -1)[:, None, :], area=1e-4, second_moment=1e-9, fibre=0.005)
    lf = link_fatigue(link, SHIGLEY)
    assert lf.sigma_m == pytest.approx(0.0, abs=1e-6)
    assert lf.safety_factor == pytest.approx(276 * MPA / (10.0 * 0.005 / 1e-9))


def test_strength_in_mpa_is_refused_with_the_mix_up_named():
    with pytest.raises(ValueError, match="Material.ultimate_strength.*MPa"):
        Material(ultimate_strength=551.0, endurance_limit=276e6)


# -- finite life: an S-N curve (Basquin's law between its points) ---------------------------------------------
# Expected values: Basquin's law S = S_1 (N / N_1)^b between two points, b = log(S_2/S_1) / log(N_2/N_1), solved
# for N in closed form; the equivalent fully reversed amplitude of Shigley section 6-14 written out here.

CURVE = ((1e3, 240 * MPA), (1e6, 140 * MPA), (5e8, 96 * MPA))


def _basquin_life(s: float, p1: tuple[float, float], p2: tuple[float, float]) -> float:
    b = math.log(p2[1] / p1[1]) / math.log(p2[0] / p1[0])
    return p1[0] * (s / p1[1]) ** (1.0 / b)


def test_sn_curve_strength_and_life_are_basquins_law():
    from ked_quasi.fatigue import SNCurve

    c = SNCurve(CURVE)
    assert c.life_at(200 * MPA) == pytest.approx(_basquin_life(200 * MPA, CURVE[0], CURVE[1]), rel=1e-12)
    assert c.life_at(100 * MPA) == pytest.approx(_basquin_life(100 * MPA, CURVE[1], CURVE[2]), rel=1e-12)
    assert c.strength_at(_basquin_life(120 * MPA, CURVE[1], CURVE[2])) == pytest.approx(120 * MPA, rel=1e-12)
    assert c.life_at(90 * MPA) == math.inf  # below the last point: the curve says nothing past it


def test_design_cycles_read_the_endurance_limit_off_the_curve():
    from ked_quasi.fatigue import SNCurve

    m = Material(ultimate_strength=310 * MPA, sn_curve=SNCurve(CURVE), design_cycles=1e6)
    assert m.endurance_limit == pytest.approx(140 * MPA, rel=1e-12)


@pytest.mark.parametrize(("kwargs", "named"), [
    ({"sn_curve": ((1e6, 140e6), (1e3, 240e6))}, "sn_curve"),  # cycles not increasing
    ({"sn_curve": ((1e3, 240.0), (1e6, 140.0))}, "MPa"),  # amplitudes in MPa
    ({"sn_curve": (("1e3", 240e6),)}, "sn_curve"),
    ({"sn_curve": CURVE, "design_cycles": 1e10}, "design_cycles"),  # outside the curve
    ({"design_cycles": 1e6}, "design_cycles"),  # no curve to read
    ({}, "endurance_limit"),  # neither S_e nor a curve
    ({"sn_curve": ((1e3, 400e6), (1e6, 140e6)), "design_cycles": 1e5}, "sn_curve"),  # above S_u = 310 MPa
    ({"sn_curve": ((1e3, 240e6, 1.0), (1e6, 140e6))}, "pair"),
    ({"endurance_limit": 1e8, "criterion": "soderberg"}, "criterion"),
])
def test_a_fatigue_curve_that_makes_no_sense_is_refused(kwargs, named):
    from ked_quasi.fatigue import SNCurve

    if "sn_curve" in kwargs:
        kwargs = {**kwargs}
        try:
            kwargs["sn_curve"] = SNCurve(kwargs["sn_curve"])
        except ValueError as exc:
            assert named in str(exc)
            return
    with pytest.raises(ValueError, match=named):
        Material(ultimate_strength=310 * MPA, **kwargs)


@pytest.mark.parametrize("criterion", ["goodman", "gerber", "asme-elliptic"])
def test_link_life_is_the_curve_read_at_the_equivalent_amplitude(criterion):
    from ked_quasi.fatigue import SNCurve
    from ked_quasi.stress import LinkStress

    # one element, N/A = 60 MPa constant and M c/I swinging +-150 MPa: sigma_m = 60, sigma_a = 150 MPa at both
    # fibres
    area, inertia, fibre = 1e-4, 1e-9, 0.005
    M = 150 * MPA * inertia / fibre * np.array([1.0, -1.0, 0.0])
    link = LinkStress("crank", np.array([0.0]), np.array([1.0]), np.full((3, 1), 60 * MPA * area),
                      np.stack([M, M], -1)[:, None, :], area, inertia, fibre)
    mat = Material(ultimate_strength=310 * MPA, yield_strength=276 * MPA, sn_curve=SNCurve(CURVE),
                   design_cycles=1e6, criterion=criterion)
    keep = {"goodman": 1 - 60 / 310, "gerber": 1 - (60 / 310) ** 2, "asme-elliptic": math.sqrt(1 - (60 / 276) ** 2)}
    s_ar = 150 * MPA / keep[criterion]
    lf = link_fatigue(link, mat, criterion)
    assert lf.life_cycles == pytest.approx(_basquin_life(s_ar, CURVE[0], CURVE[1]), rel=1e-9)
    assert not lf.life_beyond
