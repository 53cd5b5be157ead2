"""Periodic steady state on a constant basis in co-rotating frames, by Radau IIA shooting (modal acceleration).

Why: the Fourier collocation of :mod:`ked_linear.periodic` treats the correction w = u - q in absolute
coordinates on its first H crank harmonics.  On the thesis's distributed model (5 lumps per link, 40
coordinates) the frozen modes ring: their frequencies sweep over the cycle (modes 1-4 at 100 rpm: crank
harmonics 14-22, 23-37, 38-45, 56-59), every lightly damped mode rings at its own sweeping frequency once a
cycle, and w carries harmonics up to ~60 at a few tenths of a percent of its peak each.  Measured (thesis
source, default settings, against the same collocation at H = 96): the default H = 32 misses 7.1e-3 of the
peak at 100 rpm (the level estimate says 5.9e-3: honest) and 1.9e-4 at 300 rpm (estimate 7.4e-3:
pessimistic); H = 48 / 64 reach 1.0e-3 / 3e-6 at 100 rpm (5160 unknowns at 64).  A ringing mode is broad in
harmonics but smooth in time, and few modes ring: so here the ringing part is marched in time on a few
coordinates.

Method (docs/linear_model.md).  With ' = d/dtheta, sigma the speed and B = sigma C d/dtheta + sigma^2 M
d^2/dtheta^2 (as in :mod:`ked_linear.periodic`), q = K^-1 f the frozen solution:

* u = K^-1 (f - B z), z = q + W a: one quasi-static iteration from z (exact for the static part; with M = C
  = 0 the quasi-static solution at every angle);
* W(theta) = R(theta) V: V (n, r) a constant basis with V^T M V = I in co-rotating frames, R the block
  diagonal 2 x 2 rotation of each coordinate pair by its frame angle phi (the link's angle); W' = phi' J W,
  W'' = phi'' J W - phi'^2 W (J the rotation by 90 degrees; derivatives in theta);
* the reduced coordinates a follow from the condition that z's dynamic part is the projection of u's:
  W^T M (u - q) = a, i.e. (Z = K^-T M W, A_i = Z^T [B W]_i)

      A2 a'' + A1 a' + (I + A0) a = -Z^T B q,
      A0 = Z^T (sigma C W' + sigma^2 M W''),  A1 = Z^T (sigma C W + 2 sigma^2 M W'),  A2 = sigma^2 Z^T M W:

  on frozen modes the Galerkin modal equations, and with V spanning everything the exact system;
* its coefficients are sampled on :data:`SAMPLES` angles and interpolated trigonometrically; the periodic
  solution is found by shooting: Radau IIA steps (three stages, order 5, L-stable: the stiff Ritz
  directions of V are damped to their quasi-static value) marched in the direction of time give the affine
  map x(2 pi) = Phi x(0) + d of the state x = (a, a'), and x(0) = (I - Phi)^-1 d.

**Error estimate.**  Step levels :data:`STEP_LEVELS` on the smaller basis until the change of the history
(relative to its peak, per output group) gives an estimate (:func:`ked_linear.periodic.error_estimate`)
below half the tolerance; the richer basis is solved at one level (``check``; for a four-bar the reduced
Floquet ladder's probe level, at least :data:`CHECK_FROM` steps), the smaller one there too: the answer is the smaller
basis's at the last level, its error the step estimate plus twice the change between the bases at
``check``.  None when that does not reach the tolerance or anything cannot be built (A2 singular,
coefficients not interpolable): the caller then uses the Fourier collocation.

**One reduced system per basis, one pass per level.**  The homogeneous part of each one-cycle map Phi is
the reduced system's monodromy: its eigenvalues are Floquet multipliers, which the reduced Floquet ladder
(:func:`ked_linear.reduction.reduced_floquet`) takes from the same reduced systems
(:meth:`ked_linear.reduction.Reductions.reduced`, :meth:`ked_linear.reducedsystem._Reduced.propagate`): a
four-bar's steady state and its Floquet analysis share the systems of the ladder's rungs and every Radau
pass they both need.  The projection is the one above (:mod:`ked_linear.reducedsystem`: W^T M K^-1, modal
acceleration: a Petrov-Galerkin projection of the equation of motion), for both:
for the steady state the plain Galerkin projection W^T was far less accurate on
the ladder's first basis (thesis distributed, 300 rpm: 1.2e-2 of the peak against 4.3e-4; 3.2e-4 on 20
coordinates), and for the multipliers this one is as good (max |mu| at 1024 steps against the full SDIRK2
model, first / second rung, Galerkin -> this: thesis distributed 200 rpm 1.2e-4 -> 4.9e-5 / 1.3e-5 ->
4.8e-6, 300 rpm 1.6e-4 -> 2.4e-4 / 2.5e-5 -> 4e-7, 500 rpm 7.1e-4 -> 8.0e-4 / 6.2e-5 -> 2.6e-5, cognate
450 rpm 5.9e-4 -> 4.0e-4 / 2.7e-5 -> 1.1e-5; extender 300 rpm 1.2e-5 -> 7.8e-6; generated atlas linkage
1, distributed, r = 0.2: 2.6e-3 -> 4.3e-4 / 2.7e-5 -> 1.3e-5), and twice the change between consecutive
rungs covered the first rung's error in each of these.

This module is generic (no linkage): the caller supplies the bases and the frame angles
(:func:`ked_linear.linkframes.link_frames` and :func:`ked_linear.reduction.greedy_basis` for a four-bar).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .linkframes import FrameAngles
from .periodic import (
    Coefficients,
    PeriodicSystem,
    error_estimate,
    relative_change,
    spectrum,
    steady_state,
)
from .radau import radau_affine_steps  # noqa: F401  (re-exported: it was defined here)
from .reducedsystem import (  # noqa: F401  (the reduced system's parts, re-exported where they were defined)
    COEFFICIENT_TOLERANCE,
    INTERPOLATION_TOLERANCE,
    MAX_SAMPLES,
    SAMPLES,
    Propagation,
    _AtAngles,
    _Forcing,
    _frames,
    _Reduced,
)
from .reduction import (
    BASES,
    BASIS_FACTOR,
    TRAINING_ANGLES,
    Reductions,
    ladder_levels,
    link_frames,
)

STEP_LEVELS = (128, 256, 512)
"""Radau IIA steps per cycle, tried in turn (the richer basis is solved at the first)."""


@dataclass(frozen=True)
class ReducedSteadyState:
    """Output of :func:`corotating_steady_state`: u (m, n) and output y (m, p) (or None) at the requested
    angles; ``error_estimate``: the step levels' estimate plus the change between the bases (fraction of
    the peak, per output group); ``steps``: Radau steps per cycle; ``sizes``: (smaller, richer) basis sizes;
    ``step_error`` and ``basis_change``: the two parts of the estimate."""

    displacement: np.ndarray
    output: np.ndarray | None
    error_estimate: float
    steps: int
    sizes: tuple[int, int]
    step_error: float
    basis_change: float


def corotating_steady_state(system: PeriodicSystem, angles: FrameAngles, bases: tuple[np.ndarray, np.ndarray],
                            theta: np.ndarray, tolerance: float,
                            groups: tuple[slice, ...] | None = None,
                            on_grid: tuple[Coefficients, tuple[np.ndarray, np.ndarray, np.ndarray]] | None = None,
                            ) -> ReducedSteadyState | None:
    """Steady state at ``theta`` on the co-rotating bases (smaller, richer), each (n, r) with V^T M V = I, in
    the frames of ``angles``; None when the estimate does not reach ``tolerance`` (relative to the peak per
    column group of the output) or the reduced system cannot be built (see the module docstring).
    ``on_grid``: the full coefficients and ``angles`` on the :data:`SAMPLES` uniform angles from 0, if known."""
    if np.any(system.mass <= 0.0):
        return None
    G = SAMPLES
    grid = np.arange(G) * (2.0 * np.pi / G)
    co_grid, angles_grid = (system.coefficients(grid), None) if on_grid is None else on_grid
    q_hat = spectrum(np.linalg.solve(co_grid.stiffness, co_grid.load[..., None])[..., 0])
    try:
        forcing = _Forcing(system, q_hat)
        small = _Reduced(system, angles, bases[0], q_hat, co_grid, angles_grid, forcing=forcing)
        rich = _Reduced(system, angles, bases[1], q_hat, co_grid, angles_grid, forcing=forcing)
    except (ValueError, np.linalg.LinAlgError):
        return None
    return steady_state_on(small, rich, theta, tolerance, groups)


def steady_state_on(small: _Reduced, rich: _Reduced, theta: np.ndarray, tolerance: float,
                    groups: tuple[slice, ...] | None = None, check: int = STEP_LEVELS[0],
                    steps_failed: Callable[[], None] | None = None) -> ReducedSteadyState | None:
    """:func:`corotating_steady_state` on two built reduced systems of one system (smaller, richer): the
    smaller at :data:`STEP_LEVELS`, the basis change between the two at ``check`` steps (their
    discretization errors nearly cancel at equal steps).  ``steps_failed``: called (and its value
    returned) when the step levels alone do not vouch."""
    system = small.system
    if np.any(system.mass <= 0.0):
        return None
    theta = np.atleast_1d(np.asarray(theta, dtype=float))
    co = system.coefficients(theta)
    try:
        at = _AtAngles.of(small, theta)
        outputs: dict[int, tuple[np.ndarray, np.ndarray | None]] = {}
        changes, est = [], float("inf")
        for level, steps in enumerate(STEP_LEVELS):
            u, y = small.evaluate(steps, theta, co, at)
            outputs[steps] = (u, y)
            if level:
                changes.append(relative_change(_out(u, y), _out(*outputs[STEP_LEVELS[level - 1]]), groups))
                est = error_estimate(changes)
                if est < 0.5 * tolerance:
                    break
        if not est < 0.5 * tolerance:
            return None if steps_failed is None else steps_failed()
        base = outputs[check] if check in outputs else small.evaluate(check, theta, co, at)
        u_rich, y_rich = rich.evaluate(check, theta, co, at)
    except (ValueError, np.linalg.LinAlgError):
        return None
    change = relative_change(_out(u_rich, y_rich), _out(*base), groups)
    # the basis error as twice the change to the richer basis, as the reduced Floquet analysis counts it:
    # the change alone fell short of the true error by up to 1.97x (68 scenes of 8 generated atlas
    # linkages, extender and distributed at r = 0.1-0.3, against the 64-harmonic collocation)
    total = est + BASIS_FACTOR * change
    if not (np.isfinite(total) and total < tolerance):
        return None
    return ReducedSteadyState(displacement=u, output=y, error_estimate=float(total), steps=steps,
                              sizes=(small.r, rich.r), step_error=float(est),
                              basis_change=float(change))


def _out(u: np.ndarray, y: np.ndarray | None) -> np.ndarray:
    return u if y is None else y


CHECK_FROM = 128
"""Least steps at which :func:`four_bar_steady_state` compares two rungs' steady states (the ladder's probe
level where that is finer, sharing its passes).  The forced response needs it: at 64 steps the change
between the first two rungs' steady states was 3.9e-4 / 6.0e-3 of the peak (thesis extender 300 rpm /
distributed 100 rpm) against 2.9e-6 / 1.9e-5 at 128 and 256 steps alike.  The ladder itself keeps its
probe level (64 steps at high speed), so a Floquet-only evaluation does not pay the finer pass."""


class _StepsFail(Exception):
    """The step levels of a rung do not vouch: a richer rung would not either (the step error is the
    dynamics', not the basis's)."""


def _raise_steps_fail() -> None:
    raise _StepsFail


def four_bar_steady_state(scene: object, system: PeriodicSystem, theta: np.ndarray, tolerance: float,
                          groups: tuple[slice, ...] | None = None,
                          reductions: Reductions | None = None) -> ReducedSteadyState | None:
    """:func:`steady_state_on` of a four-bar's linear model on its link frames
    (:func:`ked_linear.linkframes.link_frames`) on the rungs of the reduced Floquet ladder
    (:data:`ked_linear.reduction.BASES`), their reduced systems and Radau passes shared with it: a rung
    checked against the next at the ladder's probe level (:func:`ked_linear.reduction.ladder_levels`),
    where the ladder propagates both rungs too, or at :data:`CHECK_FROM` steps if that is finer; where
    that does not vouch, the next pair of rungs (as the ladder does).  None if the system is undamped, a
    basis cannot be built or no pair vouches for ``tolerance``.  ``reductions``: the
    :class:`ked_linear.reduction.Reductions` of ``system`` if already built (shared with the reduced Floquet
    analysis).

    The richer basis was the smaller one with its static corrections (r = 14 -> 17-18 on the thesis
    distributed model) before the two analyses shared their systems; on generated atlas linkage 1
    (distributed, r = 0.2, source) its change covered the error only by a thin margin (estimate 9.46e-4 for
    a true error of 9.38e-4 against the 64-harmonic collocation), where the ladder's second rung shows
    9.1e-4 (estimate 1.85e-3: the pair declines) and the next pair (r = 23 against 26) vouches with 1.8e-4
    for a true 2.5e-5 (cognate: 6.1e-4 / 1.16e-3 / 3.5e-4 for a true 6.1e-4, 6.1e-4, 1.5e-4)."""
    red = Reductions(system, link_frames(scene)) if reductions is None else reductions
    if not red.usable or 2 * TRAINING_ANGLES != SAMPLES:
        return None
    probe = ladder_levels(red)[2]
    check = STEP_LEVELS[0] if probe is None else max(probe, CHECK_FROM)
    for i in range(len(BASES) - 1):
        small, rich = red.reduced(i), red.reduced(i + 1)
        if small is None or rich is None:
            return None
        try:
            got = steady_state_on(small, rich, theta, tolerance, groups, check, _raise_steps_fail)
        except _StepsFail:
            return None
        if got is not None:
            return got
    return None


FIRST_HARMONICS = 8
"""Crank harmonics the collocation tries first (levels 4, 8) in :func:`periodic_steady_state`: where it
converges there (low speeds: the thesis extender at 100 rpm, the distributed model at 30 rpm) it is the
cheaper answer (measured, loaded machine: 1 ms extender, 7 ms distributed at 30 rpm; the co-rotating
path 20 and 100 ms); its answer is then the one solve_linear gave before the co-rotating path existed."""


@dataclass(frozen=True)
class PeriodicAnswer:
    """The periodic steady state solve_linear reports: ``output`` (m, p) at the scene's angles, its
    ``error_estimate`` (fraction of the peak per output group), ``harmonics`` H and ``points`` N of the
    collocation (both 0 when the co-rotating basis answered), ``radau_steps`` the co-rotating basis's Radau
    IIA steps per cycle (0 when the collocation answered)."""

    output: np.ndarray
    error_estimate: float
    harmonics: int
    points: int
    radau_steps: int = 0


def periodic_steady_state(scene: object, system: PeriodicSystem, theta: np.ndarray, tolerance: float,
                          harmonics: int | None, max_harmonics: int, groups: tuple[slice, ...] | None,
                          reduce: bool, reductions: Callable[[], Reductions] | None = None) -> PeriodicAnswer:
    """A four-bar's periodic steady state: with a fixed ``harmonics`` or without ``reduce`` the collocation
    (:func:`ked_linear.periodic.steady_state`); else the collocation up to :data:`FIRST_HARMONICS`, if that
    does not reach ``tolerance`` the co-rotating basis (:func:`four_bar_steady_state`), and if that does not
    vouch for it the collocation up to ``max_harmonics``.  ``reductions``: gives the
    :class:`ked_linear.reduction.Reductions` of ``system`` (called only when the co-rotating basis is
    tried; the caller shares it with the reduced Floquet analysis)."""
    def collocation(top: int) -> PeriodicAnswer:
        ss = steady_state(system, theta, tolerance, harmonics, top, groups)
        return PeriodicAnswer(output=ss.output, error_estimate=ss.error_estimate, harmonics=ss.solution.harmonics,
                              points=ss.solution.points)

    if harmonics is not None or not reduce:
        return collocation(max_harmonics)
    first = collocation(min(FIRST_HARMONICS, max_harmonics))
    if first.error_estimate < tolerance:
        return first
    co = four_bar_steady_state(scene, system, theta, tolerance, groups,
                               None if reductions is None else reductions())
    if co is not None:
        return PeriodicAnswer(output=co.output, error_estimate=co.error_estimate, harmonics=0, points=0,
                              radau_steps=co.steps)
    return first if max_harmonics <= FIRST_HARMONICS else collocation(max_harmonics)
