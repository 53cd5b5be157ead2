"""The stress part of the design check: per link the peak stress of each tier, the quasi-static stress
history's error against the linear model's, and the fatigue safety factors (:mod:`ked_quasi.stress`,
:mod:`ked_linear.stress`, :mod:`ked_quasi.fatigue`).

Keys (all floats; NaN where a tier has no answer):

* ``quasi_static_peak_pa_<link>``, ``linear_peak_pa_<link>``: max over the cycle of |sigma| [Pa] over the link;
* ``stress_error_<link>``: max over the cycle of |sigma_qs - sigma_lin| (largest and smallest fibre stress)
  divided by the linear peak [1] (the deflection verdict's peak-normalised history error);
* with a material: ``goodman_quasi_static``, ``goodman_linear``: the smallest Goodman safety factor over the
  links [1]; ``goodman_overstatement``: goodman_quasi_static / goodman_linear - 1 [1] (> 0: the quasi-static factor is
  the more optimistic); ``safety_factor_quasi_static``, ``safety_factor_linear``, ``safety_factor_overstatement``:
  the same by the material's criterion (goodman, gerber or asme-elliptic; equal to the Goodman keys for goodman);
* with an S-N curve: ``life_cycles_quasi_static``, ``life_cycles_linear``: the shortest life over the links
  [cycles] (inf, null in JSON, where it lies beyond the curve's last point: then ``life_unbounded_<tier>`` is 1.0),
  ``life_overstatement``: life_cycles_quasi_static / life_cycles_linear [1] (> 1: the quasi-static life is the
  longer), ``life_above_curve``: 1.0 where a tier's most damaged point lies above the curve's first amplitude
  (its life is then at most that point's cycles).

With ``ked check --confirm`` (Exudyn's link stresses measured on the same scene, an answer inside the
small-deflection range): ``exudyn_peak_pa_<link>`` [Pa], ``stress_error_exudyn_<link>`` and
``linear_stress_error_exudyn_<link>`` [1]: the quasi-static and the linear stress history's error against
Exudyn's (the campaign's ``stress_<link>`` metric); the stress verdict is then the measurement's.

A linkage whose linear steady state of the masses is not resolved to :data:`ked_linear.motion.MAX_ERROR` (its
accelerations would not be trusted).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ked_quasi.fatigue import Material, history_fatigue
from ked_quasi.kinds import quasi_static_stress
from ked_quasi.stress import StressHistory, history_error


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
        out.update(_fatigue_keys(qs, lin, material))
    return out


def _fatigue_keys(qs: StressHistory, lin: StressHistory | None, material: Material) -> dict[str, float]:
    """The fatigue keys (see the module docstring) of the quasi-static and the linear stresses."""
    out: dict[str, float] = {}
    tiers = {"quasi_static": qs, **({"linear": lin} if lin is not None else {})}
    for prefix, criterion in (("goodman", "goodman"), ("safety_factor", material.criterion)):
        for tier, history in tiers.items():
            out[f"{prefix}_{tier}"] = _smallest(history_fatigue(history, material, criterion))
        if lin is not None:
            n_qs, n_lin = out[f"{prefix}_quasi_static"], out[f"{prefix}_linear"]
            out[f"{prefix}_overstatement"] = n_qs / n_lin - 1.0 if math.isfinite(n_lin) and n_lin > 0 else math.nan
    if material.sn_curve is None:
        return out
    beyond = False
    for tier, history in tiers.items():
        links = history_fatigue(history, material, material.criterion).values()
        lives = [f.life_cycles for f in links if not math.isnan(f.life_cycles)]
        out[f"life_cycles_{tier}"] = min(lives) if lives else math.nan
        out[f"life_unbounded_{tier}"] = float(math.isinf(out[f"life_cycles_{tier}"]))
        beyond |= any(f.life_beyond for f in links)
    if lin is not None:
        a, b = out["life_cycles_quasi_static"], out["life_cycles_linear"]
        out["life_overstatement"] = a / b if math.isfinite(b) and b > 0 else math.nan
    out["life_above_curve"] = float(beyond)
    return out


def measured_stress_keys(r: Any) -> dict[str, float]:
    """The keys measured against Exudyn (see the module docstring) of a computed scene ``r`` (a
    :class:`compare.results.SceneResult`); empty without Exudyn's stresses or with its answer flagged."""
    dyn = r.solutions.get("dynamic")
    if dyn is None or not dyn.ok or dyn.flags or not dyn.stress:
        return {}
    out = {f"exudyn_peak_pa_{lk}": float(np.nanmax(np.abs(v))) for lk, v in dyn.stress.items()}
    for solver, prefix in (("quasi_static", "stress_error_exudyn_"), ("linear", "linear_stress_error_exudyn_")):
        m = r.metrics.get(f"{solver}_vs_dynamic")
        for c in (m.stress_components if m is not None else ()):
            out[prefix + c.component.removeprefix("stress_")] = float(c.history_error)
    return out


def stress_verdict(keys: dict[str, float], tolerance: float) -> str:
    """The stress verdict of one speed: whether the quasi-static stress of every link is within ``tolerance``
    of Exudyn's where it was measured (``stress_error_exudyn_<link>``, ``ked check --confirm``), else of the
    linear model's (``stress_error_<link>``).  The latter grants no tier: the stress prediction is not calibrated
    against Exudyn per stratum (``ked study stress`` measures it on a sample: the linear model's stress misses
    the axial force's bending (P-delta) that Exudyn's beams carry), so the verdict says so."""
    measured = {k.removeprefix("stress_error_exudyn_"): v for k, v in keys.items()
                if k.startswith("stress_error_exudyn_")}
    if measured and all(math.isfinite(v) for v in measured.values()):
        worst = max(measured, key=measured.get)
        e = measured[worst]
        return (f"Stress (measured against Exudyn): the quasi-static stress is within {e:.1%} of Exudyn's on every "
                f"link (worst: {worst}), inside the tolerance {tolerance:.0%}" if e < tolerance else
                f"Stress (measured against Exudyn): the quasi-static stress is off by {e:.1%} on the {worst} "
                f"(tolerance {tolerance:.0%}): use a dynamic model's stresses")
    errors = {k.removeprefix("stress_error_"): v for k, v in keys.items()
              if k.startswith("stress_error_") and not k.startswith("stress_error_exudyn_")}
    if not errors or not all(math.isfinite(v) for v in errors.values()):
        return "Stress: no linear answer to compare the quasi-static stress with (not calibrated against Exudyn)"
    worst = max(errors, key=errors.get)
    e = errors[worst]
    head = (f"Stress: the quasi-static stress is within {e:.1%} of the linear model's on every link (worst: "
            f"{worst}), inside the tolerance {tolerance:.0%}" if e < tolerance else
            f"Stress: the quasi-static stress is off by {e:.1%} on the {worst} (tolerance {tolerance:.0%}): use "
            "the linear model's stresses")
    return head + "; not calibrated against Exudyn, so no tier is granted from it"


def _smallest(links: dict[str, Any]) -> float:
    factors = [f.safety_factor for f in links.values() if math.isfinite(f.safety_factor)]
    return min(factors) if factors else math.nan


def fatigue_line(keys: dict[str, float], criterion: str = "goodman") -> str:
    """One line: the safety factor of each tier by ``criterion`` and how much the quasi-static one overstates it;
    with an S-N curve, the life of each tier too."""
    if "safety_factor_quasi_static" not in keys:
        return "Fatigue: give --ultimate-strength and --endurance-limit (Pa) for the Goodman safety factor"
    name = {"goodman": "Goodman", "gerber": "Gerber", "asme-elliptic": "ASME-elliptic"}.get(criterion, criterion)
    qs = keys["safety_factor_quasi_static"]
    if not math.isfinite(keys.get("safety_factor_linear", math.nan)):
        return f"Fatigue ({name}): safety factor {qs:.3g} quasi-static (no linear answer to compare)" + _life(keys)
    over = keys["safety_factor_overstatement"]
    how = "overstates" if over >= 0 else "understates"
    return (f"Fatigue ({name}): safety factor {keys['safety_factor_linear']:.3g} linear, {qs:.3g} quasi-static "
            f"(the quasi-static factor {how} it by {abs(over):.1%})" + _life(keys))


def _life(keys: dict[str, float]) -> str:
    """The life part of the fatigue line ("" without an S-N curve)."""
    if "life_cycles_quasi_static" not in keys:
        return ""
    text = {t: _cycles(keys[f"life_cycles_{t}"]) for t in ("linear", "quasi_static") if f"life_cycles_{t}" in keys}
    out = "; life " + ", ".join(f"{t.replace('_', '-')} {v}" for t, v in text.items())
    ratio = keys.get("life_overstatement", math.nan)
    if math.isfinite(ratio):
        out += f" (the quasi-static life is {ratio:.3g} x the linear one)"
    if keys.get("life_above_curve"):
        out += "; a stress above the S-N curve's first point: that life is at most its first point's cycles"
    return out


def _cycles(n: float) -> str:
    return "beyond the S-N curve" if math.isinf(n) else "-" if math.isnan(n) else f"{n:.3g} cycles"


__all__ = ["fatigue_line", "stress_keys", "stress_verdict"]
