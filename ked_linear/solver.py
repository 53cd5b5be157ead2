"""solve_linear: the linear time-periodic KED model of a scene, its periodic steady state and stability."""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ked_quasi.scene import Scene
from ked_quasi.solver import natural_frequencies

from .floquet import floquet
from .linkage import frozen_frequencies, linkage_system
from .periodic import steady_state
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
        floquet_error: its estimated absolute error; floquet_steps: propagator steps per cycle.
    harmonics: crank harmonics H with a dynamic response; collocation_points: N;
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
        parts.append(f"periodic solve not converged: estimated error {res.error_estimate:.2g} of the peak at "
                     f"{res.harmonics} harmonics (not <= {UNRESOLVED_ESTIMATE:g}); {way_out}")
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
    text = f"{weak}stable (max |Floquet multiplier| = {mu:.4g} +- {mu_err:.2g}), {H} dynamic harmonics"
    if not est < tol:
        text += f"; estimated error {est:.2g} above tolerance {tol:g} at the largest harmonics tried"
    return text


def elastic_coordinates(scene: Scene) -> int:
    """Elastic coordinates of the linear model of ``scene``: 2 per frame node carrying mass (as
    ``ked_quasi.frame.condensed_structure`` keeps them), counted without any frame solve."""
    from ked_quasi.massmodel import lumps
    from ked_quasi.solver import node_masses
    from ked_quasi.structure import topology

    lm = lumps(scene.fourbar, scene.mass_model)
    return 2 * int(np.count_nonzero(node_masses(topology(lm), lm) > 0))


def _is_slider(scene: object) -> bool:
    from ked_quasi.slidercrank import SliderScene

    return isinstance(scene, SliderScene)


def solve_linear(scene: Scene, settings: LinearSettings | None = None) -> LinearResult:
    """Periodic steady state of the linear KED model of ``scene`` (see docs/linear_model.md); a slider-crank
    scene goes to :func:`ked_linear.slider.solve_slider_linear`."""
    if _is_slider(scene):
        from .slider import solve_slider_linear

        return solve_slider_linear(scene, settings)
    t0 = time.perf_counter()
    settings = LinearSettings() if settings is None else settings
    if not isinstance(settings, LinearSettings):
        raise TypeError(f"settings must be a LinearSettings, got {type(settings).__name__}")
    # refused before any work (the damping reference frequency of an oversized model alone takes a minute)
    size = elastic_coordinates(scene)
    if size > MAX_COORDINATES:
        raise ValueError(f"mass model: the linear KED model takes at most {MAX_COORDINATES // 2} moving lumps "
                         f"({MAX_COORDINATES} coordinates: its memory grows as their square times the Floquet "
                         f"steps); this scene has {size // 2}: use fewer lumps per link")
    ls = linkage_system(scene, settings)
    theta = scene.crank_angles
    ss = steady_state(ls.system, theta, settings.tolerance, settings.harmonics, settings.max_harmonics,
                      OUTPUT_GROUPS)
    fl = floquet(ls.system, settings.floquet_tolerance, settings.floquet_steps)
    # the uncertainty counts against stability: a multiplier within its error of 1 is no attracting orbit
    err = fl.error_estimate if np.isfinite(fl.error_estimate) else 0.0
    stable = bool(fl.max_abs + err < 1.0)
    # undamped: max |mu| >= 1 in theory (det Phi = 1, reciprocal pairs); = 1 within its error is marginal
    marginal = not stable and settings.damping_ratio == 0.0 and fl.max_abs - 1.0 <= err
    status = "ok" if stable else "marginal" if marginal else "unstable"
    deflection = ss.output if stable else np.full_like(ss.output, np.nan)
    f1 = natural_frequencies(scene, n_modes=1)[:, 0]
    return LinearResult(
        crank_angle=theta, deflection=deflection, status=status, stable=stable,
        message=_message(status, fl.max_abs, fl.error_estimate, ss.error_estimate, settings.tolerance,
                         ss.solution.harmonics),
        floquet_max_abs=fl.max_abs, floquet_error=fl.error_estimate, floquet_steps=fl.steps,
        harmonics=ss.solution.harmonics, collocation_points=ss.solution.points, error_estimate=ss.error_estimate,
        damping_reference_hz=ls.damping_reference_hz, damping_beta=ls.damping_beta,
        speed_ratio=float(scene.omega / (2.0 * np.pi * np.min(f1))),
        frozen_f1_hz=frozen_frequencies(scene, theta, settings.prestress)[:, 0], settings=settings,
        wall_s=time.perf_counter() - t0,
    )
