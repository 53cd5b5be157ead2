"""Newton tolerances scaled to the size of the deflection.

Exudyn's Newton test is on the residual (forces [N]) of the whole system, whose size is set by the
rigid motion (constraint and inertia terms of links metres long), not by the elastic deflection. At low
speed the deflection is tiny (the thesis tip model: 0.8 um at 1 rpm against links of 0.76 m), so fixed
tolerances leave an error that is a fixed fraction of the rigid motion and a large fraction of the
deflection (measured: 1.1 % of the peak at 1 rpm with the 1e-6 relative tolerance). The tolerances
actually used are therefore the given ones tightened to the deflection's scale:

    rel = min(settings.newton_rel_tol, REL_FRACTION * d_qs / L)
    abs = max(min(settings.newton_abs_tol, ABS_FRACTION * F_qs), ROUNDOFF_TOLERANCE * max(E*A))

d_qs [m]: peak |(dx, dy)| of the coupler point in the quasi-static limit (ked_quasi.solve_quasi_static,
same scene: cheap, vectorized); L [m]: the longest link; F_qs [N]: the largest d'Alembert load on a node
in that solution. The given values stay upper bounds (nothing is ever loosened); at the speeds where
the deflection is large they are the ones used (thesis linkage: from ~35 rpm up for the relative
tolerance). The round-off floor keeps the absolute tolerance reachable for very stiff links.

Where the force the deflection needs, ABS_FRACTION * F_qs, is below that round-off floor, no force test
can resolve the deflection: the residual of the axial forces (E*A ~ 1e7 N times a strain round-off of
1e-16, summed over the coordinates) is itself ~1e-8 N, and a tolerance of 1e-15 E*A makes Newton fail.
There the test is on the Newton increment instead (Exudyn newton.residualMode = 1: converged when the
L2 norm of the coordinate increment is below max(INCREMENT_FRACTION * d_qs, INCREMENT_ROUNDOFF * L) [m]),
whose round-off is that
force divided by the axial stiffness, ~1e-16 m. Measured (thesis cognate, extender, 1 rpm, 4 elements,
720 steps, no damping): 3.4e-4 of the peak left by the force test at its lowest workable floor (1e-14 E*A;
6.0e-3 at the 1e-13 E*A floor), 5.1e-5 with the increment test at 1e-4, 1e-5 or 1e-6 of d_qs alike
(the rest is the time step's, falling like h^2). Thesis linkage: every mass model at 1 rpm, the extender
and distributed models at 10 rpm and the extender model at 30 rpm.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from .settings import DynamicSettings

ROUNDOFF_TOLERANCE = 1e-13
"""The residual's round-off grows like 1e-16 * E*A [N]; the Newton absolute tolerance is kept at
least ROUNDOFF_TOLERANCE * max(E*A), so that it stays reachable for very stiff links (E x 1e4 and
more) while staying far below the inertia forces."""

REL_FRACTION = 1e-3
"""Relative Newton tolerance per unit of d_qs / L. Measured (thesis source tip, 1 rpm, 4 elements, 720
steps): the error against the quasi-static limit is ~0.012 * rel * L / d_qs, so this fraction keeps the
Newton part of the error near 1e-5 of the peak."""

ABS_FRACTION = 1e-5
"""Absolute Newton tolerance per unit of the largest quasi-static d'Alembert load F_qs [N]."""

INCREMENT_FRACTION = 1e-5
"""Newton increment tolerance [m] per unit of d_qs, used where ABS_FRACTION * F_qs is below the round-off
floor (module doc)."""

INCREMENT_ROUNDOFF = 2e-12
"""Lower bound of the increment tolerance per unit of the longest link [m/m]. Measured: links 1e6 x
stiffer (deflection 1e-8 m at 300 rpm, distributed mass) fail Newton at an increment tolerance of 1.2e-13 m
and pass at 1.2e-12 m; at nominal stiffness (1 rpm, cognate extender, d_qs 1.5e-8 m) 1e-6 to 1e-4 of d_qs
give the same history, so this bound (1.5e-12 m = 1e-4 d_qs there) costs no accuracy."""


@dataclass(frozen=True)
class NewtonTolerances:
    """Tolerances handed to Exudyn's Newton solver: abs_n [N] (residual), rel [1]; d_qs [m] and F_qs [N]:
    the quasi-static peak deflection and load they were scaled to (NaN when not available).
    increment: the test is on the Newton increment instead of the residual; abs_n and rel are then both
    that increment tolerance [m] (Exudyn's residualMode 1 wants them equal)."""

    abs_n: float
    rel: float
    d_qs: float = math.nan
    f_qs: float = math.nan
    increment: bool = False

    def text(self) -> str:
        if self.increment:
            return (f"Newton increment tolerance {self.abs_n:.3g} m (quasi-static peak {self.d_qs:.3g} m; "
                    "the force the deflection needs is below the residual's round-off)")
        return f"Newton tolerances abs {self.abs_n:.3g} N, rel {self.rel:.3g} (quasi-static peak {self.d_qs:.3g} m)"


def roundoff_floor(fourbar) -> float:
    """ROUNDOFF_TOLERANCE * max(E*A) [N]."""
    return ROUNDOFF_TOLERANCE * max(s.youngs_modulus * s.area for s in fourbar.sections)


def newton_abs_tolerance(settings: DynamicSettings, fourbar) -> float:
    """The given absolute tolerance with the round-off floor: max(settings.newton_abs_tol, 1e-13 max(E*A))
    [N] (no scaling; newton_tolerances is what the runs use)."""
    return max(settings.newton_abs_tol, roundoff_floor(fourbar))


def quasi_static_scale(scene) -> tuple[float, float]:
    """(d_qs [m], F_qs [N]): peak |(dx, dy)| of P and the largest nodal d'Alembert load of the
    quasi-static solution of the scene (NaN if it cannot be computed, e.g. at a toggle everywhere)."""
    from ked_quasi.solver import solve_quasi_static

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            qs = solve_quasi_static(scene)
    except (ValueError, ArithmeticError, np.linalg.LinAlgError):
        return math.nan, math.nan
    d = np.hypot(qs.deflection[:, 0], qs.deflection[:, 1])
    f = np.hypot(qs.loads[..., 0], qs.loads[..., 1])
    d_qs = float(np.nanmax(d)) if np.isfinite(d).any() else math.nan
    f_qs = float(np.nanmax(f)) if np.isfinite(f).any() else math.nan
    return d_qs, f_qs


def newton_tolerances(settings: DynamicSettings, scene) -> NewtonTolerances:
    """The Newton tolerances a run of `scene` uses (module doc)."""
    fourbar = scene.fourbar
    d_qs, f_qs = quasi_static_scale(scene)
    length = max(fourbar.crank, fourbar.coupler, fourbar.follower, fourbar.extender)
    rel, abs_n = settings.newton_rel_tol, settings.newton_abs_tol
    if math.isfinite(d_qs) and d_qs > 0.0:
        rel = min(rel, REL_FRACTION * d_qs / length)
    floor = roundoff_floor(fourbar)
    if math.isfinite(f_qs) and f_qs > 0.0:
        abs_n = min(abs_n, ABS_FRACTION * f_qs)
        if ABS_FRACTION * f_qs < floor and math.isfinite(d_qs) and d_qs > 0.0:
            x = max(INCREMENT_FRACTION * d_qs, INCREMENT_ROUNDOFF * length)
            return NewtonTolerances(abs_n=x, rel=x, d_qs=d_qs, f_qs=f_qs, increment=True)
    return NewtonTolerances(abs_n=max(abs_n, floor), rel=rel, d_qs=d_qs, f_qs=f_qs)
