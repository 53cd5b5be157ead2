"""The four-bar's Exudyn run at fixed settings (one entry of :mod:`exudyn_models.kinds`): build the model, start
(settings.start: the ramp, the quasi-static or the linear model's state), march or solve the periodic orbit,
and with ``stress`` one more steady cycle for the link stresses."""

from __future__ import annotations

import time
from dataclasses import replace

from .builder import build_model
from .cycles import RunRecord
from .lowspeed import run_settings
from .march import march
from .periodic import solve_periodic
from .settings import DynamicSettings
from .start import linear_start_problem, linear_state, quasi_static_state, set_initial_state
from .stress_cycle import steady_stress
from .tolerance import newton_tolerances


def run_four_bar(scene, settings: DynamicSettings, damping_beta: float, stress: bool = False) -> RunRecord:
    """One run of a four-bar ``scene`` at fixed settings.  At low speed the steps per cycle are raised
    (exudyn_models.lowspeed; recorded in RunRecord.steps_per_cycle)."""
    settings = run_settings(scene, settings, damping_beta)
    record, model = _run_as_given(scene, settings, damping_beta)
    record.steps_per_cycle = settings.steps_per_cycle
    if stress:
        t0 = time.perf_counter()
        record.stress = steady_stress(model, scene, scene.fourbar, settings.steps_per_cycle, settings,
                                      newton_tolerances(settings, scene))
        record.stress_wall_s = time.perf_counter() - t0
    return record


def check_four_bar_settings(scene, settings: DynamicSettings) -> None:
    """Nothing to refuse: the four-bar model takes every start and constant-speed method of the settings."""


def _run_as_given(scene, settings: DynamicSettings, damping_beta: float) -> tuple[RunRecord, object]:
    note = "ramp"
    problem = linear_start_problem(scene, settings) if settings.start == "linear" else ""
    if problem:  # the linear answer is outside its range: the ramp, as without the linear start
        settings, note = replace(settings, start="ramp"), f"ramp ({problem})"
    model = build_model(scene, settings, damping_beta=damping_beta)
    if settings.start != "ramp":
        linear = settings.start == "linear"  # its problems were asked above
        st = linear_state(model, scene, checked=True) if linear else quasi_static_state(model, scene)
        set_initial_state(model, st.q, st.v, st.a)
        note = st.note
    if settings.periodic == "anderson":
        return solve_periodic(scene, settings, model, note), model
    return march(scene, settings, model, note), model
