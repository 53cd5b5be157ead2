"""The reduced Floquet analysis (ked_linear/reduction.py): co-rotating link frames, a greedy constant basis,
the Radau IIA propagator, its error estimate and the fallback to the full model."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy.linalg import expm

from ked_linear import linkage_system
from ked_linear.floquet import floquet, multipliers
from ked_linear.periodic import Coefficients, PeriodicSystem
from ked_linear.reduction import (
    InterpolatedCoefficients,
    Reductions,
    corotated,
    greedy_basis,
    link_frames,
    projection,
    radau_multipliers,
    radau_tableau,
    reduced_floquet,
    static_corrections,
)
from ked_linear.settings import LinearSettings
from ked_linear.solver import single_threaded_blas, stability
from ked_quasi.presets import make_scene
from ked_quasi.solver import natural_frequencies

# max |mu| of the FULL linear model (absolute coordinates, SDIRK2 propagator of ked_linear.floquet) at 4096
# and 8192 steps per cycle, thesis source linkage, default LinearSettings (2 % damping, prestress):
# an independent discretization (other coordinates, other propagator, no reduction).  Regenerate with
# ``abs(ked_linear.multipliers(linkage_system(scene, settings).system, steps)[0])``, settings with the
# damping reference frequency of solve_linear (the mean first frozen frequency).
FULL_SDIRK2 = {
    ("tip", 100): (0.46484082231469304, 0.46483838275952183),
    ("tip", 300): (0.6786569757663913, 0.6786572165812025),
    ("joints", 100): (0.07251711111059718, 0.07250952183404921),
    ("joints", 300): (0.36187601360488103, 0.3618727475141698),
    ("extender", 100): (0.011530312812009462, 0.011523421011165805),
    ("extender", 300): (0.1004901103099041, 0.10050798857984887),
    ("distributed", 100): (0.010801998425919161, 0.010836022598965742),
    ("distributed", 300): (0.16275826240247693, 0.1627369917595287),
    ("extender", 30): (1.5206344866576729e-06, 1.485949151260287e-06),
    ("extender", 200): (0.058861493328117166, 0.058860809952878006),
    ("extender", 450): (0.178414270443741, 0.1784089309163326),
    ("distributed", 30): (0.00012228470589299842, 0.00012171630152189264),
    ("distributed", 200): (0.06714838809647322, 0.06712654421274619),
}

# the same (full SDIRK2 model at 4096 and 8192 steps) at high speed, source and cognate (default direction):
# speeds where the reduction without static corrections did not vouch (500-550 rpm) or only through its
# 2048-step fallback's neighbours
FULL_SDIRK2_HIGH = {
    ("source", 500): (0.31988512693078097, 0.31987963568538513),
    ("source", 600): (0.34397346498735454, 0.34396754436344085),
    ("cognate", 450): (0.2658478318317584, 0.26584359014784875),
    ("cognate", 600): (0.3670252594930219, 0.3670233199838901),
}


def _system(mass_model: str, rpm: float, mechanism: str = "source", direction: str | None = None, **kw):
    scene = make_scene(mechanism_name=mechanism, mass_model=mass_model, rpm=rpm, direction=direction)
    settings = LinearSettings(**kw)
    f_ref = float(np.mean(natural_frequencies(scene, n_modes=1)[:, 0]))
    return scene, linkage_system(scene, replace(settings, damping_reference_hz=f_ref)).system, settings


def _unit_mass(system: PeriodicSystem, coefficients) -> PeriodicSystem:
    """x'' + M^-1 C x' + M^-1 K x = 0 from coefficients of M x'' + C x' + K x = 0 (same multipliers)."""
    m = system.mass

    def co(theta):
        c = coefficients(theta)
        return Coefficients(stiffness=c.stiffness / m[:, None], damping=c.damping / m[:, None], load=c.load)

    return PeriodicSystem(mass=np.ones(m.size), speed=system.speed, coefficients=co)


def test_radau_constant_coefficients_match_the_matrix_exponential():
    # closed form: for constant K, C the monodromy is expm(A T), A = [[0, I], [-K, -C]]; a stiff overdamped
    # mode (K = 4e6, C = 2e4: roots -1e4 +- ..., h lambda ~ -150 per step) and a lightly damped one
    K = np.array([[40.0, 5.0], [5.0, 4.0e6]])
    C = np.array([[0.02, 0.0], [0.0, 2.0e4]])
    speed = 2.0 * np.pi
    system = PeriodicSystem(mass=np.ones(2), speed=speed, coefficients=lambda th: Coefficients(
        stiffness=np.broadcast_to(K, (th.size, 2, 2)), damping=np.broadcast_to(C, (th.size, 2, 2)),
        load=np.zeros((th.size, 2))))
    A = np.block([[np.zeros((2, 2)), np.eye(2)], [-K, -C]])
    exact = np.linalg.eigvals(expm(A * system.period))
    exact = exact[np.argsort(-np.abs(exact))]
    mu = radau_multipliers(system, 256)
    assert np.abs(mu[:2]) == pytest.approx(np.abs(exact[:2]), abs=1e-9)
    assert np.all(np.abs(mu[2:]) < 1e-12)  # L-stable: the stiff overdamped mode is damped out, not kept near 1


def test_radau_tableau_closed_form_and_order():
    # closed form of the three-stage Radau IIA method (Hairer & Wanner, Table IV.5.6)
    s6 = np.sqrt(6.0)
    c, a = radau_tableau(3)
    assert c == pytest.approx([(4.0 - s6) / 10.0, (4.0 + s6) / 10.0, 1.0], abs=1e-15)
    closed = np.array([[(88.0 - 7.0 * s6) / 360.0, (296.0 - 169.0 * s6) / 1800.0, (-2.0 + 3.0 * s6) / 225.0],
                       [(296.0 + 169.0 * s6) / 1800.0, (88.0 + 7.0 * s6) / 360.0, (-2.0 - 3.0 * s6) / 225.0],
                       [(16.0 - s6) / 36.0, (16.0 + s6) / 36.0, 1.0 / 9.0]])
    assert a == pytest.approx(closed, abs=1e-15)
    # any s: collocation conditions sum_j a_ij c_j^(k-1) = c_i^k / k, k = 1..s, and c_s = 1 (stiffly accurate)
    for stages in (2, 4, 5):
        c, a = radau_tableau(stages)
        for k in range(1, stages + 1):
            assert a @ c ** (k - 1) == pytest.approx(c**k / k, abs=1e-13)
        assert c[-1] == 1.0 and np.all(np.diff(c) > 0) and c[0] > 0


@pytest.mark.parametrize("mechanism,direction", [("source", None), ("cognate", "cw")])
def test_corotating_transform_is_exact_on_the_joints_model(mechanism, direction):
    # u = R(t) v is a change of coordinates (R periodic): the multipliers of the co-rotating system equal
    # those of the absolute one; both propagated by Radau IIA to convergence (the two discretizations
    # differ); also turning clockwise on the crossed branch (the frames' rates change sign)
    with single_threaded_blas():
        scene, system, _ = _system("joints", 300, mechanism, direction)
        frames = link_frames(scene)
        full = radau_multipliers(_unit_mass(system, system.coefficients), 1024)
        turned = radau_multipliers(_unit_mass(system, lambda th: corotated(system, frames, th)), 1024)
    assert np.abs(turned[:4]) == pytest.approx(np.abs(full[:4]), abs=1e-8)
    if mechanism == "source":  # and the full model's SDIRK2 (independent propagator) at 8192 steps
        assert abs(np.abs(turned[0]) - FULL_SDIRK2[("joints", 300)][1]) < 1e-5


def test_reduced_clockwise_crossed_against_the_unreduced_model():
    # the reduction (interpolated on descending angle grids) against the unreduced absolute-coordinate
    # model propagated by Radau IIA at 512 and 1024 steps: extender, cognate (crossed branch), clockwise
    with single_threaded_blas():
        scene, system, settings = _system("extender", 300, "cognate", "cw")
        red = reduced_floquet(system, link_frames(scene), settings.floquet_tolerance)
        coarse, fine = (float(np.abs(radau_multipliers(_unit_mass(system, system.coefficients), n)[0]))
                        for n in (512, 1024))
    assert red is not None
    assert abs(red.result.max_abs - fine) <= red.result.error_estimate + abs(fine - coarse)


def test_projection_equals_the_reference_form():
    # the fast projection (no n x n rotation) against V^T (R^T K R + ...) V from corotated(), random basis
    with single_threaded_blas():
        scene, system, _ = _system("extender", 300)
        frames = link_frames(scene)
        theta = np.linspace(0.1, 6.0, 7)
        V = np.random.default_rng(1).standard_normal((system.mass.size, 4))
        K, C = projection(system.coefficients(theta), frames.of_lumps(theta), system.mass, V)
        ref = corotated(system, frames, theta)
    assert np.allclose(K, V.T @ ref.stiffness @ V, rtol=0, atol=1e-10 * np.abs(K).max())
    assert np.allclose(C, V.T @ ref.damping @ V, rtol=0, atol=1e-10 * np.abs(C).max())


@pytest.mark.parametrize("mass_model,rpm", sorted(k for k in FULL_SDIRK2 if k[0] != "tip"))
def test_reduced_max_abs_against_the_full_model(mass_model, rpm):
    with single_threaded_blas():
        scene, system, settings = _system(mass_model, rpm)
        red = reduced_floquet(system, link_frames(scene), settings.floquet_tolerance)
    assert red is not None
    coarse, fine = FULL_SDIRK2[(mass_model, rpm)]
    err = abs(red.result.max_abs - fine)
    assert err < settings.floquet_tolerance
    # the estimate is honest: it covers the difference, up to the reference's own uncertainty (its last change)
    assert err <= red.result.error_estimate + abs(fine - coarse)
    assert red.sizes[0] <= red.sizes[1] <= system.mass.size
    if mass_model == "distributed":
        assert red.sizes[0] <= 0.6 * system.mass.size  # the answer is a real reduction's: 40 coordinates


@pytest.mark.parametrize("mechanism,rpm", sorted(FULL_SDIRK2_HIGH))
def test_reduced_vouches_at_high_speed_against_the_full_model(mechanism, rpm):
    # distributed model up to 600 rpm (the range of `ked check --rpm-range 30:600:20`): the reduction answers
    # and its estimate covers the difference to the independent full model (up to the reference's own change)
    with single_threaded_blas():
        scene, system, settings = _system("distributed", rpm, mechanism)
        red = reduced_floquet(system, link_frames(scene), settings.floquet_tolerance)
    assert red is not None
    coarse, fine = FULL_SDIRK2_HIGH[(mechanism, rpm)]
    err = abs(red.result.max_abs - fine)
    assert red.result.error_estimate <= 0.5 * settings.floquet_tolerance
    assert err <= red.result.error_estimate + abs(fine - coarse)
    assert red.sizes[0] < system.mass.size


def test_static_corrections_remove_the_truncation_error_at_high_speed():
    # the cause of the slow basis convergence at high speed: the frame forces (Coriolis 2 M phi' J v', ...) of
    # the low modes drive the links' stiff directions quasi-statically, which no low frozen mode spans.  At
    # 500 rpm (distributed) the 4-mode basis of frozen modes alone is off the full SDIRK2 model by more than a
    # quarter of the Floquet tolerance; two static correction columns more bring it four times closer
    with single_threaded_blas():
        scene, system, settings = _system("distributed", 500)
        built = Reductions(system, link_frames(scene))
        plain = greedy_basis(built._Ks, 4, 1e-6, system.mass.size, built._eigen)
        corrected = static_corrections(built._Ks, built._eigen, plain, 4, 1e-5)
        tops = []
        for W in (plain, corrected):
            V = W / np.sqrt(system.mass)[:, None]
            theta = np.arange(256) * (2.0 * np.pi / 256)
            K, C = projection(system.coefficients(theta), built.frames.of_lumps(theta), system.mass, V)
            reduced = PeriodicSystem(mass=np.ones(V.shape[1]), speed=system.speed,
                                     coefficients=InterpolatedCoefficients(K, C))
            tops.append(float(np.abs(radau_multipliers(reduced, 256)[0])))
    fine = FULL_SDIRK2_HIGH[("source", 500)][1]
    assert corrected.shape[1] > plain.shape[1]
    assert abs(tops[0] - fine) > 0.25 * settings.floquet_tolerance  # measured 3.1e-4 (24 columns)
    assert abs(tops[1] - fine) < 0.25 * abs(tops[0] - fine)  # measured 6e-5 (26 columns)


def test_fallback_undamped_and_unvouched():
    with single_threaded_blas():
        # Case I (tip): its support stiffens 1000-fold within a few degrees; the reduced coefficients (stiffness
        # form) are not interpolable within 1e-8 on 512 angles, so the reduction declines
        scene, system, settings = _system("tip", 100)
        assert reduced_floquet(system, link_frames(scene), 1e-3) is None
        scene, system, settings = _system("extender", 300, damping_ratio=0.0)
        assert reduced_floquet(system, link_frames(scene), 1e-3) is None  # undamped: Hamiltonian, full model
        scene, system, settings = _system("extender", 300)
        assert reduced_floquet(system, link_frames(scene), 1e-9) is None  # cannot vouch for 5e-10
        # a fixed step count is the full propagator's, unchanged
        fixed = replace(settings, floquet_steps=256)
        got = stability(scene, system, fixed)
        ref = floquet(system, fixed.floquet_tolerance, 256)
    assert got.max_abs == ref.max_abs and got.steps == 256


def test_reduced_systems_are_small_and_interpolated():
    with single_threaded_blas():
        scene, system, _ = _system("distributed", 300)
        built = Reductions(system, link_frames(scene))
        small, rich = built.reduced(0), built.reduced(1)
        tops = [float(np.abs(small.propagate(n).multipliers[0])) for n in (256, 512)]
    assert small.r < rich.r < system.mass.size
    # the lowest frozen mode's highest frequency over the cycle: the distributed model's first mode, 28 Hz
    # and up (docs/linear_model.md, frozen frequencies), below its second (~50 Hz at most)
    assert 2.0 * np.pi * 28.0 < built.omega_kept < 2.0 * np.pi * 60.0
    # the reduced system at non-grid angles (the Radau stages): the interpolated coefficients are finite and
    # the Radau levels agree
    assert abs(tops[0] - tops[1]) < 1e-4


@pytest.mark.slow
def test_reduced_against_full_at_other_speeds():
    # the full SDIRK2 model at 4096 and 8192 steps computed here (slow), extender and distributed off the
    # speeds above
    with single_threaded_blas():
        for mass_model, rpm in (("extender", 600), ("distributed", 150)):
            scene, system, settings = _system(mass_model, rpm)
            red = reduced_floquet(system, link_frames(scene), settings.floquet_tolerance)
            coarse, fine = (float(np.abs(multipliers(system, n)[0])) for n in (4096, 8192))
            assert red is not None
            assert abs(red.result.max_abs - fine) <= red.result.error_estimate + abs(fine - coarse)


def test_greedy_basis_gives_up_when_a_spanned_angle_stays_off():
    """A structure whose lowest frozen eigenvalue is 0 at every angle (a free rigid-body direction): the Ritz
    value's relative error is undefined there, and the worst angle's mode is spanned after the first column, so
    no column can improve it.  The greedy basis must give up (None: the caller falls back to the full model)
    instead of retrying the same angle for ever."""
    Ks = np.broadcast_to(np.diag([0.0, 1.0, 2.0]), (4, 3, 3)).copy()
    assert greedy_basis(Ks, modes=1, ritz_tolerance=1e-6, max_size=3) is None


# ---- one reduced system per basis: the modal-acceleration (Petrov-Galerkin) projection of the steady state ----

# max |mu| of the full SDIRK2 model (as FULL_SDIRK2) at 4096 and 8192 steps on generated atlas linkages
# (ked_research.atlas.generate.generate, seed 0; linkage index, source mechanism, distributed mass model, 2 %
# damping, speed ratio r = Omega / omega1_min).  Linkage 1 at r = 0.2 is where the plain Galerkin projection
# of the first rung was 2.6e-3 off the full model (the modal-acceleration one 4.3e-4, its change to the second
# rung 4.2e-4; measured at 1024 Radau steps).
FULL_SDIRK2_ATLAS = {
    (1, 0.2): (0.5002994801042704, 0.5003005326878596),
    (4, 0.2): (0.5320094307732571, 0.5320078896547729),
    (5, 0.5): (0.7245167558600117, 0.7245161962898429),
}


def _atlas_system(index: int, ratio: float, mechanism: str = "source", mass_model: str = "distributed"):
    from ked_research.atlas.compute import spec_of
    from ked_research.atlas.generate import generate

    linkage = next(lk for lk in generate(index + 1).linkages if lk.index == index)
    mm = replace(next(m for m in linkage.mass_models if m.name == mass_model), lumps=5)  # the references' lumps
    base = spec_of(linkage, mechanism, mm, ratio).scene(1.0)
    scene = replace(base, rpm=ratio * float(np.min(natural_frequencies(base, n_modes=1)[:, 0])) * 60.0)
    settings = LinearSettings(damping_ratio=0.02)
    f_ref = float(np.mean(natural_frequencies(scene, n_modes=1)[:, 0]))
    return scene, linkage_system(scene, replace(settings, damping_reference_hz=f_ref)).system, settings


@pytest.mark.parametrize("index,ratio", sorted(FULL_SDIRK2_ATLAS))
def test_reduced_floquet_on_atlas_linkages_is_honest(index, ratio):
    # the ladder on the modal-acceleration reduced systems (the periodic steady state's): wherever it answers,
    # the full model is within its estimate (up to the reference's own last change)
    with single_threaded_blas():
        scene, system, settings = _atlas_system(index, ratio)
        got = stability(scene, system, settings)
    coarse, fine = FULL_SDIRK2_ATLAS[(index, ratio)]
    assert abs(got.max_abs - fine) <= got.error_estimate + abs(fine - coarse)
    assert abs(got.max_abs - fine) < settings.floquet_tolerance
