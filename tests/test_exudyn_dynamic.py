"""Steady-state runs of the Exudyn model against ked_quasi and kinematics.

Expected values: ked_quasi.solver.solve_quasi_static (same scene; the dynamic response tends to the
quasi-static one at low speed and for stiff links), ked_quasi.kinematics.coupler_point (rigid path),
and the model itself at a finer discretization (convergence).
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner
from scipy.optimize import minimize_scalar

from exudyn_models import DynamicSettings, simulate_steady_state
from ked_cli.main import cli as ked
from ked_quasi.kinematics import coupler_point
from ked_quasi.massmodel import MassModel
from ked_quasi.presets import make_scene
from ked_quasi.scene import Scene

from .conftest import quasi_deflection as _quasi
from .conftest import random_fourbars
from .conftest import rel_error as _rel_error


@pytest.mark.parametrize("mechanism", ["source", "cognate"])
@pytest.mark.parametrize("mass_model", ["tip", "joints", "extender", "distributed"])
def test_low_speed_limit_matches_quasi_static(mass_model, mechanism):
    """30 rpm (1/10 of the thesis speed): the steady deflection is the quasi-static one within 2 % of
    the peak. (Case I keeps a genuine ~1 % dynamic part: f1 ~ 10 Hz against crank harmonics of 0.5 Hz.)"""
    scene = make_scene(mass_model=mass_model, mechanism_name=mechanism, rpm=30.0)
    res = simulate_steady_state(scene)
    assert res.converged
    np.testing.assert_allclose(res.crank_angle, scene.crank_angles)
    xy, rot = _rel_error(res.deflection, _quasi(scene))
    assert xy < 0.02 and rot < 0.02


def test_low_speed_limit_clockwise_and_geometrically_exact_beam():
    """Crank turning CW, and the alternative element type (8 linear elements per link)."""
    scene = make_scene(mass_model="extender", rpm=30.0, direction="cw")
    expected = _quasi(scene)
    for settings in (DynamicSettings(), DynamicSettings(element="gebeam", elements_per_link=8)):
        xy, rot = _rel_error(simulate_steady_state(scene, settings).deflection, expected)
        assert xy < 0.02 and rot < 0.02, settings.element


@pytest.mark.parametrize("mass_model", ["tip", "joints"])
def test_stiff_links_deflection_scales_as_inverse_e(mass_model):
    """E x 1e4 at 300 rpm: deflection x 1e4 equals the (linear, 1/E) quasi-static deflection of the
    nominal links within 2 % of the peak (rigid limit: no dynamic amplification left). 1152 steps per
    cycle: the model has an absolute error floor (~1e-7 m at the default 288 steps, falling like
    h^3) which is ~1e-4 of the nominal deflections but not small against E x 1e4 ones."""
    scene = make_scene(mass_model=mass_model, stiffness_scale=1e4)
    res = simulate_steady_state(scene, DynamicSettings(steps_per_cycle=1152))
    xy, rot = _rel_error(res.deflection * 1e4, _quasi(make_scene(mass_model=mass_model)))
    assert xy < 0.02 and rot < 0.02


def test_rigid_path_matches_kinematic_coupler_curve_and_cognate_traces_the_source_curve():
    """E x 1e6: flexible P (rigid P + deflection) lies on the kinematic coupler curve within 1 um,
    for the source, its cognate (against the source's curve) and a random CW/crossed four-bar."""
    source = make_scene(mass_model="distributed", stiffness_scale=1e6)
    cognate = make_scene(mass_model="distributed", mechanism_name="cognate", stiffness_scale=1e6)
    fb = next(f for f in random_fourbars(20, seed=3) if f.direction == "cw" and f.branch == "crossed")
    other = Scene(fb.with_stiffness_scale(1e6), MassModel("distributed"), 300.0, 10.0)
    results = {}
    for name, scene in (("source", source), ("cognate", cognate), ("other", other)):
        results[name] = simulate_steady_state(scene)
        assert np.abs(results[name].deflection[:, :2]).max() < 1e-6

    res = results["cognate"]
    path = coupler_point(cognate.fourbar, res.crank_angle) + res.deflection[:, :2]
    dense = np.linspace(0.0, 2 * np.pi, 7201)
    curve = coupler_point(source.fourbar, dense)
    for p in path:
        i = int(np.argmin(np.hypot(*(curve - p).T)))
        best = minimize_scalar(lambda th, p=p: float(np.hypot(*(coupler_point(source.fourbar, np.array([th]))[0] - p))),
                               bounds=(dense[i] - 0.002, dense[i] + 0.002), method="bounded",
                               options={"xatol": 1e-12})
        assert best.fun < 1e-6


def test_case_iii_steady_cycle_converged_in_step_and_elements():
    """Halving the step and doubling the elements changes the Case III cycle by < 1 % of its peak."""
    scene = make_scene(mass_model="extender")
    d = DynamicSettings()
    coarse = simulate_steady_state(scene, d)
    fine = simulate_steady_state(scene, DynamicSettings(steps_per_cycle=2 * d.steps_per_cycle,
                                                        elements_per_link=2 * d.elements_per_link))
    assert coarse.converged and fine.converged
    xy, rot = _rel_error(coarse.deflection, fine.deflection)
    assert xy < 0.01 and rot < 0.01


def test_unsettled_run_is_reported_not_hidden():
    scene = make_scene(mass_model="extender", step_deg=30.0)
    res = simulate_steady_state(scene, DynamicSettings(steps_per_cycle=72, max_cycles=2, steady_tol=1e-12))
    assert not res.converged and res.cycles == 2
    assert "not steady" in res.message and res.deflection.shape == (12, 3)


def test_ked_simulate_json():
    out = CliRunner().invoke(ked, ["simulate", "--mass-model", "extender", "--step-deg", "30",
                                   "--steps-per-cycle", "72", "--json"])
    assert out.exit_code == 0, out.output
    data = json.loads(out.output)
    for key in ("crank_angle_deg", "dx_m", "dy_m", "rotation_rad"):
        assert len(data[key]) == 12
    assert data["converged"] is True and data["cycles"] >= 2 and data["wall_s"] > 0


def test_cycle_extrapolation_recovers_the_limit_of_a_decaying_oscillating_transient():
    """Synthetic cycles x_k = x* + Re(a lambda^k) (one lightly damped mode seen once per cycle, a complex
    multiplier pair): minimal polynomial extrapolation over 4 cycles gives x* to round-off."""
    from exudyn_models.simulate import extrapolate_limit

    rng = np.random.default_rng(1)
    limit = rng.normal(size=(36, 3))
    a = rng.normal(size=(36, 3)) + 1j * rng.normal(size=(36, 3))
    lam = 0.6 * np.exp(1j * 2.1)
    cycles = [limit + np.real(a * lam**k) for k in range(4)]
    np.testing.assert_allclose(extrapolate_limit(cycles), limit, atol=1e-9)


@pytest.mark.slow
def test_extrapolated_steady_state_matches_a_long_plain_run():
    """Case II at 300 rpm (slowly decaying, near-resonant transient): the extrapolated cycle equals
    the cycle of a plain run settled to 1e-6 within 0.2 % of the peak."""
    scene = make_scene(mass_model="joints")
    fast = simulate_steady_state(scene)
    slow = simulate_steady_state(scene, DynamicSettings(extrapolate=False, steady_tol=1e-6))
    assert fast.cycles < slow.cycles
    xy, rot = _rel_error(fast.deflection, slow.deflection)
    assert xy < 0.002 and rot < 0.002
