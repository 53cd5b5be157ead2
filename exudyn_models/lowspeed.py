"""Time step at low speed: the axial damping of the integrator's velocity error.

The index-3 generalized-alpha scheme places every node on its (quasi-static) position at each step, but
its velocities carry an O(h^2) error. For a link turning at a varying rate phi'(t) that error has a
component along the link, so the links seem to stretch: a spurious axial strain rate ~ c h^2 phi' phi''
(the crank, turning uniformly, has none). Measured (thesis cognate, extender model, 1 rpm, 720 steps per
cycle): 3.3e-8 1/s on the coupler, extender and follower, uniform along each link, 4x smaller at half the
step, the same for spectral radii 0.6-0.99. The stiffness-proportional damping (exudyn_models.damping)
turns it into axial forces beta E A eps_t, comparable with the inertia loads at low speed: a deflection
error ~ beta Omega h^2 that does not shrink with the speed like the deflection (~ Omega^2) does. Relative to
the quasi-static peak it grows like 1/Omega:

    e ~ A * (beta / 2) * Omega_1^2 / Omega * (2 pi / N)^2     (= A zeta (Omega_1 / Omega) (2 pi / N)^2
                                                                 when the damping reference is f_1)

(Omega_1 = 2 pi f_1, the structure's mean first natural frequency; Omega the crank speed; N steps per
cycle). Measured at 1 rpm, 720 steps, zeta 0.02 (error of the history against the quasi-static one,
Newton increment test): thesis cognate extender 9.5e-4 of the peak (no damping: 5.1e-5), 1440 steps:
2.6e-4; cognate joints 5.0e-4 / rotation 9.6e-4, 1440 steps: 1.7e-4 / 2.8e-4. A = DAMPING_ERROR_FACTOR
bounds these. The steps per cycle a run uses are the given ones times the smallest integer k that brings
the estimate below STEP_ERROR_TARGET, and only where the estimate also exceeds (2 pi / N)^2, the size of
the integrator's ordinary relative O(h^2) error of the crank harmonics (A zeta Omega_1 / Omega > 1, i.e.
Omega_1 / Omega > 200 at zeta 0.02: the quasi-static regime, where this error alone does not fall with the
speed). Elsewhere the step error is the ordinary one, which steps_per_cycle is there to set (a deliberately
coarse run, e.g. 72 steps per cycle at 240 rpm, stays as given), and the run is bit for bit what it was
(thesis default campaign, 30-300 rpm: k = 1 everywhere); at 1 rpm k = 2-3.
"""

from __future__ import annotations

import math
from dataclasses import replace

from .settings import DynamicSettings

DAMPING_ERROR_FACTOR = 0.25
"""A in the estimate (module doc): bounds the measured thesis cases (0.14 for the cognate extender, 0.25
for the cognate joints rotation)."""

STEP_ERROR_TARGET = 2.5e-4
"""Largest estimated error (fraction of the quasi-static peak) the low-speed step leaves: a quarter of the
1e-3 the reference must meet."""

MAX_STEPS_PER_CYCLE = 23040
"""No refinement beyond this (the refinement ladder's cap)."""


def step_error_estimate(scene, steps_per_cycle: int, damping_beta: float, f1_hz: float) -> float:
    """Estimated error [fraction of the peak] of the axially damped velocity error (module doc)."""
    omega = 2.0 * math.pi * scene.rpm / 60.0
    if not (damping_beta > 0.0 and omega > 0.0 and math.isfinite(f1_hz) and f1_hz > 0.0):
        return 0.0
    omega1 = 2.0 * math.pi * f1_hz
    return DAMPING_ERROR_FACTOR * 0.5 * damping_beta * omega1**2 / omega * (2.0 * math.pi / steps_per_cycle) ** 2


def low_speed_steps(scene, settings: DynamicSettings, damping_beta: float, f1_hz: float) -> int:
    """Steps per cycle a run uses: settings.steps_per_cycle times the smallest integer k with the estimate
    below STEP_ERROR_TARGET, where the estimate exceeds both that target and (2 pi / N)^2 (module doc;
    capped at MAX_STEPS_PER_CYCLE; never fewer than given)."""
    n = settings.steps_per_cycle
    e = step_error_estimate(scene, n, damping_beta, f1_hz)
    if e <= STEP_ERROR_TARGET or e <= (2.0 * math.pi / n) ** 2:
        return n  # small, or not above the ordinary O(h^2) step error, which steps_per_cycle is there for
    k = math.ceil(math.sqrt(e / STEP_ERROR_TARGET))
    return max(n, min(k * n, MAX_STEPS_PER_CYCLE // n * n))


def run_settings(scene, settings: DynamicSettings, damping_beta: float) -> DynamicSettings:
    """The settings a run uses: settings with steps_per_cycle raised by low_speed_steps (same object when
    unchanged). f_1 from ked_quasi's frozen-structure frequencies (exudyn_models.damping)."""
    if not damping_beta > 0.0:
        return settings
    from .damping import reference_frequency

    f1 = reference_frequency(scene, replace(settings, damping_reference_hz=None))
    n = low_speed_steps(scene, settings, damping_beta, f1)
    return settings if n == settings.steps_per_cycle else replace(settings, steps_per_cycle=n)
