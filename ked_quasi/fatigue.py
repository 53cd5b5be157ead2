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

**Finite life** (metals without an endurance limit, e.g. aluminium alloys, or a life estimate of any): an S-N
curve (:class:`SNCurve`: fully reversed stress amplitude against cycles to failure, straight between its points
in log-log coordinates, Basquin's law piecewise) gives the fatigue strength at the design life, which stands in
for S_e (``Material(design_cycles=...)``), and the life of the link: the fully reversed amplitude equivalent to
(sigma_m, sigma_a) on the criterion's line through (0, S_f) (Goodman sigma_a / (1 - sigma_m/S_u), Gerber
sigma_a / (1 - (sigma_m/S_u)^2), ASME-elliptic sigma_a / sqrt(1 - (sigma_m/S_y)^2); sigma_a for a compressive
mean; Shigley, section 6-14) read on the curve.  A life beyond the curve's last point is reported as infinite
(the curve says nothing past it), one above its first point's amplitude as that first point's cycles or fewer
(:attr:`LinkFatigue.life_beyond`).
"""

from __future__ import annotations

import math
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
CYCLES = Rule("design_cycles", "cycles", 1.0, 1e12, "a fatigue life from one cycle to 1e12 (a crank turning at "
              "3000 rpm for 600 years)")
AMPLITUDE = Rule("sn_curve stress amplitude", "Pa", 1e5, 1e10, "a fully reversed stress amplitude the material "
                 "survives for the point's cycles", mixup_low=_MIXUP)


@dataclass(frozen=True)
class SNCurve:
    """A stress-life curve: ``points`` ((cycles N [1], fully reversed stress amplitude S [Pa]), ...), at least
    two, N increasing and S decreasing; straight between points in log-log coordinates."""

    points: tuple[tuple[float, float], ...]

    def __post_init__(self) -> None:
        if not all(isinstance(p, (tuple, list)) and len(p) == 2 for p in self.points):
            raise ValueError(f"sn_curve: each point must be a pair [cycles, amplitude in Pa], got {self.points!r}")
        pts = tuple((float(CYCLES.check(n, "sn_curve cycles")), float(AMPLITUDE.check(a, "sn_curve amplitude")))
                    for n, a in self.points)
        if len(pts) < 2:
            raise ValueError("sn_curve: needs at least two points [cycles, amplitude in Pa]; allowed: e.g. "
                             "[[1e3, 4.0e8], [5e8, 1.3e8]]")
        if any(b[0] <= a[0] or b[1] >= a[1] for a, b in zip(pts, pts[1:])):
            raise ValueError("sn_curve: the cycles must increase and the amplitudes decrease from point to point "
                             f"(got {[list(p) for p in pts]}); allowed: a falling S-N curve")
        object.__setattr__(self, "points", pts)

    def _logs(self) -> tuple[np.ndarray, np.ndarray]:
        n, a = np.array(self.points).T
        return np.log10(n), np.log10(a)

    def strength_at(self, cycles: float, name: str = "cycles") -> float:
        """The fatigue strength S_f [Pa] at ``cycles`` (inside the curve's range; ``name``: the parameter a
        refusal names)."""
        ln, la = self._logs()
        c = math.log10(cycles)
        if not ln[0] <= c <= ln[-1]:
            raise ValueError(f"{name}: {cycles:g} is outside the S-N curve's cycles ({10 ** ln[0]:g} to "
                             f"{10 ** ln[-1]:g}); allowed: a design life the curve covers")
        return float(10 ** np.interp(c, ln, la))

    def life_at(self, amplitude: float) -> float:
        """Cycles to failure at a fully reversed ``amplitude`` [Pa]: inf below the last point's amplitude, the
        first point's cycles above the first's (the curve covers neither), NaN for NaN."""
        if not math.isfinite(amplitude):
            return math.nan if math.isnan(amplitude) else 0.0
        ln, la = self._logs()
        if amplitude <= 0.0 or math.log10(amplitude) < la[-1]:
            return math.inf
        return float(10 ** np.interp(math.log10(amplitude), la[::-1], ln[::-1]))


@dataclass(frozen=True)
class Material:
    """Fatigue strengths of a link's material [Pa] and how the check uses them: ultimate_strength S_u
    (tensile), endurance_limit S_e (the corrected, fully reversed endurance limit; without one, the S-N curve's
    strength at ``design_cycles``), yield_strength S_y (optional; the ASME-elliptic criterion needs it),
    sn_curve (optional :class:`SNCurve`: the life estimate, and S_e for a metal without an endurance limit),
    design_cycles (the design life [cycles] at which S_e is read from the curve), criterion (one of
    :data:`CRITERIA`, the one the safety factor uses; default goodman).  Ranges: :data:`STRENGTH_RULES` (a
    value that reads as MPa is refused with the likely mix-up named); S_e <= S_u, S_y <= S_u."""

    ultimate_strength: float
    endurance_limit: float | None = None
    yield_strength: float | None = None
    sn_curve: SNCurve | None = None
    design_cycles: float | None = None
    criterion: str = "goodman"

    def __post_init__(self) -> None:
        if self.criterion not in CRITERIA:
            raise ValueError(f"Material.criterion: {self.criterion!r} is not a fatigue criterion; allowed: "
                             f"{', '.join(CRITERIA)}")
        if self.criterion == "asme-elliptic" and self.yield_strength is None:
            raise ValueError("Material.yield_strength: the ASME-elliptic criterion needs the yield strength S_y "
                             "[Pa] (a linkage file's [fatigue] yield_strength); give it, or use the goodman or "
                             "gerber criterion")
        self._endurance_from_curve()
        for name, rule in STRENGTH_RULES.items():
            value = getattr(self, name)
            if value is None and name == "yield_strength":
                continue
            object.__setattr__(self, name, float(rule.check(value, f"Material.{name}")))
        if self.sn_curve is not None and self.sn_curve.points[0][1] > self.ultimate_strength:
            raise ValueError(f"Material.sn_curve: its first amplitude {self.sn_curve.points[0][1]:g} Pa exceeds the "
                             f"ultimate strength {self.ultimate_strength:g} Pa; allowed: amplitudes at most S_u")
        if self.endurance_limit > self.ultimate_strength:
            raise ValueError(f"Material.endurance_limit: {self.endurance_limit:g} Pa exceeds the ultimate strength "
                             f"{self.ultimate_strength:g} Pa; allowed: an endurance limit at most the ultimate "
                             "strength (steels: about half of it)")
        if self.yield_strength is not None and self.yield_strength > self.ultimate_strength:
            raise ValueError(f"Material.yield_strength: {self.yield_strength:g} Pa exceeds the ultimate strength "
                             f"{self.ultimate_strength:g} Pa; allowed: a yield strength at most the ultimate strength")


    def _endurance_from_curve(self) -> None:
        """S_e from the S-N curve at the design life where it is not given; refused where neither is."""
        if self.design_cycles is not None:
            object.__setattr__(self, "design_cycles", float(CYCLES.check(self.design_cycles, "Material.design_cycles")))
            if self.sn_curve is None:
                raise ValueError("Material.design_cycles: needs an S-N curve (sn_curve) to read the fatigue "
                                 "strength at it")
            if self.endurance_limit is not None:
                raise ValueError("Material.design_cycles: give either endurance_limit or design_cycles with the "
                                 "S-N curve, not both (the curve's strength at design_cycles is the endurance limit)")
            object.__setattr__(self, "endurance_limit", self.sn_curve.strength_at(self.design_cycles,
                                                                                "Material.design_cycles"))
        elif self.endurance_limit is None:
            raise ValueError("Material.endurance_limit: required (or an S-N curve, sn_curve, with design_cycles "
                             "for a metal without an endurance limit)")


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


def equivalent_amplitude(sigma_m: np.ndarray | float, sigma_a: np.ndarray | float, material: Material,
                         criterion: str = "goodman") -> np.ndarray:
    """The fully reversed stress amplitude [Pa] as damaging as (sigma_m, sigma_a) by ``criterion`` (see the
    module docstring); inf where the mean reaches the strength the criterion's line ends at."""
    sm, sa = np.asarray(sigma_m, dtype=float), np.asarray(sigma_a, dtype=float)
    tensile = np.where(sm > 0.0, sm, 0.0)
    if criterion == "goodman":
        keep = 1.0 - tensile / material.ultimate_strength
    elif criterion == "gerber":
        keep = 1.0 - (tensile / material.ultimate_strength) ** 2
    else:
        keep = np.sqrt(np.clip(1.0 - (tensile / material.yield_strength) ** 2, 0.0, None))
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(keep > 0.0, sa / np.where(keep > 0.0, keep, 1.0), np.inf)


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
    alternating stress sigma_m, sigma_a [Pa]; criterion: as :func:`safety_factor`; with an S-N curve, the life
    [cycles] at the link's most damaged point (inf: beyond the curve's last point; NaN without a curve) and
    ``life_beyond``: whether the curve does not cover that point's amplitude (above its first point: at most
    its first point's cycles)."""

    safety_factor: float
    sigma_m: float
    sigma_a: float
    criterion: str
    life_cycles: float = math.nan
    life_beyond: bool = False


def link_fatigue(link: object, material: Material, criterion: str | None = None) -> LinkFatigue:
    """The smallest safety factor over the extreme-fibre points of a :class:`ked_quasi.stress.LinkStress`
    over its (one steady) cycle, by ``criterion`` (None: the material's)."""
    criterion = material.criterion if criterion is None else criterion
    sm, sa = mean_alternating(fibre_histories(link))
    n = safety_factor(sm, sa, material, criterion)
    if not np.isfinite(sm).any():
        return LinkFatigue(float("nan"), float("nan"), float("nan"), criterion)
    i = int(np.nanargmin(np.where(np.isnan(n), np.inf, n)))
    life, beyond = math.nan, False
    if material.sn_curve is not None:
        amp = float(np.nanmax(equivalent_amplitude(sm, sa, material, criterion)))
        life = material.sn_curve.life_at(amp)
        beyond = amp > material.sn_curve.points[0][1]
    return LinkFatigue(float(n[i]), float(sm[i]), float(sa[i]), criterion, life, beyond)


def history_fatigue(history: object, material: Material | dict, criterion: str | None = None
                    ) -> dict[str, LinkFatigue]:
    """Link -> :class:`LinkFatigue` of a :class:`ked_quasi.stress.StressHistory` (``material``: one for every
    link, or a dict link -> Material; ``criterion`` None: each material's)."""
    out = {}
    for lk, ls in history.links.items():
        mat = material[lk] if isinstance(material, dict) else material
        out[lk] = link_fatigue(ls, mat, criterion)
    return out


__all__ = ["CRITERIA", "STRENGTH_RULES", "LinkFatigue", "Material", "SNCurve", "equivalent_amplitude",
           "fibre_histories", "history_fatigue", "link_fatigue", "mean_alternating", "safety_factor"]
