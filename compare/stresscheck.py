"""The stress part of the design check: per link the peak stress of each tier, the quasi-static stress
history's error against the linear model's, and the fatigue safety factors (:mod:`ked_quasi.stress`,
:mod:`ked_linear.stress`, :mod:`ked_quasi.fatigue`).

Keys (all floats; NaN where a tier has no answer):

* ``quasi_static_peak_pa_<link>``, ``linear_peak_pa_<link>``: max over the cycle of |sigma| [Pa] over the link;
* ``stress_error_<link>``: max over the cycle of |sigma_qs - sigma_lin| (largest and smallest fibre stress)
  divided by the linear peak [1] (the deflection verdict's peak-normalised history error);
* with a material: ``goodman_quasi_static``, ``goodman_linear``: the smallest Goodman safety factor over the
  links [1]; ``goodman_overstatement``: goodman_quasi_static / goodman_linear - 1 [1] (> 0: the quasi-static factor is
  the more optimistic).

A linkage whose linear steady state of the masses is not resolved to :data:`ked_linear.motion.MAX_ERROR` (its
accelerations would not be trusted).
"""

from __future__ import annotations

import math
from typing import Any

from ked_quasi.fatigue import Material, history_fatigue
from ked_quasi.stress import StressHistory, history_error, quasi_static_stress


def stress_keys(scene: Any, linear_settings: Any | None, linear_stable: bool,
                material: Material | None = None) -> dict[str, float]:
    """The stress keys of one speed's ``scene`` (see the module docstring); ``linear_settings``: the linear
    model's settings (None: no linear tier), ``linear_stable``: whether its steady state is stable."""
    qs = quasi_static_stress(scene)
    lin = None
    if linear_settings is not None:
        from ked_linear.stress import linear_stress

        try:
            lin = linear_stress(scene, linear_settings, stable=linear_stable)
        except ValueError:  # the masses' steady state not resolved well enough for its accelerations
            lin = None
    out: dict[str, float] = {}
    for lk, peak in qs.peaks().items():
        out[f"quasi_static_peak_pa_{lk}"] = peak
    if lin is not None:
        for lk, peak in lin.peaks().items():
            out[f"linear_peak_pa_{lk}"] = peak
        for lk, err in history_error(qs, lin).items():
            out[f"stress_error_{lk}"] = err
    if material is not None:
        out["goodman_quasi_static"] = _smallest(qs, material)
        if lin is not None:
            out["goodman_linear"] = _smallest(lin, material)
            n_qs, n_lin = out["goodman_quasi_static"], out["goodman_linear"]
            out["goodman_overstatement"] = n_qs / n_lin - 1.0 if math.isfinite(n_lin) and n_lin > 0 else math.nan
    return out


def stress_verdict(keys: dict[str, float], tolerance: float) -> str:
    """The stress verdict of one speed: whether the quasi-static stress of every link is within ``tolerance``
    of the linear model's (``stress_error_<link>``).  It grants no tier: the stress prediction is not calibrated
    against Exudyn per stratum (``ked study stress`` measures it on a sample: the linear model's stress misses
    the axial force's bending (P-delta) that Exudyn's beams carry), so the verdict says so."""
    errors = {k.removeprefix("stress_error_"): v for k, v in keys.items() if k.startswith("stress_error_")}
    if not errors or not all(math.isfinite(v) for v in errors.values()):
        return "Stress: no linear answer to compare the quasi-static stress with (not calibrated against Exudyn)"
    worst = max(errors, key=errors.get)
    e = errors[worst]
    head = (f"Stress: the quasi-static stress is within {e:.1%} of the linear model's on every link (worst: "
            f"{worst}), inside the tolerance {tolerance:.0%}" if e < tolerance else
            f"Stress: the quasi-static stress is off by {e:.1%} on the {worst} (tolerance {tolerance:.0%}): use "
            "the linear model's stresses")
    return head + "; not calibrated against Exudyn, so no tier is granted from it"


def _smallest(history: StressHistory, material: Material) -> float:
    factors = [f.safety_factor for f in history_fatigue(history, material).values() if math.isfinite(f.safety_factor)]
    return min(factors) if factors else math.nan


def fatigue_line(keys: dict[str, float]) -> str:
    """One line: the Goodman safety factor of each tier and how much the quasi-static one overstates it."""
    if "goodman_quasi_static" not in keys:
        return "Fatigue: give --ultimate-strength and --endurance-limit (Pa) for the Goodman safety factor"
    qs = keys["goodman_quasi_static"]
    if "goodman_linear" not in keys or not math.isfinite(keys["goodman_linear"]):
        return f"Fatigue (Goodman): safety factor {qs:.3g} quasi-static (no linear answer to compare)"
    over = keys["goodman_overstatement"]
    how = "overstates" if over >= 0 else "understates"
    return (f"Fatigue (Goodman): safety factor {keys['goodman_linear']:.3g} linear, {qs:.3g} quasi-static "
            f"(the quasi-static factor {how} it by {abs(over):.1%})")


__all__ = ["fatigue_line", "stress_keys", "stress_verdict"]
