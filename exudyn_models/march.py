"""Marching to steady state in one Exudyn run (settings.periodic = "off"): after the start (ramp, or the
quasi-static start state) the solver runs up to max_cycles constant-speed cycles; a pre-step function
samples every completed cycle on the scene grid and stops the run once it is steady (exudyn_models.cycles
.SteadyTracker: plain test, then the extrapolated limit).

An extrapolated limit is an estimate, not a simulated cycle: it is accepted only when one more cycle,
simulated from the extrapolated full state, reproduces it within steady_tol (confirm_extrapolation). The
full state (ODE2 coordinates, velocities, accelerations, algebraic coordinates) is recorded at the end of
each cycle and extrapolated with the weights of the deflection's extrapolation (the same transient decays
in every linear observation of the cycles); a coordinate that turns by whole revolutions per cycle (the
crank's rotation) is first brought to the phase of the last cycle. An estimate the confirming cycle does
not reproduce fitted something other than a decaying transient toward a periodic orbit: it is dropped
(RunRecord.confirmation says why) and the march goes on from the last simulated cycle's end without
extrapolation: the run is then steady only by two successive simulated cycles. So is a run whose
estimate lies beyond the small-deflection range of ked_quasi.limits: the extrapolation assumes a linear
cycle map (a decaying transient of a linear periodic system), which large deflections are not."""

from __future__ import annotations

import math

import exudyn as exu
import numpy as np

from ked_quasi import limits

from .builder import BuiltModel
from .cycles import (
    EXTRAPOLATION_ORDER,
    CycleSampler,
    RunRecord,
    SteadyTracker,
    relative_change,
    rows_by_step,
    solver_settings,
)
from .errors import SimulationError
from .settings import DynamicSettings
from .start import set_initial_state
from .tolerance import NewtonTolerances, newton_tolerances


class _CycleCheck:
    """Exudyn pre-step function: at each cycle end, sample the cycle and decide whether to go on.

    Cycle k (k = 0, 1, ...) is complete when the step to time cycle_start(k + 1) is finished; the
    pre-step function of the following step sees t = cycle_start(k + 1) (up to round-off)."""

    def __init__(self, model: BuiltModel, sample: CycleSampler, tracker: SteadyTracker, step: float):
        drive = model.drive
        self.model, self.sample, self.tracker = model, sample, tracker
        self.step = step
        self.ramp_steps = round(drive.ramp_time / step)
        self.cycle_time = drive.cycle_time
        self.next_check = drive.cycle_start(1) - 0.5 * step
        self.converged = False
        self.result: np.ndarray | None = None
        self.extrapolated = False
        self.error: BaseException | None = None
        self.ends: list[tuple[np.ndarray, ...]] = []  # full state at the end of each cycle of tracker.history
        self.pending = False
        self.linkage = None  # the four-bar or slider-crank (the small-deflection bound of an estimate)
        self.unused = ""  # why a settled estimate was not used

    def record_end(self, mbs) -> None:
        """Record the model's current full state as the end state of the last checked cycle. (Exudyn calls
        the pre-step function with the time at the end of the coming step while the state is still the one
        at its start, so the state at a cycle's end is read at the following call, or after the run.)"""
        sd = mbs.systemData
        end = (np.array(sd.GetODE2Coordinates()), np.array(sd.GetODE2Coordinates_t()),
               np.array(sd.GetODE2Coordinates_tt()), np.array(sd.GetAECoordinates()))
        self.ends = (self.ends + [end])[-(EXTRAPOLATION_ORDER + 2):]
        self.pending = False

    def __call__(self, mbs, t: float) -> bool:
        if self.pending:  # the model's state is now the one at the end of the last checked cycle
            self.record_end(mbs)
        if t < self.next_check:
            return True
        self.next_check += self.cycle_time
        try:
            return self._check(mbs)
        except Exception as exc:  # noqa: BLE001 - reported after the solver returned
            self.error = exc
            return False

    def _check(self, mbs) -> bool:
        tr, n = self.tracker, self.sample.n
        data = mbs.GetSensorStoredData(self.model.p_sensor)
        rows = rows_by_step(data, self.step)
        first = self.ramp_steps + tr.cycles * n
        tr.add(self.sample(data[rows[first:first + n], 1:]))
        self.pending = True
        if tr.steady():
            self.converged, self.result = True, tr.current
            return False
        estimate = tr.settled_estimate()
        found = limits.flags(estimate[:, :3], self.linkage) if estimate is not None else ()
        if found:  # the extrapolation assumes a linear cycle map: not where the deflections are large
            tr.rejected = True
            self.unused = (f"extrapolated orbit after {tr.cycles} cycles not used: beyond the small-deflection "
                           f"range ({', '.join(found)}), where the extrapolation's linear cycle map does not hold")
        elif estimate is not None:
            self.converged, self.result, self.extrapolated = True, estimate, True
            return False
        return True


def march(scene, settings: DynamicSettings, model: BuiltModel, start_note: str, *, sampler=None,
          tolerances=None) -> RunRecord:
    """Run the model (initial state already set) to steady state or max_cycles in one Exudyn run.
    sampler, tolerances: the cycle sampler and Newton tolerances (None: the four-bar's CycleSampler and
    newton_tolerances; the slider-crank passes its own, exudyn_models.slider_simulate). An extrapolated
    cycle that its confirming cycle does not reproduce is dropped and the march goes on, without
    extrapolation, from the last simulated cycle's end (a new Exudyn run from that state)."""
    drive, mbs = model.drive, model.mbs
    n = settings.steps_per_cycle
    h = drive.cycle_time / n
    t_end = drive.cycle_start(settings.max_cycles)
    tol = newton_tolerances(settings, scene) if tolerances is None else tolerances
    tracker = SteadyTracker(settings)
    check = _CycleCheck(model, CycleSampler(model, scene, n) if sampler is None else sampler, tracker, h)
    check.linkage = scene.linkage
    steps = newton = 0
    t_start, confirmation = 0.0, ""
    while True:
        mbs.SetPreStepUserFunction(check)
        sset = solver_settings(settings, h, t_end, tol)
        sset.timeIntegration.startTime = t_start
        sset.timeIntegration.numberOfSteps = max(1, round((t_end - t_start) / h))
        solver = exu.MainSolverImplicitSecondOrder()
        ok = solver.SolveSystem(mbs, sset)
        steps += int(solver.it.currentStepIndex)
        newton += int(solver.it.newtonStepsCount)
        if check.error is not None:
            raise check.error
        t = float(solver.it.currentTime)
        if not ok and not check.converged:
            raise SimulationError("Newton iteration did not converge (step rejected)", t,
                                  float(np.mod(drive.angle(t), 2.0 * math.pi)), cycles=tracker.cycles,
                                  peaks=tuple(tracker.peaks), step_index=steps)
        if not check.converged and tracker.cycles < settings.max_cycles:
            check(mbs, t_end)  # the last cycle ends with the run
        if tracker.current is None:
            raise SimulationError("no complete steady cycle was simulated", t,
                                  float(np.mod(drive.angle(t), 2.0 * math.pi)))
        if not check.extrapolated:
            confirmation = confirmation or check.unused
            break
        if check.pending:
            check.record_end(mbs)
        mbs.SetPreStepUserFunction(0)  # the confirming cycle runs on its own
        confirmed, text, c_steps, c_newton = confirm_extrapolation(model, settings, check.sample, tol, check.result,
                                                                   tracker, check.ends)
        steps, newton = steps + c_steps, newton + c_newton
        if confirmed:
            confirmation = text
            break
        confirmation = f"extrapolated orbit after {tracker.cycles} cycles not confirmed: {text}"
        check.converged, check.extrapolated, check.result = False, False, None
        if tracker.cycles >= settings.max_cycles:
            break
        tracker.rejected = True  # from here on only two successive simulated cycles make the run steady
        set_initial_state(model, *check.ends[-1])  # go on marching from the last simulated cycle's end
        t_start = drive.cycle_start(tracker.cycles)
        check.next_check = drive.cycle_start(tracker.cycles + 1) - 0.5 * h
    return RunRecord(deflection=tracker.current if check.result is None else check.result, steps=steps,
                     newton_iterations=newton, converged=check.converged, extrapolated=check.extrapolated,
                     tracker=tracker, start_note=start_note, confirmation=confirmation)


def extrapolated_state(ends: list[tuple[np.ndarray, ...]], weights: np.ndarray) -> tuple[np.ndarray, ...]:
    """The full state (q, v, a, ae) at the end of the last of ``ends`` extrapolated with ``weights``
    (exudyn_models.cycles.extrapolation_weights of the same cycles). Velocities, accelerations and the
    algebraic coordinates are periodic; a coordinate whose value grows by whole turns per cycle (a crank's
    rotation [rad]; the change of a position over one cycle at the same crank angle is far below pi m) is
    brought to the last cycle's phase first."""
    last = len(ends) - 1
    q_turn = 2.0 * math.pi * np.rint((ends[-1][0] - ends[-2][0]) / (2.0 * math.pi))
    q = sum(g * (e[0] + (last - i) * q_turn) for i, (g, e) in enumerate(zip(weights, ends)))
    return (q, *(sum(g * e[j] for g, e in zip(weights, ends)) for j in (1, 2, 3)))


def confirm_extrapolation(model: BuiltModel, settings: DynamicSettings, sample, tol: NewtonTolerances,
                          estimate: np.ndarray, tracker: SteadyTracker,
                          ends: list[tuple[np.ndarray, ...]]) -> tuple[bool, str, int, int]:
    """Simulate one cycle from the extrapolated state (the tracker's weights over ``ends``) and compare it
    with ``estimate``: (confirmed, what was found, steps, Newton iterations). Confirmed when the simulated
    cycle reproduces the estimate within steady_tol. tol: the march's Newton tolerances."""
    drive, n = model.drive, settings.steps_per_cycle
    h = drive.cycle_time / n
    t0 = drive.cycle_start(tracker.cycles)
    q, v, a, ae = extrapolated_state(ends, tracker.weights)
    set_initial_state(model, q, v, a, ae)
    sset = solver_settings(settings, h, t0 + n * h, tol)
    sset.timeIntegration.startTime = t0
    sset.timeIntegration.numberOfSteps = n
    solver = exu.MainSolverImplicitSecondOrder()
    ok = solver.SolveSystem(model.mbs, sset)
    steps, newton = int(solver.it.currentStepIndex), int(solver.it.newtonStepsCount)
    if not ok:
        return False, "Newton failed in the cycle simulated from the extrapolated state", steps, newton
    data = model.mbs.GetSensorStoredData(model.p_sensor)
    rows = rows_by_step(data, h, t0)[:n]
    if rows.size < n or np.any(rows < 0):
        return False, "the cycle simulated from the extrapolated state has missing samples", steps, newton
    change = relative_change(sample(data[rows, 1:]), estimate)
    if change < settings.steady_tol:
        return True, (f"confirmed by a cycle simulated from the extrapolated state (change {change:.2e} < tol "
                      f"{settings.steady_tol:g})"), steps, newton
    return False, (f"a cycle simulated from the extrapolated state differs from it by {change:.2e} of the peak "
                   f"(not < tol {settings.steady_tol:g})"), steps, newton
