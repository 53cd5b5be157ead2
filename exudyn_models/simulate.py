"""Run the elastic four-bar to periodic steady state and return the coupler-point deflection.

Deflection (same meaning as ked_quasi.solver.solve_quasi_static): flexible position of P minus the
rigid-kinematics position of P at the same prescribed crank angle, dx, dy in the global frame [m],
and the elastic rotation [rad] of the extender tip cross-section at P (slope angle of the beam at P
minus the rigid extender angle).

Time integration: Exudyn generalized-alpha (index 3), fixed step h = T_cycle / steps_per_cycle,
no adaptive stepping (it hides instability), modified Newton with one Jacobian update per step,
zero initial accelerations (consistent: the drive starts from rest with zero acceleration, and
links may be exactly massless). After the start-up ramp (exudyn_models.drive) the solver advances
one crank cycle at a time; after each cycle the deflection is sampled on the scene's crank-angle
grid and compared with the previous cycle. Steady state: max |change| < steady_tol * peak, for dx,dy
(relative to the peak of |dx|, |dy|) and for the rotation (relative to its peak), after at least
min_cycles cycles; the returned cycle is then the last one simulated. With settings.extrapolate the
limit cycle is also estimated from the last 4 cycles by minimal polynomial extrapolation (the
transient of a lightly damped mode decays geometrically from cycle to cycle); once two successive
estimates agree within steady_tol (and differ from the last cycle by < 20 % of the peak) the estimate
is returned. That saves the last few cycles of a slowly decaying, near-resonant transient.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import exudyn as exu
import numpy as np
from scipy.interpolate import CubicSpline

from ked_quasi.kinematics import joint_positions

from .builder import BuiltModel, build_model, p_pose
from .damping import reference_frequency
from .settings import DynamicSettings


class SimulationError(RuntimeError):
    """The time integration failed. `.time` [s] and `.crank_angle` [rad, in [0, 2 pi)] say where."""

    def __init__(self, message: str, time: float, crank_angle: float):
        super().__init__(f"{message} at t = {time:.6g} s, crank angle = "
                         f"{math.degrees(crank_angle):.3f} deg")
        self.time = time
        self.crank_angle = crank_angle


@dataclass(frozen=True)
class DynamicResult:
    """Steady-state coupler-point deflection over one crank cycle plus run statistics.

    crank_angle (n,) [rad]: the scene's grid (0 .. 2 pi - step, ascending).
    deflection (n, 3): dx [m], dy [m] (global frame), rotation [rad] of P at those angles.
    wall_s: wall time of the whole run [s] (build + integrate + post-process).
    steps: time steps taken (ramp + cycles). newton_iterations: Newton iterations in total.
    cycles: constant-speed cycles simulated (the last one is returned).
    converged: True if the steady-state criterion was met within max_cycles.
    cycle_change: last relative change between successive cycles (the steady-state measure);
    cycle_changes: all of them, one per cycle from the second on (how the transient decayed).
    damping_reference_hz: the frequency at which the modal damping ratio was imposed.
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


ROUNDOFF_TOLERANCE = 1e-13
"""The residual's round-off grows like 1e-16 * E*A [N]; the Newton absolute tolerance is kept at
least ROUNDOFF_TOLERANCE * max(E*A), so that it stays reachable for very stiff links (E x 1e4 and
more) while staying far below the inertia forces."""


def newton_abs_tolerance(settings: DynamicSettings, fourbar) -> float:
    """Newton absolute tolerance [N]: max(settings.newton_abs_tol, 1e-13 * max(E*A))."""
    ea = max(s.youngs_modulus * s.area for s in fourbar.sections)
    return max(settings.newton_abs_tol, ROUNDOFF_TOLERANCE * ea)


def solver_settings(settings: DynamicSettings, step: float, end_time: float,
                    abs_tol: float | None = None) -> exu.SimulationSettings:
    """Exudyn SimulationSettings for a fixed-step generalized-alpha run writing no files.
    abs_tol [N]: Newton absolute tolerance (None -> settings.newton_abs_tol)."""
    sset = exu.SimulationSettings()
    sset.solution.file.write = False  # default would write solution/coordinatesSolution.txt
    sset.solution.sensors.writePeriod = 0.5 * step  # store the P sensor every step
    ti = sset.timeIntegration
    ti.endTime = end_time
    ti.numberOfSteps = max(1, round(end_time / step))
    ti.adaptiveStep = False
    ti.automaticStepSize = False
    ti.verboseMode = 0
    ti.stepInformation = 0
    ti.generalizedAlpha.spectralRadius = settings.spectral_radius
    ti.generalizedAlpha.computeInitialAccelerations = False
    nw = ti.newton
    nw.absoluteTolerance = settings.newton_abs_tol if abs_tol is None else abs_tol
    nw.relativeTolerance = settings.newton_rel_tol
    nw.useModifiedNewton = True
    nw.modifiedNewtonJacUpdatePerStep = True
    nw.maxIterations = settings.newton_max_iterations
    sset.linearSolver.solverType = (exu.LinearSolverType.EigenSparse if settings.sparse
                                    else exu.LinearSolverType.EXUdense)
    sset.show.computationTime = False
    sset.show.statistics = False
    return sset


def _rigid_p_pose(fourbar, angles: np.ndarray) -> np.ndarray:
    """(k, 3) rigid-kinematics x, y [m] and extender angle [rad] of P at crank angles [rad]."""
    jp = joint_positions(fourbar, angles)
    P, A = np.asarray(jp["P"], dtype=float), np.asarray(jp["A"], dtype=float)
    d = P - A
    return np.column_stack([P[:, 0], P[:, 1], np.arctan2(d[:, 1], d[:, 0])])


def _relative_change(new: np.ndarray, old: np.ndarray) -> float:
    """max |new - old| relative to the peak of new, for (dx, dy) and rotation separately."""
    out = 0.0
    for cols in (slice(0, 2), slice(2, 3)):
        peak = float(np.max(np.abs(new[:, cols])))
        if peak > 0.0:
            out = max(out, float(np.max(np.abs(new[:, cols] - old[:, cols]))) / peak)
    return out


class _CycleSampler:
    """Turns the P sensor samples of one constant-speed cycle into deflections on the scene grid."""

    def __init__(self, model: BuiltModel, scene, steps_per_cycle: int):
        drive = model.drive
        self.model = model
        self.n = steps_per_cycle
        j = np.arange(steps_per_cycle)
        self.angles = np.mod(drive.sign * 2.0 * math.pi * j / steps_per_cycle, 2.0 * math.pi)
        self.order = np.argsort(self.angles)
        self.rigid = _rigid_p_pose(scene.fourbar, self.angles)
        self.grid = np.asarray(scene.crank_angles, dtype=float)

    def __call__(self, coords: np.ndarray) -> np.ndarray:
        """coords: (n_steps, ncoord) sensor values at the cycle's steps (crank angle 0 first)."""
        d = p_pose(self.model, coords) - self.rigid
        d[:, 2] = np.mod(d[:, 2] + math.pi, 2.0 * math.pi) - math.pi
        a, d = self.angles[self.order], d[self.order]
        spline = CubicSpline(np.append(a, a[0] + 2.0 * math.pi), np.vstack([d, d[:1]]),
                             bc_type="periodic", axis=0)
        return spline(self.grid)


EXTRAPOLATION_ORDER = 2
"""Decaying transient components assumed by the cycle extrapolation (2 = one lightly damped mode,
whose per-cycle multiplier is a complex pair); it needs EXTRAPOLATION_ORDER + 2 cycles."""


def extrapolate_limit(cycles: list[np.ndarray]) -> np.ndarray:
    """Limit of a sequence of cycles x_0..x_{k+1} (k = len - 2) by minimal polynomial extrapolation.

    If successive cycles follow x_{i+1} - x* = T (x_i - x*) (a linear periodic system's Poincare map,
    sampled on the grid) and the transient has at most k components, x* = sum_i g_i x_i with weights
    from the least-squares fit sum_i c_i (x_{i+1} - x_i) = 0, c_k = 1, g = c / sum(c). dx, dy and the
    rotation are scaled by their peaks so both enter the fit alike.
    """
    X = np.array(cycles, dtype=float)
    scale = np.ones(X.shape[-1])
    for cols in (slice(0, 2), slice(2, 3)):
        peak = float(np.max(np.abs(X[-1][:, cols])))
        scale[cols] = 1.0 / peak if peak > 0.0 else 1.0
    flat = (X * scale).reshape(len(cycles), -1)
    U = np.diff(flat, axis=0).T
    k = len(cycles) - 2
    c, *_ = np.linalg.lstsq(U[:, :k], -U[:, k], rcond=None)
    c = np.append(c, 1.0)
    if abs(c.sum()) < 1e-12:
        return X[-1]
    return np.tensordot(c / c.sum(), X[:k + 1], axes=1)


def simulate_steady_state(scene, settings: DynamicSettings | None = None) -> DynamicResult:
    """Drive the elastic four-bar of `scene` (ked_quasi Scene) to periodic steady state.

    Returns the deflection of P over one steady cycle on scene.crank_angles (see module doc).
    Raises SimulationError (with time and crank angle) if Newton fails, ValueError on bad input.
    If the cycles do not settle within settings.max_cycles, the last cycle is returned with
    converged=False and a message saying so.
    """
    t_wall = time.perf_counter()
    settings = DynamicSettings() if settings is None else settings
    if not isinstance(settings, DynamicSettings):
        raise TypeError("settings must be a DynamicSettings")
    f_ref = reference_frequency(scene, settings) if settings.damping_ratio > 0.0 else float("nan")
    model = build_model(scene, settings, damping_beta=None if settings.damping_ratio > 0.0 else 0.0)
    drive, mbs = model.drive, model.mbs
    n = settings.steps_per_cycle
    h = drive.cycle_time / n
    ramp_steps = round(drive.ramp_time / h)
    sset = solver_settings(settings, h, drive.cycle_start(settings.max_cycles),
                           newton_abs_tolerance(settings, scene.fourbar))
    sample = _CycleSampler(model, scene, n)
    state = {"cycles": 0, "current": None, "change": float("inf"), "converged": False, "error": None,
             "changes": [], "history": [], "estimate": None, "result": None, "extrapolated": False}
    # cycle k (k = 0, 1, ...) is complete when the step to time cycle_start(k + 1) is finished; the
    # pre-step function of the following step sees t = cycle_start(k + 1) (up to round-off)
    next_check = [drive.cycle_start(1) - 0.5 * h]

    def check_cycle(mbs_, t: float) -> bool:
        if t < next_check[0]:
            return True
        next_check[0] += drive.cycle_time
        try:
            k = state["cycles"]
            data = mbs_.GetSensorStoredData(model.p_sensor)
            step = np.rint(data[:, 0] / h).astype(int)
            rows = np.full(step.max() + 1, -1)
            rows[step] = np.arange(step.size)  # last row of each step (chunk boundaries repeat rows)
            first = ramp_steps + k * n
            current = sample(data[rows[first:first + n], 1:])
            state["cycles"] = k + 1
            if state["current"] is not None:
                state["change"] = _relative_change(current, state["current"])
                state["changes"].append(state["change"])
            state["current"] = current
            state["history"] = (state["history"] + [current])[-(EXTRAPOLATION_ORDER + 2):]
            enough = state["cycles"] >= settings.min_cycles
            if state["change"] < settings.steady_tol and enough:
                state["converged"], state["result"] = True, current
                return False
            if settings.extrapolate and len(state["history"]) == EXTRAPOLATION_ORDER + 2:
                estimate = extrapolate_limit(state["history"])
                previous, state["estimate"] = state["estimate"], estimate
                if previous is not None and enough:
                    change = _relative_change(estimate, previous)
                    # accept only a settled estimate that is a modest correction of the last cycle
                    if change < settings.steady_tol and _relative_change(estimate, current) < 0.2:
                        state["change"] = change  # the estimate's change (cycle_changes stay plain)
                        state["converged"], state["result"], state["extrapolated"] = True, estimate, True
                        return False
        except Exception as exc:  # noqa: BLE001 - reported after the solver returned
            state["error"] = exc
            return False
        return True

    mbs.SetPreStepUserFunction(check_cycle)
    solver = exu.MainSolverImplicitSecondOrder()
    ok = solver.SolveSystem(mbs, sset)
    if state["error"] is not None:
        raise state["error"]
    if not ok and not state["converged"]:
        t = float(solver.it.currentTime)
        raise SimulationError("Newton iteration did not converge (step rejected)", t,
                              float(np.mod(drive.angle(t), 2.0 * math.pi)))
    if not state["converged"] and state["cycles"] < settings.max_cycles:
        check_cycle(mbs, drive.cycle_start(settings.max_cycles))  # the last cycle ends with the run
    cycles, change, converged = state["cycles"], state["change"], state["converged"]
    if state["result"] is None:
        state["result"] = state["current"]
    if state["current"] is None:
        raise SimulationError("no complete steady cycle was simulated", float(solver.it.currentTime),
                              float(np.mod(drive.angle(float(solver.it.currentTime)), 2.0 * math.pi)))
    if converged and state["extrapolated"]:
        message = (f"steady after {cycles} cycles, extrapolated from the last {EXTRAPOLATION_ORDER + 2} "
                   f"(change of the estimate {change:.2e} < tol {settings.steady_tol:g})")
    elif converged:
        message = f"steady after {cycles} cycles (change {change:.2e} < tol {settings.steady_tol:g})"
    else:
        message = (f"not steady after max_cycles={settings.max_cycles} cycles: last relative change "
                   f"{change:.2e} >= tol {settings.steady_tol:g}")
    return DynamicResult(crank_angle=np.asarray(scene.crank_angles, dtype=float),
                         deflection=state["result"], wall_s=time.perf_counter() - t_wall,
                         steps=int(solver.it.currentStepIndex), newton_iterations=int(solver.it.newtonStepsCount),
                         cycles=cycles, converged=converged, message=message, cycle_change=change,
                         damping_reference_hz=f_ref, settings=settings,
                         cycle_changes=tuple(state["changes"]))
