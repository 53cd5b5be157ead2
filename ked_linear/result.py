"""The linear model's answer: its result type, validity flags and verdict text (no solving here)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .settings import HARMONICS, LinearSettings

OUTPUT_GROUPS = (slice(0, 2), slice(2, 3))
"""Error measure of the history: (dx, dy) as a vector against its peak, the rotation against its peak."""


@dataclass(frozen=True)
class LinearResult:
    """Periodic steady state of the linear KED model on the scene's grid, and its stability.

    crank_angle (n,) [rad]: ``scene.crank_angles``.
    deflection (n, 3): dx, dy [m] (global frame) and rotation [rad, CCW] of the section at P, elastic,
        relative to the rigid position at the same crank angle (as ``solve_quasi_static``); all NaN
        when not ``stable`` (no asymptotically stable periodic steady state exists).
    status: "ok" (asymptotically stable), "marginal" (undamped, every multiplier on the unit circle within
        its error: the free vibrations never decay; the message says "marginal (undamped)") or "unstable";
        stable: status == "ok"; message: one line saying why.
    floquet_max_abs: largest |Floquet multiplier| of the homogeneous system over one crank cycle;
        floquet_error: its estimated absolute error; floquet_steps: propagator steps per cycle (of the
        reduced system's Radau IIA propagator when the reduced Floquet analysis answered: damped extender
        and distributed models, ``ked_linear.reduction``; else of the full model's SDIRK2 or
        Gauss-Legendre propagator); floquet_reduced: whether the reduced Floquet analysis answered.
    harmonics: crank harmonics H with a dynamic response; collocation_points: N (both 0 when the steady
        state on the co-rotating reduced basis answered, ``ked_linear.corotating``); radau_steps: that
        basis's Radau IIA steps per cycle (0 when the collocation answered);
        error_estimate: estimated relative error of the history (change from the level below, fraction of the peak).
    damping_reference_hz [Hz], damping_beta [s]: the stiffness-proportional damping used.
    speed_ratio: Omega / omega1_min, omega1_min = 2 pi min over the grid of the first unstressed frozen
        natural frequency (``ked_quasi.natural_frequencies``).
    frozen_f1_hz (n,) [Hz]: first natural frequency of (M, K(theta)) as solved (prestressed if
        ``settings.prestress``; negative if the prestressed structure buckles).
    wall_s [s]: wall time of the solve.
    """

    crank_angle: np.ndarray
    deflection: np.ndarray
    status: str
    stable: bool
    message: str
    floquet_max_abs: float
    floquet_error: float
    floquet_steps: int
    harmonics: int
    collocation_points: int
    error_estimate: float
    damping_reference_hz: float
    damping_beta: float
    speed_ratio: float
    frozen_f1_hz: np.ndarray
    settings: LinearSettings
    wall_s: float
    radau_steps: int = 0
    floquet_reduced: bool = False


MAX_COORDINATES = 240
"""Largest number of elastic coordinates (2 per moving lump) the linear model accepts (the Floquet step
matrices alone take 2 x steps x (2n)^2 x 8 bytes: 470 MB at 240 coordinates and 512 steps)."""

UNRESOLVED_ESTIMATE = 0.02
"""A history whose estimated discretization error exceeds this fraction of its peak is flagged
"unresolved": the periodic solve did not converge within ``max_harmonics`` (typically a frozen higher
mode whose frequency sweeps over many crank harmonics during the cycle)."""


WEAKLY_DAMPED = 0.9
"""max |Floquet multiplier| (plus its error) from which a stable result is flagged "weakly_damped": the
transient shrinks by less than a factor 0.9 per cycle, so the periodic answer is a knife-edge one (a few
per cent of damping, stiffness or speed away from instability) and a time-marching model started from
rest needs many cycles to settle, or never does once its nonlinearity detunes the resonance."""

SETTLE_TOL = 2e-3
SETTLE_BUDGET = 80
"""Cycle-to-cycle change (fraction of the peak) at which a time-marching model counts as settled, and its
budget of cycles: the Exudyn model's defaults (``exudyn_models.DynamicSettings`` steady_tol, max_cycles).
A result whose transient needs more cycles than the budget is flagged "weakly_damped" too."""

RESULT_FLAGS = ("unresolved", "weakly_damped")
"""The linear model's own flags (besides the small-deflection flags of ``ked_quasi.limits``)."""


def cycles_to_settle(max_abs: float, tol: float = SETTLE_TOL) -> float:
    """Cycles after which a transient of the size of the peak, shrinking by ``max_abs`` per cycle,
    changes by less than ``tol`` of the peak from one cycle to the next: mu^n (1 - mu) < tol (inf if
    max_abs >= 1, 0 if it never exceeds tol)."""
    if not max_abs < 1.0:
        return float("inf")
    if max_abs <= 0.0 or 1.0 - max_abs <= tol:
        return 0.0 if max_abs <= 0.0 else float(np.log(tol) / np.log(max_abs))
    return max(0.0, float(np.log(tol / (1.0 - max_abs)) / np.log(max_abs)))


def weakly_damped(res: LinearResult) -> bool:
    """max |mu| + its error >= :data:`WEAKLY_DAMPED`, or a transient that needs more than
    :data:`SETTLE_BUDGET` cycles to settle."""
    err = res.floquet_error if np.isfinite(res.floquet_error) else 0.0
    mu = res.floquet_max_abs + err
    return bool(mu >= WEAKLY_DAMPED or cycles_to_settle(mu) > SETTLE_BUDGET)


def result_flags(res: LinearResult, fourbar: object) -> tuple[str, ...]:
    """Validity flags of a stable result: the small-deflection bounds of ``ked_quasi.limits`` plus
    "unresolved" (error estimate above :data:`UNRESOLVED_ESTIMATE`, or none: a single level) and
    "weakly_damped" (:func:`weakly_damped`); () when not stable (no history)."""
    from ked_quasi import limits

    if not res.stable:
        return ()
    found = limits.flags(res.deflection, fourbar)
    found += ("unresolved",) if not res.error_estimate <= UNRESOLVED_ESTIMATE else ()
    return found + (("weakly_damped",) if weakly_damped(res) else ())


def describe_flags(found: tuple[str, ...], res: LinearResult, fourbar: object) -> str:
    """One line per kind of flag, "; "-joined (empty if none)."""
    from ked_quasi import limits

    parts = [limits.describe(tuple(f for f in found if f not in RESULT_FLAGS), res.deflection, fourbar)]
    if "unresolved" in found:
        way_out = "raise max_harmonics" if res.settings.max_harmonics < HARMONICS.hi else "use the Exudyn model"
        where = f"{res.harmonics} harmonics" if res.harmonics > 0 else "the co-rotating reduced basis"
        parts.append(f"periodic solve not converged: estimated error {res.error_estimate:.2g} of the peak on "
                     f"{where} (not <= {UNRESOLVED_ESTIMATE:g}); {way_out}")
    if "weakly_damped" in found:
        n = cycles_to_settle(res.floquet_max_abs)
        mu = res.floquet_max_abs
        parts.append(f"weakly damped: max |Floquet multiplier| {mu:.3g} (not < {WEAKLY_DAMPED:g}), the "
                     f"transient shrinks only x{res.floquet_max_abs:.3g} per cycle (~{n:.0f} cycles to settle within "
                     f"{SETTLE_TOL:g} of the peak): close to a parametric resonance, the periodic answer is no valid "
                     "answer here and a nonlinear model may never settle; avoid this speed or add damping")
    return "; ".join(p for p in parts if p)


MARGINAL = "marginal (undamped)"
"""Verdict of an undamped linkage whose multipliers all lie on the unit circle (within their error)."""


def _message(status: str, mu: float, mu_err: float, est: float, tol: float, H: int) -> str:
    if status == "marginal":
        return (f"{MARGINAL}: max |Floquet multiplier| = {mu:.9g} (+- {mu_err:.2g}), on the unit circle: free "
                "vibrations never decay, no asymptotically stable periodic steady state (add damping)")
    if status == "unstable":
        return (f"unstable: max |Floquet multiplier| = {mu:.6g} (+- {mu_err:.2g}) not safely below 1, no stable "
                "periodic steady state (parametric resonance, buckling, or no damping)")
    weak = "weakly damped, " if mu + mu_err >= WEAKLY_DAMPED else ""
    how = f"{H} dynamic harmonics" if H > 0 else "steady state on the co-rotating reduced basis"
    text = f"{weak}stable (max |Floquet multiplier| = {mu:.4g} +- {mu_err:.2g}), {how}"
    if not est < tol:
        text += f"; estimated error {est:.2g} above tolerance {tol:g} at the largest harmonics tried"
    return text
