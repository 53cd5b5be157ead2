"""Shared machinery of the constant-speed phase: solver settings, sampling one cycle of the P sensor on
the scene grid, the steady-state test, and the limit-cycle extrapolation (see exudyn_models.simulate)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import exudyn as exu
import numpy as np
from scipy.interpolate import CubicSpline

from ked_quasi.kinematics import joint_positions

from .builder import BuiltModel, p_pose
from .settings import DynamicSettings
from .tolerance import ROUNDOFF_TOLERANCE, NewtonTolerances, newton_abs_tolerance  # noqa: F401 - re-exported

EXTRAPOLATION_ORDER = 2
"""Decaying transient components assumed by the cycle extrapolation (2 = one lightly damped mode,
whose per-cycle multiplier is a complex pair); it needs EXTRAPOLATION_ORDER + 2 cycles."""


def solver_settings(settings: DynamicSettings, step: float, end_time: float,
                    tol: NewtonTolerances | None = None) -> exu.SimulationSettings:
    """Exudyn SimulationSettings for a fixed-step generalized-alpha run writing no files.
    tol: the Newton tolerances (exudyn_models.tolerance.newton_tolerances; None -> the settings' own)."""
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
    nw.absoluteTolerance = settings.newton_abs_tol if tol is None else tol.abs_n
    nw.relativeTolerance = settings.newton_rel_tol if tol is None else tol.rel
    if tol is not None and tol.increment:
        nw.residualMode = 1  # test the coordinate increment [m] (exudyn_models.tolerance)
    nw.useModifiedNewton = True
    nw.modifiedNewtonJacUpdatePerStep = True
    nw.maxIterations = settings.newton_max_iterations
    sset.linearSolver.solverType = (exu.LinearSolverType.EigenSparse if settings.sparse
                                    else exu.LinearSolverType.EXUdense)
    sset.show.computationTime = False
    sset.show.statistics = False
    return sset


def rigid_p_pose(fourbar, angles: np.ndarray) -> np.ndarray:
    """(k, 3) rigid-kinematics x, y [m] and extender angle [rad] of P at crank angles [rad]."""
    jp = joint_positions(fourbar, angles)
    P, A = np.asarray(jp["P"], dtype=float), np.asarray(jp["A"], dtype=float)
    d = P - A
    return np.column_stack([P[:, 0], P[:, 1], np.arctan2(d[:, 1], d[:, 0])])


def relative_change(new: np.ndarray, old: np.ndarray) -> float:
    """max |new - old| relative to the peak of new, for (dx, dy) and rotation separately."""
    out = 0.0
    for cols in (slice(0, 2), slice(2, 3)):
        peak = float(np.max(np.abs(new[:, cols])))
        if peak > 0.0:
            out = max(out, float(np.max(np.abs(new[:, cols] - old[:, cols]))) / peak)
    return out


class CycleSampler:
    """Turns the P sensor samples of one constant-speed cycle into deflections on the scene grid."""

    def __init__(self, model: BuiltModel, scene, steps_per_cycle: int):
        drive = model.drive
        self.model = model
        self.n = steps_per_cycle
        j = np.arange(steps_per_cycle)
        self.angles = np.mod(drive.sign * 2.0 * math.pi * j / steps_per_cycle, 2.0 * math.pi)
        self.order = np.argsort(self.angles)
        self.rigid = rigid_p_pose(scene.fourbar, self.angles)
        self.grid = np.asarray(scene.crank_angles, dtype=float)

    def __call__(self, coords: np.ndarray) -> np.ndarray:
        """coords: (n_steps, ncoord) sensor values at the cycle's steps (crank angle 0 first)."""
        d = p_pose(self.model, coords) - self.rigid
        d[:, 2] = np.mod(d[:, 2] + math.pi, 2.0 * math.pi) - math.pi
        a, d = self.angles[self.order], d[self.order]
        spline = CubicSpline(np.append(a, a[0] + 2.0 * math.pi), np.vstack([d, d[:1]]),
                             bc_type="periodic", axis=0)
        return spline(self.grid)


def rows_by_step(data: np.ndarray, step: float, t0: float = 0.0) -> np.ndarray:
    """Row of the sensor data for each step index round((t - t0) / step) (the last row of each step:
    chunk boundaries repeat rows); -1 where a step has no row."""
    idx = np.rint((data[:, 0] - t0) / step).astype(int)
    rows = np.full(idx.max() + 1, -1)
    rows[idx] = np.arange(idx.size)
    return rows


def extrapolate_limit(cycles: list[np.ndarray]) -> np.ndarray:
    """Limit of a sequence of cycles x_0..x_{k+1} (k = len - 2) by minimal polynomial extrapolation.

    If successive cycles follow x_{i+1} - x* = T (x_i - x*) (a linear periodic system's Poincare map,
    sampled on the grid) and the transient has at most k components, x* = sum_i g_i x_i with weights
    from the least-squares fit sum_i c_i (x_{i+1} - x_i) = 0, c_k = 1, g = c / sum(c). dx, dy and the
    rotation are scaled by their peaks so both enter the fit alike.
    """
    return np.tensordot(extrapolation_weights(cycles), np.array(cycles, dtype=float), axes=1)


def extrapolation_weights(cycles: list[np.ndarray]) -> np.ndarray:
    """The weights g, shape (len(cycles),) and summing to 1) of :func:`extrapolate_limit`: limit = sum_i g_i x_i.
    The same weights extrapolate any other linear observation of the same cycles (e.g. the model's full
    state at each cycle's end, exudyn_models.march), since its transient decays by the same multipliers;
    a fit without a finite limit (sum(c) ~ 0) gives the last cycle."""
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
    g = np.zeros(len(cycles))
    if abs(c.sum()) < 1e-12:
        g[-1] = 1.0
    else:
        g[:k + 1] = c / c.sum()
    return g


@dataclass
class SteadyTracker:
    """Progress of the steady-state test over the constant-speed cycles of one run.

    cycles: cycles seen; current: the last one on the grid (n, 3); change: the last relative change
    (or the accepted estimate's); changes: one per cycle from the second on; history: the last
    EXTRAPOLATION_ORDER + 2 cycles; estimate: the last extrapolated limit; peaks [m]: peak |d| of
    every cycle (growth evidence for exudyn_models.failure); weights: the extrapolation weights of the last
    estimate over history (exudyn_models.cycles.extrapolation_weights); rejected: an estimate of this run was
    not confirmed by a simulated cycle (exudyn_models.march), so no later one is accepted."""

    settings: DynamicSettings
    cycles: int = 0
    current: np.ndarray | None = None
    change: float = math.inf
    changes: list[float] = field(default_factory=list)
    history: list[np.ndarray] = field(default_factory=list)
    estimate: np.ndarray | None = None
    peaks: list[float] = field(default_factory=list)
    weights: np.ndarray | None = None
    rejected: bool = False

    def add(self, cycle: np.ndarray) -> None:
        """Record one more simulated cycle."""
        self.cycles += 1
        if self.current is not None:
            self.change = relative_change(cycle, self.current)
            self.changes.append(self.change)
        self.current = cycle
        self.history = (self.history + [cycle])[-(EXTRAPOLATION_ORDER + 2):]
        self.peaks.append(float(np.max(np.hypot(cycle[:, 0], cycle[:, 1]))))

    @property
    def enough(self) -> bool:
        return self.cycles >= self.settings.min_cycles

    def steady(self) -> bool:
        """Two successive simulated cycles differ by < steady_tol (after at least min_cycles)."""
        return self.change < self.settings.steady_tol and self.enough

    def settled_estimate(self) -> np.ndarray | None:
        """The extrapolated limit cycle once two successive estimates agree within steady_tol (and it is
        a modest correction, < 20 % of the peak, of the last cycle); None otherwise."""
        if not (self.settings.extrapolate and not self.rejected and len(self.history) == EXTRAPOLATION_ORDER + 2):
            return None
        self.weights = extrapolation_weights(self.history)
        estimate = np.tensordot(self.weights, np.array(self.history, dtype=float), axes=1)
        previous, self.estimate = self.estimate, estimate
        if previous is None or not self.enough:
            return None
        change = relative_change(estimate, previous)
        if change < self.settings.steady_tol and relative_change(estimate, self.current) < 0.2:
            self.change = change  # the estimate's change (changes stay plain)
            return estimate
        return None


@dataclass
class RunRecord:
    """What one run at fixed settings produced (before it becomes a DynamicResult).

    deflection (n, 3) of the returned cycle; steps, newton_iterations: totals; converged; extrapolated:
    the returned cycle is the extrapolated limit; tracker: the cycles; start_note: how the constant-speed
    phase began; residuals: periodic-solve residuals per cycle (empty when marching); message;
    steps_per_cycle: the steps per cycle the run used (exudyn_models.lowspeed; 0 = not recorded);
    confirmation: how an extrapolated cycle was checked by a cycle simulated from the extrapolated state
    (exudyn_models.march.confirm_extrapolation): the confirming cycle's change when the returned cycle is
    extrapolated, else why the last extrapolated orbit was rejected ("" when none was)."""

    deflection: np.ndarray
    steps: int
    newton_iterations: int
    converged: bool
    extrapolated: bool
    tracker: SteadyTracker
    start_note: str
    residuals: tuple[float, ...] = ()
    message: str = ""
    steps_per_cycle: int = 0
    confirmation: str = ""
    stress: object = None  # ked_quasi.stress.StressHistory of the steady cycle, when asked for
    stress_wall_s: float = 0.0  # wall time of that stress cycle [s]
