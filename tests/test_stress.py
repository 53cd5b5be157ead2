"""Link stress histories against closed forms and independent statics.

Each test names where its expected value comes from: beam tables (simply supported beam under a linearly
varying load), free-body statics of the frozen linkage, the solid circle's section properties, and the
quasi-static limit of the linear model.
"""

import math
from dataclasses import replace

import numpy as np
import pytest

from ked_quasi import MassModel, Scene, SliderScene, simeon_slider_crank, thesis_fourbar
from ked_quasi.kinds import quasi_static_stress
from ked_quasi.kinematics import joint_positions
from ked_quasi.linkage import THESIS_SECTION, Section
from ked_quasi.stress import history_error
from ked_quasi.units import INCH

THETA = math.radians(40.0)
RPM = 300.0


def _cx(a, b):
    return a[0] * b[1] - a[1] * b[0]


def _acceleration(position, theta, omega, h=1e-3):
    """omega^2 d2x/dtheta2 by 5-point central differences of a rigid position (constant crank speed)."""
    p = [np.asarray(position(theta + k * h), float) for k in (-2, -1, 0, 1, 2)]
    return omega**2 * (-p[0] + 16 * p[1] - 30 * p[2] + 16 * p[3] - p[4]) / (12 * h * h)


def test_default_fibre_distance_is_the_solid_circle():
    """The thesis's 0.5 in round bar: A = pi r^2, I = pi r^4 / 4 give r = 2 sqrt(I/A) = 0.25 in (within the
    rounding of the thesis's A = 0.19634 in^2 for pi/16 = 0.196350 in^2: 3e-5)."""
    assert THESIS_SECTION.extreme_fibre == pytest.approx(0.25 * INCH, rel=5e-5)


def test_fibre_distance_below_the_radius_of_gyration_is_refused():
    """I = integral y^2 dA <= A c^2 for any section: c < sqrt(I/A) is no section."""
    with pytest.raises(ValueError, match="Section.fibre_distance"):
        replace(THESIS_SECTION, fibre_distance=0.1 * INCH)
    with pytest.raises(ValueError, match="Section.fibre_distance"):
        replace(THESIS_SECTION, fibre_distance=-1.0)
    sec = replace(THESIS_SECTION, fibre_distance=0.3 * INCH)
    assert Section.from_dict(sec.to_dict()) == sec and "fibre_distance" not in THESIS_SECTION.to_dict()


def test_crank_free_body_with_a_tip_mass():
    """Massless links, tip mass m at P, frozen at 40 deg, 300 rpm.  Independent statics: the follower is a
    two-force member (force t along B-Q on the body); moments about A on the coupler body give t; the pin force
    on the crank at A is F_A = -m a_P + t u; the crank is a cantilever from M with the end load F_A:
    M_root = (A - M) x F_A (beam table: M = F L for the transverse component), N = F_A . e, M(A) = 0;
    sigma = N/A +- |M| c/I with c = 0.25 in."""
    m = 0.907
    fb = thesis_fourbar()
    scene = Scene(fb, MassModel("tip", payload=m), rpm=RPM)
    omega = RPM * 2 * math.pi / 60
    j = joint_positions(fb, THETA)
    A, B, Q, M, P = (np.asarray(j[k], float).reshape(-1)[-2:] for k in ("A", "B", "Q", "M", "P"))
    aP = _acceleration(lambda t: np.asarray(joint_positions(fb, t)["P"]).reshape(-1), THETA, omega)
    F = -m * aP
    u = (B - Q) / np.linalg.norm(B - Q)
    t = -_cx(P - A, F) / _cx(B - A, u)
    FA = F + t * u
    L = np.linalg.norm(A - M)
    e = (A - M) / L
    m_root, n_axial = _cx(A - M, FA), FA @ e

    crank = quasi_static_stress(scene, np.array([THETA])).links["crank"]
    assert abs(crank.moment[0, 0, 0]) == pytest.approx(abs(m_root), rel=1e-6)
    assert abs(crank.moment[0, -1, 1]) < 1e-9 * abs(m_root)
    assert crank.axial[0, 0] == pytest.approx(n_axial, rel=1e-6)
    c = 0.25 * INCH  # the round bar's radius (the default rule's, within the thesis's rounding of A)
    expected = n_axial / THESIS_SECTION.area + abs(m_root) * c / THESIS_SECTION.second_moment
    assert crank.sigma_max[0] == pytest.approx(expected, rel=5e-5)
    assert crank.sigma_min[0] == pytest.approx(expected - 2 * abs(m_root) * c / THESIS_SECTION.second_moment,
                                               rel=5e-5)
    follower = quasi_static_stress(scene, np.array([THETA])).links["follower"]
    assert np.abs(follower.moment).max() < 1e-9 * abs(m_root)  # a two-force member bends nowhere
    assert abs(follower.axial[0, 0]) == pytest.approx(abs(t), rel=1e-6)


@pytest.mark.parametrize("deg", [30.0, 90.0, 200.0])
def test_simeon_rod_is_a_simply_supported_beam(deg):
    """Simeon's rod, pinned at the crank and at the slider, loaded by its own transverse inertia
    w(s) = -mu a_n(s), linear from w_A at A to w_B at B.  Beam tables (simply supported, uniform plus
    triangular load): M(L/2) = w L^2/8 for uniform w, w0 L^2/16 for a triangle, so M_mid = (w_A + w_B) L^2/16
    (axial loads and the loads at the supports bend nothing).  40 lumps: the midpoint rule's O(1/n^2)."""
    sc = simeon_slider_crank()
    omega = 150.0
    scene = SliderScene(sc, MassModel("distributed", lumps=40), rpm=omega * 60 / (2 * math.pi))
    theta = math.radians(deg)
    r, L = sc.crank, sc.coupler

    def ends(t):
        A = np.array([r * math.cos(t), r * math.sin(t)])
        B = np.array([r * math.cos(t) + math.sqrt(L * L - (r * math.sin(t)) ** 2), 0.0])
        return np.r_[A, B]

    x = ends(theta)
    acc = _acceleration(ends, theta, omega)
    e = (x[2:] - x[:2]) / L
    n = np.array([-e[1], e[0]])
    mu = sc.section("coupler").mass_per_length
    wA, wB = -mu * acc[:2] @ n, -mu * acc[2:] @ n
    expected = (wA + wB) * L * L / 16

    rod = quasi_static_stress(scene, np.array([theta])).links["coupler"]
    assert abs(rod.moment_at(0.5)[0]) == pytest.approx(abs(expected), rel=2e-3)
    ends_moment = np.abs([rod.moment[0, 0, 0], rod.moment[0, -1, 1]])
    assert ends_moment.max() < 1e-9 * abs(expected)  # pins carry no moment


def test_linear_equals_quasi_static_at_one_rpm():
    """At 1 rpm the elastic accelerations are ~(Omega/omega_1)^2 ~ 1e-6 of the rigid ones: the linear model's
    stress must equal the quasi-static one within 0.1 % of the peak, on every link (distributed mass on 12 lumps:
    the dynamics on 10 and the static correction; and the tip mass)."""
    from ked_linear.stress import linear_stress

    for mm in (MassModel("distributed", lumps=12), MassModel("tip", payload=0.907)):
        scene = Scene(thesis_fourbar(), mm, rpm=1.0)
        err = history_error(linear_stress(scene), quasi_static_stress(scene))
        assert set(err) == {"crank", "coupler", "extender", "follower"}
        assert max(err.values()) < 1e-3, err


def test_slider_linear_equals_quasi_static_at_one_rpm():
    """Simeon's slider-crank at 1 rpm (20 lumps: the dynamics on 10 and the static correction): the linear
    stress equals the quasi-static one within 0.1 % of the peak (elastic accelerations ~ (Omega/omega_1)^2)."""
    from ked_linear.stress import linear_stress

    scene = SliderScene(simeon_slider_crank(), MassModel("distributed", lumps=20), rpm=1.0)
    err = history_error(linear_stress(scene), quasi_static_stress(scene))
    assert set(err) == {"crank", "coupler"} and max(err.values()) < 1e-3, err


def test_stress_scales_with_speed_squared():
    """Quasi-static loads are -m a_rigid, a_rigid ~ Omega^2 at constant crank speed: every section force and
    stress scales as the speed squared."""
    mm = MassModel("distributed", lumps=4)
    a = quasi_static_stress(Scene(thesis_fourbar(), mm, rpm=100.0))
    b = quasi_static_stress(Scene(thesis_fourbar(), mm, rpm=300.0))
    for lk in a.links:
        np.testing.assert_allclose(b.links[lk].moment, 9 * a.links[lk].moment, rtol=1e-9, atol=1e-12)
