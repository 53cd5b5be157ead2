"""Marching to steady state in one Exudyn run (settings.periodic = "off"): after the start (ramp, or the
quasi-static start state) the solver runs up to max_cycles constant-speed cycles; a pre-step function
samples every completed cycle on the scene grid and stops the run once it is steady (exudyn_models.cycles
.SteadyTracker: plain test, then the extrapolated limit).

An extrapolated limit is an estimate, not a simulated cycle: it is accepted only when one more cycle,
simulated from the extrapolated full state, reproduces it within steady_tol (confirm_extrapolation). The
full state (ODE2 coordinates, velocities, accelerations, algebraic coordinates) is recorded at the end of
each cycle and extrapolated with the weights of the deflection's extrapolation (the same transient decays
in every linear observation of the cycles); a coordinate that turns by whole revolutions per cycle (the
crank's rotation) is first brought to the phase of the last cycle. Otherwise the run is not steady
(RunRecord.confirmation says why): the extrapolation fitted something other than a decaying transient
toward a periodic orbit."""

from __future__ import annotations

import math

import exudyn as exu
import numpy as np

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
        if estimate is not None:
            self.converged, self.result, self.extrapolated = True, estimate, True
            return False
        return True


def march(scene, settings: DynamicSettings, model: BuiltModel, start_note: str, *, sampler=None,
          tolerances=None) -> RunRecord:
    """Run the model (initial state already set) to steady state or max_cycles in one Exudyn run.
    sampler, tolerances: the cycle sampler and Newton tolerances (None: the four-bar's CycleSampler and
    newton_tolerances; the slider-crank passes its own, exudyn_models.slider_simulate)."""
    drive, mbs = model.drive, model.mbs
    n = settings.steps_per_cycle
    h = drive.cycle_time / n
    tol = newton_tolerances(settings, scene) if tolerances is None else tolerances
    sset = solver_settings(settings, h, drive.cycle_start(settings.max_cycles), tol)
    tracker = SteadyTracker(settings)
    check = _CycleCheck(model, CycleSampler(model, scene, n) if sampler is None else sampler, tracker, h)
    mbs.SetPreStepUserFunction(check)
    solver = exu.MainSolverImplicitSecondOrder()
    ok = solver.SolveSystem(mbs, sset)
    if check.error is not None:
        raise check.error
    t = float(solver.it.currentTime)
    if not ok and not check.converged:
        raise SimulationError("Newton iteration did not converge (step rejected)", t,
                              float(np.mod(drive.angle(t), 2.0 * math.pi)), cycles=tracker.cycles,
                              peaks=tuple(tracker.peaks), step_index=int(solver.it.currentStepIndex))
    if not check.converged and tracker.cycles < settings.max_cycles:
        check(mbs, drive.cycle_start(settings.max_cycles))  # the last cycle ends with the run
    if tracker.current is None:
        raise SimulationError("no complete steady cycle was simulated", t, float(np.mod(drive.angle(t), 2.0 * math.pi)))
    record = RunRecord(deflection=tracker.current if check.result is None else check.result,
                       steps=int(solver.it.currentStepIndex), newton_iterations=int(solver.it.newtonStepsCount),
                       converged=check.converged, extrapolated=check.extrapolated, tracker=tracker,
                       start_note=start_note)
    if check.extrapolated:
        if check.pending:
            check.record_end(mbs)
        mbs.SetPreStepUserFunction(0)  # the confirming cycle runs on its own
        confirm_extrapolation(model, settings, check.sample, tol, record, check.ends)
    return record


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
                          record: RunRecord, ends: list[tuple[np.ndarray, ...]]) -> None:
    """Simulate one cycle from the extrapolated state and keep the extrapolated cycle only if that cycle
    reproduces it within steady_tol; else the record becomes not converged (the last simulated cycle is
    returned) and record.confirmation says why. tol: the march's Newton tolerances."""
    tracker, drive, n = record.tracker, model.drive, settings.steps_per_cycle
    h = drive.cycle_time / n
    t0 = drive.cycle_start(tracker.cycles)
    q, v, a, ae = extrapolated_state(ends, tracker.weights)
    set_initial_state(model, q, v, a, ae)
    sset = solver_settings(settings, h, t0 + n * h, tol)
    sset.timeIntegration.startTime = t0
    sset.timeIntegration.numberOfSteps = n
    solver = exu.MainSolverImplicitSecondOrder()
    ok = solver.SolveSystem(model.mbs, sset)
    record.steps += int(solver.it.currentStepIndex)
    record.newton_iterations += int(solver.it.newtonStepsCount)
    reason = ""
    if not ok:
        reason = "Newton failed in the cycle simulated from the extrapolated state"
    else:
        data = model.mbs.GetSensorStoredData(model.p_sensor)
        rows = rows_by_step(data, h, t0)[:n]
        if rows.size < n or np.any(rows < 0):
            reason = "the cycle simulated from the extrapolated state has missing samples"
        else:
            change = relative_change(sample(data[rows, 1:]), record.deflection)
            if change < settings.steady_tol:
                record.confirmation = (f"confirmed by a cycle simulated from the extrapolated state (change "
                                       f"{change:.2e} < tol {settings.steady_tol:g})")
                return
            reason = (f"a cycle simulated from the extrapolated state differs from it by {change:.2e} of the peak "
                      f"(not < tol {settings.steady_tol:g})")
    record.confirmation = f"extrapolated orbit not confirmed: {reason}"
    record.converged, record.extrapolated, record.deflection = False, False, tracker.current
