"""Direct solution of the periodic orbit (settings.periodic = "anderson").

Unknown: the full Exudyn state at the start of a constant-speed cycle, as its deviation from the rigid
motion at that crank angle, y = (q - q_r, (v - v_r) / Omega, (a - a_r) / Omega^2) (all in metres or
slope units, so the parts weigh alike; the rigid motion turns the crank a full revolution per cycle, the
deviation is periodic). Phi(y) = the state one simulated crank cycle later (one Exudyn run from that
state: ODE2 coordinates, velocities and accelerations are set as the initial state; a restart reproduces
a continuous run to ~1e-10 relative). The periodic orbit is the fixed point y = Phi(y); plain marching
iterates y <- Phi(y) and converges like the slowest Floquet multiplier (~0.88 per cycle near
resonance at 2 % damping). Anderson mixing (type II, memory m = settings.anderson_memory):

    g_k = Phi(y_k) - y_k,   y_{k+1} = y_k + g_k - (dY + dG) gamma,   gamma = argmin |g_k - dG gamma|

(dY, dG: the last m differences of y and g) removes the few slow transient components in about as many
cycles (for a linear map it is equivalent to GMRES). Every cycle is sampled on the scene grid. The run is
steady only when a plain continuation cycle (started where the previous cycle ended) differs from its
predecessor by < steady_tol: the usual two-successive-cycles test, on simulated cycles, never on an
estimate. A cycle is continued plainly when the mixing has nothing to mix yet, when the last change is
already below steady_tol, or after a mixed state made Newton fail (then the history restarts).
Recorded: the residual |g_k| / |Phi(y_k)| of every cycle (RunRecord.residuals).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import exudyn as exu
import numpy as np

from .builder import BuiltModel
from .cycles import CycleSampler, RunRecord, SteadyTracker, rows_by_step, solver_settings
from .errors import SimulationError
from .settings import DynamicSettings
from .start import rigid_motion, set_initial_state
from .tolerance import newton_tolerances

RESIDUAL_RESET_FACTOR = 10.0
"""A residual this many times the smallest one so far restarts the mixing history (safeguard)."""


@dataclass
class State:
    """Full state of the model at one instant: ODE2 coordinates q, velocities v, accelerations a, and the
    algebraic (Lagrange multiplier) coordinates ae, carried over but not mixed."""

    q: np.ndarray
    v: np.ndarray
    a: np.ndarray
    ae: np.ndarray


class CycleRunner:
    """Runs the model over one time interval from a given state (one Exudyn SolveSystem), counting steps
    and Newton iterations."""

    def __init__(self, scene, settings: DynamicSettings, model: BuiltModel):
        self.model, self.settings = model, settings
        self.step = model.drive.cycle_time / settings.steps_per_cycle
        self.tol = newton_tolerances(settings, scene)
        self.solver = exu.MainSolverImplicitSecondOrder()
        self.steps = 0
        self.newton_iterations = 0

    def run(self, state: State | None, t0: float, n_steps: int) -> np.ndarray:
        """Integrate n_steps from t0 (from `state`, or the model's initial state if None); returns the P
        sensor rows at steps 0..n_steps-1 (time first). Raises SimulationError on a Newton failure."""
        model = self.model
        if state is not None:
            set_initial_state(model, state.q, state.v, state.a, state.ae)
        sset = solver_settings(self.settings, self.step, t0 + n_steps * self.step, self.tol)
        sset.timeIntegration.startTime = t0
        sset.timeIntegration.numberOfSteps = n_steps
        ok = self.solver.SolveSystem(model.mbs, sset)
        done = int(self.solver.it.currentStepIndex)
        self.steps += done
        self.newton_iterations += int(self.solver.it.newtonStepsCount)
        if not ok:
            t = float(self.solver.it.currentTime)
            raise SimulationError("Newton iteration did not converge (step rejected)", t,
                                  float(np.mod(model.drive.angle(t), 2.0 * math.pi)), step_index=self.steps)
        data = model.mbs.GetSensorStoredData(model.p_sensor)
        rows = rows_by_step(data, self.step, t0)
        return data[rows[:n_steps]]

    def end_state(self) -> State:
        sd = self.model.mbs.systemData
        return State(np.array(sd.GetODE2Coordinates()), np.array(sd.GetODE2Coordinates_t()),
                     np.array(sd.GetODE2Coordinates_tt()), np.array(sd.GetAECoordinates()))


class _Rigid:
    """Rigid motion at the start of cycle k (crank angle sign * 2 pi k): (q_r, v_r, a_r)."""

    def __init__(self, model: BuiltModel, scene):
        self.model, self.scene = model, scene
        d = model.drive
        self.omega, self.sign = d.omega, d.sign

    def at_cycle(self, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        theta = self.model.drive.angle(self.model.drive.cycle_start(k))
        q, dq, d2q = rigid_motion(self.model, self.scene, theta)
        return q, self.sign * self.omega * dq, self.omega**2 * d2q

    def deviation(self, s: State, k: int) -> np.ndarray:
        q, v, a = self.at_cycle(k)
        return np.concatenate([s.q - q, (s.v - v) / self.omega, (s.a - a) / self.omega**2])

    def state(self, y: np.ndarray, k: int, ae: np.ndarray) -> State:
        q, v, a = self.at_cycle(k)
        n = q.size
        return State(q + y[:n], v + self.omega * y[n:2 * n], a + self.omega**2 * y[2 * n:], ae)


def anderson_step(ys: list[np.ndarray], gs: list[np.ndarray]) -> np.ndarray:
    """Type-II Anderson update from the iterates ys and residuals gs (oldest first, >= 2 of each)."""
    Y = np.diff(np.array(ys), axis=0).T
    G = np.diff(np.array(gs), axis=0).T
    gamma, *_ = np.linalg.lstsq(G, gs[-1], rcond=None)
    return ys[-1] + gs[-1] - (Y + G) @ gamma


def solve_periodic(scene, settings: DynamicSettings, model: BuiltModel, start_note: str) -> RunRecord:
    """Periodic orbit by Anderson-accelerated cycles (see module doc); initial state already set in the
    model (quasi-static start) or reached through the ramp."""
    drive = model.drive
    n = settings.steps_per_cycle
    runner = CycleRunner(scene, settings, model)
    sample = CycleSampler(model, scene, n)
    tracker = SteadyTracker(settings)
    rigid = _Rigid(model, scene)
    if drive.ramp_time > 0.0:
        runner.run(None, 0.0, round(drive.ramp_time / runner.step))
        state = runner.end_state()
    else:
        state = _initial_state(model)  # the start state set in the model
    ys: list[np.ndarray] = []
    gs: list[np.ndarray] = []
    residuals: list[float] = []
    plain, last_plain_end = True, None
    converged = False
    for k in range(settings.max_cycles):
        try:
            rows = runner.run(state, drive.cycle_start(k), n)
        except SimulationError as exc:
            if plain or last_plain_end is None:
                raise SimulationError(exc.reason, exc.time, exc.crank_angle, cycles=tracker.cycles,
                                      peaks=tuple(tracker.peaks), step_index=exc.step_index) from None
            state, plain = last_plain_end, True  # the mixed state was out of reach: restart the history
            ys, gs = [], []
            rows = runner.run(state, drive.cycle_start(k), n)
        tracker.add(sample(rows[:, 1:]))
        end = runner.end_state()
        if plain and tracker.steady():
            converged = True
            break
        y = rigid.deviation(state, k)
        y_end = rigid.deviation(end, k + 1)
        g = y_end - y
        residuals.append(float(np.linalg.norm(g) / max(np.linalg.norm(y_end), 1e-300)))
        if residuals[-1] > RESIDUAL_RESET_FACTOR * min(residuals):
            ys, gs = [], []
        ys, gs = (ys + [y])[-(settings.anderson_memory + 1):], (gs + [g])[-(settings.anderson_memory + 1):]
        last_plain_end = end
        if len(ys) < 2 or tracker.change < settings.steady_tol:
            state, plain = end, True
        else:
            state, plain = rigid.state(anderson_step(ys, gs), k + 1, end.ae), False
    return RunRecord(deflection=tracker.current, steps=runner.steps, newton_iterations=runner.newton_iterations,
                     converged=converged, extrapolated=False, tracker=tracker, start_note=start_note,
                     residuals=tuple(residuals))


def _initial_state(model: BuiltModel) -> State:
    sd = model.mbs.systemData
    init = exu.ConfigurationType.Initial
    return State(np.array(sd.GetODE2Coordinates(init)), np.array(sd.GetODE2Coordinates_t(init)),
                 np.array(sd.GetODE2Coordinates_tt(init)), np.array(sd.GetAECoordinates(init)))
