"""Fatigue safety factors of a steady cycle's fluctuating normal stress (infinite life, stress-life method).

At a point of a link the normal stress over one steady crank cycle fluctuates between sigma_max and
sigma_min; its mean (midrange) and alternating (amplitude) components are

    sigma_m = (sigma_max + sigma_min) / 2,   sigma_a = (sigma_max - sigma_min) / 2.

The fatigue safety factor n against the endurance limit S_e (already corrected for surface, size, load,
temperature and reliability: the Marin factors are the user's) and the ultimate tensile strength S_u, for
sigma_m > 0 (Shigley's Mechanical Engineering Design, chapter 6, "Failure criteria for fluctuating stress",
Tables 6-6 to 6-8):

* Goodman:        1/n = sigma_a/S_e + sigma_m/S_u
* Gerber:         n = 1/2 (S_u/sigma_m)^2 (sigma_a/S_e) [-1 + sqrt(1 + (2 sigma_m S_e / (S_u sigma_a))^2)]
* ASME-elliptic:  n = [(sigma_a/S_e)^2 + (sigma_m/S_y)^2]^(-1/2)   (needs the yield strength S_y)

and for a compressive (or zero) mean, n = S_e / sigma_a for every criterion (failure when sigma_a = S_e,
ibid.).  The points checked are the extreme fibres (both faces) at every element end of a link: the factor of
a link is the smallest over them.  SI units.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .rules import Rule

CRITERIA = ("goodman", "gerber", "asme-elliptic")

_MIXUP = ("strengths are in Pa", "MPa", 1e6, "e.g. 6.9e8 Pa for a cold-drawn AISI 1050 steel")
STRENGTH_RULES = {
    "ultimate_strength": Rule("ultimate_strength", "Pa", 1e6, 1e10, "a link's material, from soft polymers "
                              "(~10 MPa) to the strongest steels (~5 GPa)", mixup_low=_MIXUP),
    "endurance_limit": Rule("endurance_limit", "Pa", 1e5, 1e10, "the corrected fully reversed stress amplitude "
                            "the part survives at the design life, at most the ultimate strength",
                            mixup_low=_MIXUP),
    "yield_strength": Rule("yield_strength", "Pa", 1e6, 1e10, "the material's yield strength, at most its "
                           "ultimate strength", mixup_low=_MIXUP),
}


@dataclass(frozen=True)
class Material:
    """Fatigue strengths of a link's material [Pa]: ultimate_strength S_u (tensile), endurance_limit S_e
    (the corrected, fully reversed endurance limit), yield_strength S_y (optional; the ASME-elliptic
    criterion needs it).  Ranges: :data:`STRENGTH_RULES` (a value that reads as MPa is refused with the
    likely mix-up named); S_e <= S_u, S_y <= S_u."""

    ultimate_strength: float
    endurance_limit: float
    yield_strength: float | None = None

    def __post_init__(self) -> None:
        for name, rule in STRENGTH_RULES.items():
            value = getattr(self, name)
            if value is None and name == "yield_strength":
                continue
            object.__setattr__(self, name, float(rule.check(value, f"Material.{name}")))
        if self.endurance_limit > self.ultimate_strength:
            raise ValueError(f"Material.endurance_limit: {self.endurance_limit:g} Pa exceeds the ultimate strength "
                             f"{self.ultimate_strength:g} Pa; allowed: an endurance limit at most the ultimate "
                             "strength (steels: about half of it)")
        if self.yield_strength is not None and self.yield_strength > self.ultimate_strength:
            raise ValueError(f"Material.yield_strength: {self.yield_strength:g} Pa exceeds the ultimate strength "
                             f"{self.ultimate_strength:g} Pa; allowed: a yield strength at most the ultimate strength")


def mean_alternating(sigma: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(sigma_m, sigma_a) [Pa] of stress histories ``sigma`` (n_angles, ...) over one cycle (axis 0)."""
    hi, lo = np.nanmax(sigma, axis=0), np.nanmin(sigma, axis=0)
    return 0.5 * (hi + lo), 0.5 * (hi - lo)


def safety_factor(sigma_m: np.ndarray | float, sigma_a: np.ndarray | float, material: Material,
                  criterion: str = "goodman") -> np.ndarray:
    """The fatigue safety factor n of mean and alternating stresses [Pa] (any shape); ``criterion`` one of
    :data:`CRITERIA`.  A point with no alternating stress and no tensile mean is infinitely safe (inf)."""
    if criterion not in CRITERIA:
        raise ValueError(f"criterion: {criterion!r} is not a fatigue criterion; allowed: {', '.join(CRITERIA)}")
    if criterion == "asme-elliptic" and material.yield_strength is None:
        raise ValueError("Material.yield_strength: the ASME-elliptic criterion needs the yield strength S_y [Pa]; "
                         "give it, or use the goodman or gerber criterion")
    sm, sa = np.asarray(sigma_m, dtype=float), np.asarray(sigma_a, dtype=float)
    Su, Se = material.ultimate_strength, material.endurance_limit
    tensile = sm > 0.0
    smt = np.where(tensile, sm, 1.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        compressive = Se / sa
        if criterion == "goodman":
            n = 1.0 / (sa / Se + smt / Su)
        elif criterion == "gerber":
            ratio = 2.0 * smt * Se / (Su * sa)
            # -1 + sqrt(1 + x^2) = x^2 / (1 + sqrt(1 + x^2)): no cancellation for a small mean
            n = np.where(sa > 0.0, 0.5 * (Su / smt) ** 2 * (sa / Se) * ratio**2 / (1.0 + np.sqrt(1.0 + ratio**2)),
                         Su / smt)
        else:
            n = 1.0 / np.hypot(sa / Se, smt / material.yield_strength)
    return np.where(tensile, n, compressive)


def fibre_histories(link: object) -> np.ndarray:
    """(n_angles, 2 E 2) [Pa]: the normal stress at both extreme fibres at every element end of a
    :class:`ked_quasi.stress.LinkStress` (N/A +- M c/I with the moment's sign: one face, then the other)."""
    n = link.axial.shape[0]
    axial = link.axial[..., None] / link.area
    bend = link.moment * (link.fibre / link.second_moment)
    return np.concatenate([(axial + bend).reshape(n, -1), (axial - bend).reshape(n, -1)], axis=1)


@dataclass(frozen=True)
class LinkFatigue:
    """The fatigue check of one link: safety factor n at its critical point and that point's mean and
    alternating stress sigma_m, sigma_a [Pa]; criterion: as :func:`safety_factor`."""

    safety_factor: float
    sigma_m: float
    sigma_a: float
    criterion: str


def link_fatigue(link: object, material: Material, criterion: str = "goodman") -> LinkFatigue:
    """The smallest safety factor over the extreme-fibre points of a :class:`ked_quasi.stress.LinkStress`
    over its (one steady) cycle."""
    sm, sa = mean_alternating(fibre_histories(link))
    n = safety_factor(sm, sa, material, criterion)
    if not np.isfinite(sm).any():
        return LinkFatigue(float("nan"), float("nan"), float("nan"), criterion)
    i = int(np.nanargmin(np.where(np.isnan(n), np.inf, n)))
    return LinkFatigue(float(n[i]), float(sm[i]), float(sa[i]), criterion)


def history_fatigue(history: object, material: Material | dict, criterion: str = "goodman") -> dict[str, LinkFatigue]:
    """Link -> :class:`LinkFatigue` of a :class:`ked_quasi.stress.StressHistory` (``material``: one for every
    link, or a dict link -> Material)."""
    out = {}
    for lk, ls in history.links.items():
        mat = material[lk] if isinstance(material, dict) else material
        out[lk] = link_fatigue(ls, mat, criterion)
    return out


__all__ = ["CRITERIA", "STRENGTH_RULES", "LinkFatigue", "Material", "fibre_histories", "history_fatigue",
           "link_fatigue", "mean_alternating", "safety_factor"]
