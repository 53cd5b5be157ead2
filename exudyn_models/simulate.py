"""Run the elastic four-bar to periodic steady state and return the coupler-point deflection.

Deflection (same meaning as ked_quasi.solver.solve_quasi_static): flexible position of P minus the
rigid-kinematics position of P at the same prescribed crank angle, dx, dy in the global frame [m],
and the elastic rotation [rad] of the extender tip cross-section at P (slope angle of the beam at P
minus the rigid extender angle).

Time integration: Exudyn generalized-alpha (index 3), fixed step h = T_cycle / steps_per_cycle,
modified Newton with one Jacobian update per step. One run at fixed settings (_run):
  start (settings.start): "ramp": from rest, zero initial accelerations (consistent: the drive starts
      from rest with zero acceleration, and links may be exactly massless), through the start-up ramp
      (exudyn_models.drive); "quasi_static": at full speed from crank angle 0, from the quasi-static
      deflected state and its rate (exudyn_models.start); "linear": the same on the linear model's periodic
      orbit, or from the ramp where the linear answer is outside its range (the start note says why).
  constant-speed phase (settings.periodic): "off": marching in one Exudyn run (exudyn_models.march):
      after each cycle the deflection is sampled on the scene's crank-angle grid and compared with the
      previous cycle; steady when max |change| < steady_tol * peak, for dx,dy (relative to the peak of
      |dx|, |dy|) and for the rotation (relative to its peak), after at least min_cycles cycles; with
      settings.extrapolate the limit cycle is also estimated from the last 4 cycles by minimal
      polynomial extrapolation and accepted once two successive estimates agree within steady_tol (and
      differ from the last cycle by < 20 % of the peak) and a cycle simulated from the extrapolated
      state reproduces it within steady_tol (else the march goes on, exudyn_models.march).
      "anderson": the periodic orbit solved directly, cycle by cycle with Anderson mixing of the full
      state (exudyn_models.periodic); steady by the same two-successive-cycles test on a plain
      continuation cycle.
Refinement (settings.refine): a Newton failure is retried along the ladder of exudyn_models.refine within
refine_budget_s; every attempt is recorded (DynamicResult.attempts, SimulationError.attempts). A scene that
runs through at the requested settings is returned exactly as without refinement.
Failures are classified (exudyn_models.failure): SimulationError.failure_class / DynamicResult
.failure_class "numerical" or "physical" with the evidence.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np

from ked_quasi import limits
from ked_quasi.stress import StressHistory

from .cycles import (  # noqa: F401 - re-exported (the public home of these names)
    EXTRAPOLATION_ORDER,
    ROUNDOFF_TOLERANCE,
    CycleSampler,
    RunRecord,
    extrapolate_limit,
    newton_abs_tolerance,
    relative_change,
    solver_settings,
)
from .damping import rayleigh_beta
from .errors import SimulationError
from .failure import Extension, classify, classify_newton_failure, cycles_to_grant, evidence_of
from .kinds import model
from .refine import Attempt, failure_hint, ladder, over_budget, rung_settings
from .settings import DynamicSettings

__all__ = ["Attempt", "DynamicResult", "SimulationError", "extrapolate_limit", "newton_abs_tolerance",
           "simulate_steady_state", "solver_settings"]


@dataclass(frozen=True)
class DynamicResult:
    """Steady-state coupler-point deflection over one crank cycle plus run statistics.

    crank_angle (n,) [rad]: the scene's grid (0 .. 2 pi - step, ascending).
    deflection (n, 3): dx [m], dy [m] (global frame), rotation [rad] of P at those angles.
    wall_s: wall time of the whole run [s] (build + integrate + post-process, every attempt).
    steps: time steps taken (start + cycles) by the run that produced the result; newton_iterations: its
        Newton iterations in total.
    cycles: constant-speed cycles simulated (the last one is returned).
    converged: True if the steady-state criterion was met within max_cycles.
    cycle_change: last relative change between successive cycles (the steady-state measure);
    cycle_changes: all of them, one per cycle from the second on (how the transient decayed).
    damping_reference_hz: the frequency at which the modal damping ratio was imposed.
    settings: the requested settings; solved_settings: the settings that produced the returned history
        (different from settings only when the refinement ladder was used); attempts: every run of the
        ladder (exudyn_models.refine.Attempt), the first one at the requested settings.
    failure_class: "" when converged, else "numerical" or "physical"; evidence: the reason and its
        numbers (exudyn_models.failure).
    start: how the constant-speed phase began ("ramp", "quasi-static", "linear", or the fallback and its reason,
        e.g. "ramp (linear answer outside its range: large_deflection)").
    periodic_residuals: |Phi(y) - y| / |Phi(y)| per cycle of the periodic solve (empty when marching).
    cycle_peaks [m]: peak |d| (vector dx, dy) of every constant-speed cycle.
    midspan (n,) [m]: a slider-crank's coupler midspan deflection normal to its chord
        (exudyn_models.slider_simulate); None for a four-bar.
    flags: validity flags of the history (ked_quasi.limits: large_deflection, large_rotation, non_finite),
        the same bounds as the quasi-static and linear answers: a deflection beyond the small-deflection
        range is not compared as a valid reference; validity: one line saying why (empty if no flag).
    stress: link stress histories (ked_quasi.stress.StressHistory, tier "exudyn") of one more steady cycle,
        from the beam elements' section forces (exudyn_models.stress_cycle); None unless asked for.
    stress_wall_s: wall time of that stress cycle [s] (0 without it; part of wall_s).
    """

    crank_angle: np.ndarray
    deflection: np.ndarray
    wall_s: float
    steps: int
    newton_iterations: int
    cycles: int
    converged: bool
    message: str
    cycle_change: float
    damping_reference_hz: float
    settings: DynamicSettings
    cycle_changes: tuple[float, ...] = ()
    solved_settings: DynamicSettings | None = None
    attempts: tuple[Attempt, ...] = ()
    failure_class: str = ""
    evidence: str = ""
    start: str = ""
    periodic_residuals: tuple[float, ...] = ()
    cycle_peaks: tuple[float, ...] = ()
    midspan: np.ndarray | None = None
    flags: tuple[str, ...] = ()
    validity: str = ""
    stress: StressHistory | None = None
    stress_wall_s: float = 0.0


def _run(scene, settings: DynamicSettings, damping_beta: float, stress: bool = False) -> RunRecord:
    """One run at fixed settings of the scene's kind (:mod:`exudyn_models.kinds`): build, start, constant-speed
    phase; with ``stress``, one more cycle gives the link stresses (exudyn_models.stress_cycle)."""
    return model(scene).run(scene, settings, damping_beta, stress)


def _message(record: RunRecord, settings: DynamicSettings) -> str:
    tr = record.tracker
    cycles, change, tol = tr.cycles, tr.change, settings.steady_tol
    if record.converged and record.extrapolated:
        return (f"steady after {cycles} cycles, extrapolated from the last {EXTRAPOLATION_ORDER + 2} "
                f"(change of the estimate {change:.2e} < tol {tol:g}; {record.confirmation})")
    rejected = f" ({record.confirmation}; marching went on)" if record.confirmation else ""
    if record.converged and record.residuals:
        return (f"steady after {cycles} cycles (change {change:.2e} < tol {tol:g}; periodic orbit by Anderson "
                f"mixing, residual {record.residuals[0]:.1e} -> {record.residuals[-1]:.1e})")
    if record.converged:
        return f"steady after {cycles} cycles (change {change:.2e} < tol {tol:g}){rejected}"
    return (f"not steady after max_cycles={settings.max_cycles} cycles: last relative change "
            f"{change:.2e} >= tol {tol:g}{rejected}")


def _result(scene, settings: DynamicSettings, solved: DynamicSettings, record: RunRecord, f_ref: float,
            t_wall: float, attempts: tuple[Attempt, ...], extension: Extension | None = None) -> DynamicResult:
    tr = record.tracker
    message, failure_class, evidence = _message(record, solved), "", ""
    if not record.converged:
        ev = evidence_of(tr)
        failure_class, reason = classify(ev, solved.steady_tol, extension)
        evidence = f"{reason}; {ev.text()}"
        message = f"{message} [{failure_class}: {evidence}]"
    if solved != settings:
        message += f" (refined: {attempts[-1].rung})"
    if record.steps_per_cycle not in (0, solved.steps_per_cycle):
        message += f" (low speed: {record.steps_per_cycle} steps per cycle)"
    if record.start_note not in ("ramp", "quasi-static", "linear"):
        message += f" (start: {record.start_note})"
    d = np.asarray(record.deflection)
    linkage = scene.linkage
    flags = limits.flags(d[:, :3], linkage)
    return DynamicResult(crank_angle=np.asarray(scene.crank_angles, dtype=float), deflection=d[:, :3],
                         wall_s=time.perf_counter() - t_wall, steps=record.steps,
                         newton_iterations=record.newton_iterations, cycles=tr.cycles, converged=record.converged,
                         message=message, cycle_change=tr.change, damping_reference_hz=f_ref, settings=settings,
                         cycle_changes=tuple(tr.changes), solved_settings=solved, attempts=attempts,
                         failure_class=failure_class, evidence=evidence, start=record.start_note,
                         periodic_residuals=record.residuals, cycle_peaks=tuple(tr.peaks),
                         midspan=d[:, 3].copy() if d.shape[1] > 3 else None, flags=flags,
                         validity=limits.describe(flags, d[:, :3], linkage), stress=record.stress,
                         stress_wall_s=record.stress_wall_s)


def _extend(scene, settings: DynamicSettings, solved: DynamicSettings, record: RunRecord, beta: float,
            t_wall: float, attempts: list[Attempt],
            stress: bool = False) -> tuple[DynamicSettings, RunRecord, Extension | None]:
    """A run that did not settle but whose cycle changes decay: grant the cycles the measured contraction
    predicts (exudyn_models.failure.cycles_to_grant) by a rerun with max_cycles raised, if settings.refine
    and the wall-time budget allow. Returns the settings and record to report, and what was granted."""
    if record.converged:
        return solved, record, None
    before = evidence_of(record.tracker)
    predicted, grant = cycles_to_grant(before, solved.steady_tol)
    if grant == 0:
        return solved, record, None
    s = replace(solved, max_cycles=solved.max_cycles + grant)
    if not settings.refine:
        return solved, record, Extension(before, predicted, grant, False, "refine=False")
    rung = f"cycles +{grant}"
    skip = over_budget(t_wall, settings.refine_budget_s, attempts[-1:], s)
    if skip:
        attempts.append(Attempt(rung, s, "skipped", 0.0, 0, skip))
        return solved, record, Extension(before, predicted, grant, False, skip)
    t0 = time.perf_counter()
    try:
        longer = _run(scene, s, beta, stress)
    except SimulationError as exc:
        attempts.append(_attempt(rung, s, t0, exc=exc))
        return solved, record, Extension(before, predicted, grant, False, f"Newton failed in the longer run: {exc}")
    attempts.append(_attempt(rung, s, t0, longer))
    return s, longer, Extension(before, predicted, grant, True)


def _attempt(rung: str, settings: DynamicSettings, t0: float, record: RunRecord | None = None,
             exc: SimulationError | None = None) -> Attempt:
    wall = time.perf_counter() - t0
    if exc is not None:
        return Attempt(rung, settings, "newton failure", wall, exc.cycles, str(exc))
    outcome = "steady" if record.converged else "not steady"
    return Attempt(rung, settings, outcome, wall, record.tracker.cycles, _message(record, settings))


def _exhausted(first: SimulationError, settings: DynamicSettings, attempts: list[Attempt],
               peaks: list[tuple[float, ...]]) -> SimulationError:
    """The error raised when no attempt ran through: cause, way out, what was tried, class, evidence."""
    failure_class, reason = classify_newton_failure(peaks)
    hint = failure_hint(settings, first.step_index, first.time)
    tried = "; ".join(a.text() for a in attempts)
    detail = hint if len(attempts) <= 1 else f"{hint}. Tried: {tried}"
    return first.with_context(detail=detail, failure_class=failure_class, evidence=reason, attempts=tuple(attempts))


def simulate_steady_state(scene, settings: DynamicSettings | None = None, *, stress: bool = False) -> DynamicResult:
    """Drive the elastic four-bar of `scene` (ked_quasi Scene) or slider-crank (ked_quasi.slidercrank
    .SliderScene, exudyn_models.slider_builder) to periodic steady state.

    Returns the deflection of P over one steady cycle on scene.crank_angles (see module doc).
    Raises SimulationError (with time, crank angle, likely cause, failure class and the attempts) if
    Newton fails at the requested settings and, with settings.refine, on every rung of the ladder within
    the budget; ValueError on bad input. If the cycles do not settle within settings.max_cycles, the last
    cycle is returned with converged=False, a message, failure_class and evidence.
    """
    t_wall = time.perf_counter()
    settings = DynamicSettings() if settings is None else settings
    if not isinstance(settings, DynamicSettings):
        raise TypeError("settings must be a DynamicSettings")
    kind = model(scene)
    kind.check_settings(scene, settings)
    f_ref = kind.reference_frequency(scene, settings) if settings.damping_ratio > 0.0 else float("nan")
    beta = rayleigh_beta(settings.damping_ratio, f_ref) if settings.damping_ratio > 0.0 else 0.0
    attempts: list[Attempt] = []
    peaks: list[tuple[float, ...]] = []
    try:
        record = _run(scene, settings, beta, stress)
        attempts.append(_attempt("requested", settings, t_wall, record))
        solved, record, ext = _extend(scene, settings, settings, record, beta, t_wall, attempts, stress)
        return _result(scene, settings, solved, record, f_ref, t_wall, tuple(attempts), ext)
    except SimulationError as exc:
        first = exc
        attempts.append(_attempt("requested", settings, t_wall, exc=exc))
        peaks.append(exc.peaks)
    if settings.refine:
        tried = {settings}
        for rung in ladder(scene.mass_model.name):
            s = rung_settings(settings, rung)
            if s in tried:
                continue
            tried.add(s)
            skip = over_budget(t_wall, settings.refine_budget_s, attempts, s)
            if skip:
                attempts.append(Attempt(rung.name, s, "skipped", 0.0, 0, skip))
                continue
            t0 = time.perf_counter()
            try:
                record = _run(scene, s, beta, stress)
            except SimulationError as exc:
                attempts.append(_attempt(rung.name, s, t0, exc=exc))
                peaks.append(exc.peaks)
                continue
            attempts.append(_attempt(rung.name, s, t0, record))
            solved, record, ext = _extend(scene, settings, s, record, beta, t_wall, attempts, stress)
            return _result(scene, settings, solved, record, f_ref, t_wall, tuple(attempts), ext)
    raise _exhausted(first, settings, attempts, peaks)
