"""Marching to steady state in one Exudyn run (settings.periodic = "off"): after the start (ramp, or the
quasi-static start state) the solver runs up to max_cycles constant-speed cycles; a pre-step function
samples every completed cycle on the scene grid and stops the run once it is steady (exudyn_models.cycles
.SteadyTracker: plain test, then the extrapolated limit)."""

from __future__ import annotations

import math

import exudyn as exu
import numpy as np

from .builder import BuiltModel
from .cycles import CycleSampler, RunRecord, SteadyTracker, rows_by_step, solver_settings
from .errors import SimulationError
from .settings import DynamicSettings
from .tolerance import newton_tolerances


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

    def __call__(self, mbs, t: float) -> bool:
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
    sset = solver_settings(settings, h, drive.cycle_start(settings.max_cycles),
                           newton_tolerances(settings, scene) if tolerances is None else tolerances)
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
    return RunRecord(deflection=tracker.current if check.result is None else check.result,
                     steps=int(solver.it.currentStepIndex), newton_iterations=int(solver.it.newtonStepsCount),
                     converged=check.converged, extrapolated=check.extrapolated, tracker=tracker,
                     start_note=start_note)
