"""Fatigue safety factors of the links from a steady cycle of fibre stresses (pure numpy).

At each fibre location of a link (every element end, both extreme fibres, signed: the upper fibre sees
N/A + M c/I and the lower N/A - M c/I, so a moment that changes sign cycles one fibre through tension and
compression) the steady cycle gives the mean and alternating stress

    sigma_m = (max_t sigma + min_t sigma) / 2,     sigma_a = (max_t sigma - min_t sigma) / 2,

and a mean-stress criterion the fatigue safety factor n (Shigley's Mechanical Engineering Design, 9th ed.,
section 6-12, table 6-7/6-8):

    goodman        1/n = sigma_a/S_e + sigma_m/S_ut                                          (eq. 6-46)
    gerber         n = (S_ut/sigma_m)^2 sigma_a/(2 S_e) [-1 + sqrt(1 + (2 sigma_m S_e/(S_ut sigma_a))^2)]  (6-47)
    asme-elliptic  1/n^2 = (sigma_a/S_e)^2 + (sigma_m/S_y)^2                                  (eq. 6-48)

For a compressive mean stress (sigma_m <= 0) every criterion gives n = S_e / sigma_a (Shigley section 6-12:
a compressive mean does not shorten fatigue life; first-cycle yield is a separate check).  A fibre with no
alternating stress and no tensile mean never fails in fatigue: n = inf.  The link's factor is the smallest
over its fibre locations.  Stresses and strengths in Pa.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .rules import Rule, check_choice

CRITERIA = ("goodman", "gerber", "asme-elliptic")

_STRENGTH_MIXUP = ("strengths are in Pa", "MPa", 1e6, "e.g. 6.9e8 Pa for a cold-drawn AISI 1050 steel")
ULTIMATE_STRENGTH = Rule("ultimate_strength", "Pa", 1e6, 1e10, "a link's material, from soft polymers (~10 MPa) "
                         "to the strongest steels (~5 GPa)", mixup_low=_STRENGTH_MIXUP)
ENDURANCE_LIMIT = Rule("endurance_limit", "Pa", 1e5, 1e10, "the fully reversed stress amplitude the part "
                       "survives indefinitely (or at the design life), below the ultimate strength",
                       mixup_low=_STRENGTH_MIXUP)
YIELD_STRENGTH = Rule("yield_strength", "Pa", 1e6, 1e10, "the material's yield strength, at most its ultimate "
                      "strength", mixup_low=_STRENGTH_MIXUP)


@dataclass(frozen=True)
class FatigueMaterial:
    """Strengths of a link's material for the fatigue check.

    ultimate_strength S_ut [Pa]; endurance_limit S_e [Pa] (of the part, i.e. after surface, size and other
    Marin factors; for a metal without an endurance limit: its fatigue strength at the design life), at most
    S_ut; yield_strength S_y [Pa] (only the ASME-elliptic criterion needs it), at most S_ut.
    """

    ultimate_strength: float
    endurance_limit: float
    yield_strength: float | None = None

    def __post_init__(self) -> None:
        su = ULTIMATE_STRENGTH.check(self.ultimate_strength, "FatigueMaterial.ultimate_strength")
        se = ENDURANCE_LIMIT.check(self.endurance_limit, "FatigueMaterial.endurance_limit")
        if se > su:
            raise ValueError(f"FatigueMaterial.endurance_limit: {se:g} Pa exceeds the ultimate strength {su:g} Pa; "
                             "allowed: a positive stress amplitude in Pa at most ultimate_strength (for steels "
                             "about half of it)")
        object.__setattr__(self, "ultimate_strength", float(su))
        object.__setattr__(self, "endurance_limit", float(se))
        if self.yield_strength is not None:
            sy = YIELD_STRENGTH.check(self.yield_strength, "FatigueMaterial.yield_strength")
            if sy > su:
                raise ValueError(f"FatigueMaterial.yield_strength: {sy:g} Pa exceeds the ultimate strength {su:g} "
                                 "Pa; allowed: a stress in Pa at most ultimate_strength")
            object.__setattr__(self, "yield_strength", float(sy))

    def to_dict(self) -> dict[str, float]:
        """Plain dict (TOML, JSON, HDF5 attributes); ``yield_strength`` only when given."""
        d = {"ultimate_strength": self.ultimate_strength, "endurance_limit": self.endurance_limit}
        if self.yield_strength is not None:
            d["yield_strength"] = self.yield_strength
        return d


def mean_alternating(history: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean and alternating stress [Pa] over the cycle (axis 0) of a stress history (n, ...) [Pa]; angles
    without an answer (NaN) are skipped."""
    hi, lo = np.nanmax(history, axis=0), np.nanmin(history, axis=0)
    return 0.5 * (hi + lo), 0.5 * (hi - lo)


def safety_factor(sigma_m: np.ndarray | float, sigma_a: np.ndarray | float, material: FatigueMaterial,
                  criterion: str = "goodman") -> np.ndarray:
    """Fatigue safety factor n (element-wise) of mean ``sigma_m`` and alternating ``sigma_a`` stresses [Pa]
    by ``criterion`` (one of :data:`CRITERIA`; see the module docstring for the formulas)."""
    check_choice("criterion", criterion, CRITERIA)
    if criterion == "asme-elliptic" and material.yield_strength is None:
        raise ValueError("FatigueMaterial.yield_strength: the asme-elliptic criterion needs the yield strength "
                         "[Pa]; give it, or use goodman or gerber")
    sm = np.asarray(sigma_m, dtype=float)
    sa = np.abs(np.asarray(sigma_a, dtype=float))
    se, su = material.endurance_limit, material.ultimate_strength
    smp = np.maximum(sm, 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        if criterion == "goodman":
            n = 1.0 / (sa / se + smp / su)
        elif criterion == "gerber":
            ratio = 2.0 * smp * se / (su * sa)
            gerber = (su / smp) ** 2 * sa / (2.0 * se) * (-1.0 + np.sqrt(1.0 + ratio**2))
            # sigma_m -> 0 is the fully reversed limit S_e/sigma_a; sigma_a -> 0 the static limit S_ut/sigma_m
            n = np.where(smp == 0.0, se / sa, np.where(sa == 0.0, su / smp, gerber))
        else:
            n = 1.0 / np.sqrt((sa / se) ** 2 + (smp / material.yield_strength) ** 2)
    return np.where((sa == 0.0) & (smp == 0.0), np.inf, n)


def link_safety_factor(link: object, material: FatigueMaterial, criterion: str = "goodman") -> float:
    """Smallest fatigue safety factor over a link's fibre locations from its steady-cycle stress history
    (a :class:`ked_quasi.stress.LinkStress`: ``axial`` (n, E) [N], ``moment`` (n, E, 2) [N m], ``area``,
    ``second_moment``, ``fibre``); signed upper and lower fibres, see the module docstring."""
    axial = np.asarray(link.axial)[..., None] / link.area
    bending = np.asarray(link.moment) * (link.fibre / link.second_moment)
    fibres = np.stack([axial + bending, axial - bending], axis=-1)  # (n, E, 2 ends, 2 fibres)
    sm, sa = mean_alternating(fibres)
    return float(np.min(safety_factor(sm, sa, material, criterion)))


__all__ = ["CRITERIA", "FatigueMaterial", "link_safety_factor", "mean_alternating", "safety_factor"]
