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


@dataclass(frozen=True)
class NewtonTolerances:
    """Tolerances handed to Exudyn's Newton solver: abs_n [N] (residual), rel [1]; d_qs [m] and F_qs [N]:
    the quasi-static peak deflection and load they were scaled to (NaN when not available)."""

    abs_n: float
    rel: float
    d_qs: float = math.nan
    f_qs: float = math.nan

    def text(self) -> str:
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
    if math.isfinite(f_qs) and f_qs > 0.0:
        abs_n = min(abs_n, ABS_FRACTION * f_qs)
    return NewtonTolerances(abs_n=max(abs_n, roundoff_floor(fourbar)), rel=rel, d_qs=d_qs, f_qs=f_qs)
