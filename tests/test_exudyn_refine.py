"""Refinement ladder, start state, periodic solve and failure classification of exudyn_models.

Expected values: the same model at a much finer discretization (8 elements per link, 5040 steps per
cycle), the legacy algorithm (exudyn_models.LEGACY_DEFAULTS: ramp, marching, no refinement) run to a
tight steady tolerance, ked_quasi.solve_quasi_static (the linear quasi-static deflection, for the start
state), and physics: with neither structural nor numerical damping a transient never decays, so marching
has no attracting periodic orbit to settle on.
"""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest

from exudyn_models import LEGACY_DEFAULTS, DynamicSettings, SimulationError, build_model, simulate_steady_state
from exudyn_models.builder import p_pose
from exudyn_models.start import linear_start_problem, linear_state, quasi_static_state
from ked_quasi import MassModel, thesis_fourbar
from ked_quasi.kinematics import coupler_point
from ked_quasi.linkage import THESIS_TIP_MASS_KG
from ked_quasi.presets import make_scene
from ked_quasi.scene import Scene
from ked_quasi.solver import solve_quasi_static

LEGACY = DynamicSettings(**LEGACY_DEFAULTS)
ORIGINAL_FIELDS = {"element", "elements_per_link", "steps_per_cycle", "spectral_radius", "damping_ratio",
                   "damping_reference_hz", "ramp_cycles", "steady_tol", "min_cycles", "max_cycles", "extrapolate",
                   "newton_abs_tol", "newton_rel_tol", "newton_max_iterations", "sparse"}


def _case_i() -> Scene:
    return Scene(thesis_fourbar(), MassModel("tip", payload=THESIS_TIP_MASS_KG), rpm=300.0)


def _peak(d: np.ndarray) -> float:
    return float(np.hypot(d[:, 0], d[:, 1]).max())


def _rel_error(got: np.ndarray, expected: np.ndarray) -> float:
    """max |got - expected| of (dx, dy) relative to the expected peak of |dx|, |dy|."""
    return float(np.abs(got[:, :2] - expected[:, :2]).max() / np.abs(expected[:, :2]).max())


def test_every_new_setting_has_a_legacy_value():
    new = {f.name for f in dataclasses.fields(DynamicSettings)} - ORIGINAL_FIELDS
    assert new == set(LEGACY_DEFAULTS)
    assert LEGACY.refine is False and LEGACY.start == "ramp" and LEGACY.periodic == "off"


@pytest.mark.parametrize(("field", "value"), [("start", "rest"), ("periodic", "newton"), ("anderson_memory", 0),
                                              ("refine", 1), ("refine_budget_s", 0.0)])
def test_bad_new_settings_name_the_parameter(field, value):
    with pytest.raises(ValueError, match=field):
        DynamicSettings(**{field: value})


def test_case_i_default_converges_through_the_ladder_and_records_its_attempts():
    """Thesis Case I at 300 rpm: fails at the requested settings (Newton, ~71.5 deg), then runs through on a
    rung of the ladder; the attempts say so. Regression pins: the failing angle 71.5 deg (from the code's
    own output) and peak |d| 0.1294 m within 2 % (a 2880-step run of the same scene; the slow test below
    compares against a finer discretization computed in the test itself)."""
    res = simulate_steady_state(_case_i())
    assert res.converged and res.failure_class == ""
    assert res.attempts[0].rung == "requested" and res.attempts[0].outcome == "newton failure"
    assert "71.5" in res.attempts[0].message
    assert res.attempts[-1].outcome == "steady" and res.solved_settings == res.attempts[-1].settings
    assert res.solved_settings != res.settings == DynamicSettings()
    assert abs(_peak(res.deflection) - 0.1294) / 0.1294 < 0.02


@pytest.mark.slow
def test_case_i_default_matches_a_fine_run():
    """Peak |d| of the default run within 2 % of 8 elements per link and 5040 steps per cycle."""
    res = simulate_steady_state(_case_i())
    fine = simulate_steady_state(_case_i(), DynamicSettings(elements_per_link=8, steps_per_cycle=5040))
    assert fine.converged and fine.solved_settings == fine.settings
    assert abs(_peak(res.deflection) - _peak(fine.deflection)) / _peak(fine.deflection) < 0.02


@pytest.mark.parametrize("base", [DynamicSettings(), DynamicSettings(periodic="anderson"),
                                  DynamicSettings(start="quasi_static")])
def test_ladder_leaves_a_scene_that_succeeds_bit_identical(base):
    scene = make_scene(mass_model="extender", step_deg=30.0)
    on = simulate_steady_state(scene, dataclasses.replace(base, steps_per_cycle=180, refine=True))
    off = simulate_steady_state(scene, dataclasses.replace(base, steps_per_cycle=180, refine=False))
    assert on.converged and len(on.attempts) == 1 and on.solved_settings == on.settings
    assert np.array_equal(on.deflection, off.deflection)
    assert (on.steps, on.newton_iterations, on.cycle_changes) == (off.steps, off.newton_iterations, off.cycle_changes)


def test_exhausted_budget_is_numerical_and_lists_the_attempts():
    """One Newton iteration per step at a tight tolerance fails at once; a budget smaller than any rung's
    estimated cost leaves every rung skipped, and the failure is numerical with the attempts listed."""
    scene = make_scene(mass_model="extender", step_deg=30.0)
    settings = DynamicSettings(newton_abs_tol=1e-30, newton_rel_tol=1e-30, newton_max_iterations=1,
                               steps_per_cycle=180, refine_budget_s=1e-3)
    with pytest.raises(SimulationError) as info:
        simulate_steady_state(scene, settings)
    exc = info.value
    assert exc.failure_class == "numerical" and exc.evidence
    assert exc.attempts[0].rung == "requested" and exc.attempts[0].outcome == "newton failure"
    assert len(exc.attempts) == 6 and {a.outcome for a in exc.attempts[1:]} == {"skipped"}
    assert all("refine_budget_s" in a.message for a in exc.attempts[1:])
    assert "Tried:" in str(exc) and "requested" in str(exc)


@pytest.mark.parametrize(("field", "value"), [("steps_per_cycle", 10)])
def test_failure_outside_the_working_range_names_its_cause(field, value):
    scene = make_scene(mass_model="tip")
    with pytest.raises(SimulationError, match=f"Likely cause: {field} = {value}.*Way out") as info:
        simulate_steady_state(scene, DynamicSettings(refine=False, **{field: value}))
    assert info.value.failure_class == "numerical"


def test_elements_beyond_the_working_range_are_refused_with_the_cause():
    # beyond 64 elements per link Newton's tolerance is unreachable (the ladder's cap): refused up front
    with pytest.raises(ValueError, match=r"elements_per_link: must be an integer in \[1, 64\].*Newton"):
        DynamicSettings(elements_per_link=1000)


def test_undamped_marching_never_settles_and_is_classified_physical():
    """zeta = 0: the free vibration of the lowest modes excited by the start never decays (the integrator's
    numerical damping, spectral radius 0.9, acts only on the highest modes), the motion is quasi-periodic
    (energy off the crank harmonics), so marching has no attracting orbit to settle on."""
    scene = make_scene(mass_model="extender", step_deg=30.0, rpm=200.0)
    res = simulate_steady_state(scene, DynamicSettings(damping_ratio=0.0, steps_per_cycle=360, periodic="off",
                                                       extrapolate=False, max_cycles=10, refine=False))
    assert not res.converged and res.failure_class == "physical"
    assert "quasi-periodic" in res.evidence and "physical" in res.message


def test_decaying_transient_gets_the_predicted_cycles_from_the_ladder():
    """Damped (2 %, Case III): the cycle change shrinks ~10x per cycle; stopped after 6 cycles at
    steady_tol 1e-5, the measured contraction predicts settling within a cycle or two, the ladder grants
    them (rung "cycles +N") and the run settles. Without the ladder the same run is "undecided" (the
    cycles were not granted), with the prediction in its evidence."""
    scene = make_scene(mass_model="extender", step_deg=30.0)
    base = DynamicSettings(steps_per_cycle=180, periodic="off", extrapolate=False, steady_tol=1e-5, max_cycles=6)
    res = simulate_steady_state(scene, base)
    assert res.converged and res.attempts[-1].rung.startswith("cycles +")
    assert res.solved_settings.max_cycles > base.max_cycles and res.cycles > base.max_cycles
    res = simulate_steady_state(scene, dataclasses.replace(base, refine=False))
    assert not res.converged and res.failure_class == "undecided"
    assert "predicted settling" in res.evidence and "refine=False" in res.evidence


def test_quasi_static_start_state_is_the_quasi_static_deflection():
    """The start state's P deflection at crank angle 0 equals ked_quasi's (linear regime, Case III) within 2 %."""
    scene = make_scene(mass_model="extender")
    model = build_model(scene, DynamicSettings(start="quasi_static"))
    st = quasi_static_state(model, scene)
    k = model.mbs.GetNodeODE2Index(model.p_node)
    got = p_pose(model, st.q[k:k + 4][None, :])[0, :2] - coupler_point(scene.fourbar, np.array([0.0]))[0]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        expected = solve_quasi_static(scene, np.array([0.0])).deflection[0, :2]
    assert st.note == "quasi-static"
    assert np.abs(got - expected).max() < 0.02 * np.abs(expected).max()


def test_linear_start_state_is_the_linear_deflection():
    """The linear start's P deflection at crank angle 0 equals the linear model's periodic answer there within
    2 % of its peak (the start is a static solve under the loads of the linear model's whole motion, the
    mode-acceleration form of its deflection; Case III at r ~ 0.1, where the dynamic part is 8 % of the
    quasi-static answer, so a start without it would miss by that much)."""
    from ked_linear import solve_linear

    scene = make_scene(mass_model="extender")
    model = build_model(scene, DynamicSettings(start="linear"))
    st = linear_state(model, scene)
    k = model.mbs.GetNodeODE2Index(model.p_node)
    got = p_pose(model, st.q[k:k + 4][None, :])[0, :2] - coupler_point(scene.fourbar, np.array([0.0]))[0]
    lin = solve_linear(scene).deflection[:, :2]
    assert st.note == "linear"
    assert np.abs(got - lin[0]).max() < 0.02 * np.abs(lin).max()


def test_linear_start_leaves_a_small_transient():
    """Started on the linear model's orbit, the first cycle-to-cycle change is the linear model's distance from
    Exudyn's orbit (about 1 % of the peak where its range holds), against order one after the ramp; the
    answers agree within the steady-state tolerance."""
    scene = make_scene(mass_model="distributed", rpm=150.0, step_deg=30.0)
    base = DynamicSettings(steps_per_cycle=360)
    ramp = simulate_steady_state(scene, base)
    lin = simulate_steady_state(scene, dataclasses.replace(base, start="linear"))
    assert lin.cycle_changes[0] < 0.05 < ramp.cycle_changes[0]
    assert lin.cycles <= ramp.cycles
    assert _rel_error(lin.deflection, ramp.deflection) < 2 * base.steady_tol


def test_linear_start_falls_back_where_the_linear_answer_is_unavailable():
    """Undamped, the linear model has no asymptotically stable orbit ("marginal"): the start is the quasi-static
    one, and its note says why."""
    scene = make_scene(mass_model="extender")
    model = build_model(scene, DynamicSettings(start="linear", damping_ratio=0.0))
    st = linear_state(model, scene)
    assert st.note.startswith("quasi-static (linear start unavailable:"), st.note


def test_linear_start_is_the_ramp_where_the_linear_answer_is_outside_its_range():
    """Case I at 150 rpm: the linear answer is beyond the small-deflection range (and unresolved), so the run
    starts from the ramp, says why in its start note, and is the ramp's run (the same discrete equations from the
    same state: equal bit for bit); Case III at 300 rpm (r ~ 0.1) is inside the range and starts on the orbit."""
    inside = make_scene(mass_model="extender", step_deg=30.0)
    assert linear_start_problem(inside, DynamicSettings()) == ""
    scene = make_scene(mass_model="tip", rpm=150.0, step_deg=30.0)
    assert "large_deflection" in linear_start_problem(scene, DynamicSettings())
    base = DynamicSettings(steps_per_cycle=360)
    ramp = simulate_steady_state(scene, base)
    lin = simulate_steady_state(scene, dataclasses.replace(base, start="linear"))
    assert lin.start.startswith("ramp (linear answer outside its range: large_deflection"), lin.start
    assert "(start: ramp (linear answer outside its range" in lin.message
    assert lin.cycles == ramp.cycles and np.array_equal(lin.deflection, ramp.deflection)


def test_periodic_solve_matches_a_tightly_settled_march_in_fewer_cycles():
    """Case II (slowly decaying transient): the Anderson periodic orbit equals the legacy march settled to
    1e-6 within 0.1 % of the peak, in fewer than half its cycles."""
    scene = make_scene(mass_model="joints", step_deg=30.0)
    orbit = simulate_steady_state(scene, DynamicSettings(steps_per_cycle=360, periodic="anderson"))
    march = simulate_steady_state(scene, dataclasses.replace(LEGACY, steps_per_cycle=360, steady_tol=1e-6,
                                                             extrapolate=False, max_cycles=200))
    assert orbit.converged and march.converged and orbit.periodic_residuals
    assert orbit.periodic_residuals[-1] < 1e-2 * orbit.periodic_residuals[0]
    assert 2 * orbit.cycles <= march.cycles
    assert _rel_error(orbit.deflection, march.deflection) < 1e-3


def test_budget_estimate_takes_the_costliest_attempt_not_an_early_failure():
    """The cost of a rung is estimated from each attempt that ran, scaled by steps x elements (the
    integrator's work per cycle); a Newton failure after 0.01 s must not hide a 1 s full run."""
    import time

    from exudyn_models.refine import Attempt, over_budget

    base = DynamicSettings()
    full = Attempt("requested", base, "not steady", 1.0, 40, "")
    early = Attempt("newton x4", base, "newton failure", 0.01, 0, "")
    doubled = dataclasses.replace(base, steps_per_cycle=2 * base.steps_per_cycle)
    now = time.perf_counter()
    assert "estimated 2.0 s" in over_budget(now, 1.5, [full, early], doubled)  # 1 s x 2 steps
    assert over_budget(now, 60.0, [full, early], doubled) == ""
