"""Validity study, pure: group the study's points into families (linkage, mechanism, mass model,
damping, direction) and summarize each: errors over the speed-ratio grid, validity limits with their
grid and discretization uncertainty, harmonic content of the loads and the one-mode prediction.

A family's grid slot (one requested speed ratio) may hold two scenes: the pinned base discretization
and, when that one failed in the Newton iteration, a *retry* with more steps per cycle; the base
scene is used if it solved, else the retry.  *Refined* scenes (doubled elements and steps) at the
ratios bracketing a crossing measure the discretization uncertainty.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field

import numpy as np

from compare.limits import (
    ERROR_KINDS,
    TOLERANCES,
    Errors,
    Limit,
    crossing,
    errors,
    harmonic_spectrum,
    one_mode_limit,
    peak_of,
    validity_limit,
)
from ked_quasi.harmonics import significant_harmonic
from ked_quasi.massmodel import MASS_MODELS
from ked_research.validity.data import Point

HARMONIC_FRACTIONS = (0.01, 0.05)

Family = tuple[str, str, str, float, str]


@dataclass(frozen=True, eq=False)
class Slot:
    """The scene used at one requested speed ratio of a family (``retried``: the base scene failed
    and this is the retry with more steps per cycle; ``base`` is then the failed base scene)."""

    point: Point
    errors: Errors | None
    retried: bool = False
    base: Point | None = None

    @property
    def ok(self) -> bool:
        return self.point.ok and self.errors is not None

    @property
    def r(self) -> float:
        return self.point.r


@dataclass(frozen=True, eq=False)
class FamilySummary:
    """Everything the report says about one family; limits keyed by (error kind, tolerance)."""

    family: Family
    slots: tuple[Slot, ...]
    omega1_min: float
    f1_range_hz: tuple[float, float]
    limits: dict[tuple[str, float], Limit]
    refined_cross: dict[tuple[str, float], float]
    refined_note: dict[tuple[str, float], str]
    k_significant: dict[float, int]
    spectrum: np.ndarray
    one_mode: dict[tuple[str, float], float]
    rpm_points: tuple[Slot, ...] = field(default=())

    # the parts of ``family``: linkage, mechanism, mass model, damping ratio [1], crank direction
    linkage = property(lambda self: self.family[0])
    mechanism = property(lambda self: self.family[1])
    mass_model = property(lambda self: self.family[2])
    damping = property(lambda self: self.family[3])
    direction = property(lambda self: self.family[4])

    def discretization_shift(self, kind: str, tol: float) -> float:
        """|r_cross(refined) - r_cross(base)| [1] (nan if not measured)."""
        return abs(self.refined_cross.get((kind, tol), math.nan) - self.limits[(kind, tol)].r_cross)


def _slot(base: Point | None, retry: Point | None) -> Slot:
    if base is not None and base.ok:
        return Slot(base, errors(base.qs, base.dyn))
    if retry is not None:
        return Slot(retry, errors(retry.qs, retry.dyn) if retry.ok else None, retried=True, base=base)
    assert base is not None
    return Slot(base, None)


def _slots(points: Iterable[Point], kind: str) -> tuple[Slot, ...]:
    """One slot per requested speed (ratio or rpm): the scene with the fewest steps per cycle is the
    base, one with more steps (same speed) its retry."""
    by_speed: dict[float, list[Point]] = {}
    for p in points:
        if p.speed_kind == kind:
            by_speed.setdefault(p.spec.speed.value, []).append(p)
    out = []
    for pts in by_speed.values():
        pts = sorted(pts, key=lambda p: p.steps_per_cycle)
        out.append(_slot(pts[0], pts[-1] if len(pts) > 1 else None))
    return tuple(sorted(out, key=lambda s: s.r))


def _refined(slots: Sequence[Slot], refined: Sequence[Point], lim: Limit, kind: str) -> tuple[float, str]:
    if lim.status != "crossed":
        return math.nan, ""
    by_r = {round(p.spec.speed.value, 9): p for p in refined}
    lo = next(s for s in slots if s.r == lim.r_pass)
    hi = next(s for s in slots if s.r == lim.r_fail)
    p_lo, p_hi = by_r.get(round(lo.point.spec.speed.value, 9)), by_r.get(round(hi.point.spec.speed.value, 9))
    if p_lo is None or p_hi is None:
        return math.nan, "not run"
    if not (p_lo.ok and p_hi.ok):
        bad = p_lo if not p_lo.ok else p_hi
        return math.nan, f"refined scene failed at r={bad.r:.3g} ({bad.error_type})"
    e_lo, e_hi = errors(p_lo.qs, p_lo.dyn).of(kind), errors(p_hi.qs, p_hi.dyn).of(kind)
    c = crossing(p_lo.r, e_lo, p_hi.r, e_hi, lim.tolerance)
    if not math.isfinite(c):
        return math.nan, f"refined errors {e_lo:.3f}, {e_hi:.3f} do not bracket {lim.tolerance:g}"
    return c, ""


def summarize_family(family: Family, points: Sequence[Point],
                     loads_of: Callable[[Point], tuple[np.ndarray, np.ndarray]]) -> FamilySummary:
    """Summary of one family from its points (base, retry and refined scenes); ``loads_of`` returns
    the quasi-static (loads (n, N, 2) [N], deflection (n, 2) [m]) of a point at any speed."""
    base = [p for p in points if not p.refined]
    refined = [p for p in points if p.refined and p.speed_kind == "ratio"]
    slots = _slots(base, "ratio")
    limits, ref_c, ref_note, one = {}, {}, {}, {}
    r = [s.r for s in slots]
    ok = [s.ok for s in slots]
    any_point = base[0] if base else points[0]
    loads, qs_shape = loads_of(any_point)
    for kind in ERROR_KINDS:
        errs = [s.errors.of(kind) if s.errors is not None else math.nan for s in slots]
        for tol in TOLERANCES:
            lim = validity_limit(r, errs, ok, tol)
            limits[(kind, tol)] = lim
            ref_c[(kind, tol)], ref_note[(kind, tol)] = _refined(slots, refined, lim, kind)
            one[(kind, tol)] = one_mode_limit(qs_shape, tol, family[3], kind)
    f1 = [p.f1_range_hz for p in base if math.isfinite(p.f1_range_hz[0])]
    w1 = [p.omega1_min for p in base if math.isfinite(p.omega1_min)]
    return FamilySummary(
        family=family, slots=slots, omega1_min=w1[0] if w1 else math.nan,
        f1_range_hz=f1[0] if f1 else (math.nan, math.nan), limits=limits, refined_cross=ref_c,
        refined_note=ref_note,
        k_significant={fr: significant_harmonic(loads, fr) for fr in HARMONIC_FRACTIONS},
        spectrum=harmonic_spectrum(loads), one_mode=one, rpm_points=_slots(base, "rpm"),
    )


def summarize(points: Sequence[Point],
              loads_of: Callable[[Point], tuple[np.ndarray, np.ndarray]]) -> list[FamilySummary]:
    """Summaries of every family, in a stable order (linkage order of first appearance, then
    mechanism, mass model, damping, direction)."""
    fams: dict[Family, list[Point]] = {}
    for p in points:
        fams.setdefault(p.family, []).append(p)
    link_order = list(dict.fromkeys(p.linkage for p in points))

    def order(f: Family) -> tuple:
        return link_order.index(f[0]), f[1] != "source", MASS_MODELS.index(f[2]), f[3], f[4] != "ccw"

    return [summarize_family(f, fams[f], loads_of) for f in sorted(fams, key=order)
            if any(not p.refined for p in fams[f])]


@dataclass(frozen=True, eq=False)
class LimitRange:
    """One (error kind, tolerance) over the families whose limit was crossed on the grid: the families with
    the lowest and the highest first crossing, how many crossed, the largest grid step [1] to the first
    failing ratio."""

    low: FamilySummary
    high: FamilySummary
    families: int
    step: float


@dataclass(frozen=True, eq=False)
class Answer:
    """The validity answer over the reference families (speed ratios r [1]): per (kind, tolerance) the
    range of the crossed limits (absent: none crossed); whether all four crossed somewhere (``complete``);
    of the 10 % history limit the spread [1] between the mass models' means over the linkages and the
    largest spread [1] between the linkages of one mass model, and its (min, max) per mass model; the
    discretization shifts [1] of the crossings (refined minus base, finite ones)."""

    ranges: dict[tuple[str, float], LimitRange]
    complete: bool
    between_mass_models: float
    within_mass_model: float
    history10: dict[str, tuple[float, float]]
    shifts: tuple[float, ...]


def answer(ref: Sequence[FamilySummary]) -> Answer:
    """The findings behind the study's answer (``ref``: the reference families)."""
    ranges = {}
    for key in [(k, t) for k in ("peak", "history") for t in TOLERANCES]:
        fams = [fs for fs in ref if fs.limits[key].status == "crossed"]
        if fams:
            ranges[key] = LimitRange(min(fams, key=lambda f: f.limits[key].r_limit),
                                     max(fams, key=lambda f: f.limits[key].r_limit), len(fams),
                                     max(f.limits[key].step for f in fams))
    by_mm: dict[str, list[float]] = {}
    for fs in ref:
        if fs.limits[("history", 0.10)].status == "crossed":
            by_mm.setdefault(fs.mass_model, []).append(fs.limits[("history", 0.10)].r_limit)
    means = [float(np.mean(v)) for v in by_mm.values()]
    shifts = [fs.discretization_shift(k, t) for fs in ref for k in ("peak", "history") for t in TOLERANCES]
    return Answer(ranges=ranges, complete=len(ranges) == 2 * len(TOLERANCES),
                  between_mass_models=max(means) - min(means) if means else math.nan,
                  within_mass_model=max((max(v) - min(v) for v in by_mm.values()), default=math.nan),
                  history10={m: (min(v), max(v)) for m, v in by_mm.items()},
                  shifts=tuple(x for x in shifts if math.isfinite(x)))


THESIS_RPM = (300.0, 400.0)
"""The thesis's two crank speeds [rpm] whose deflections it compares."""


@dataclass(frozen=True, eq=False)
class AtRpm:
    """One family's scene at a crank speed [rpm]: speed ratio r [1], quasi-static and dynamic peaks |d| of P
    [m] (nan: no scene, or the dynamic model failed), history error [1] (nan: no dynamic solution) and the
    exception type of a failed dynamic run (None if it solved or there is no scene)."""

    rpm: float
    r: float
    qs_peak: float
    dyn_peak: float
    error: float
    failure: str | None


@dataclass(frozen=True, eq=False)
class Claims:
    """The thesis's claims checked with dynamics: per thesis family (2 % damping, ccw, with rpm scenes)
    its scenes at 300 and 400 rpm; per cognate family with a source twin, (source, cognate) at each rpm."""

    doubling: tuple[tuple[FamilySummary, AtRpm, AtRpm], ...]
    cognate: tuple[tuple[FamilySummary, AtRpm, AtRpm], ...]


def at_rpm(fs: FamilySummary, rpm: float) -> AtRpm:
    """The family's scene at ``rpm`` (all nan when it has none)."""
    s = next((s for s in fs.rpm_points if s.point.spec.speed.value == rpm), None)
    if s is None:
        return AtRpm(rpm, math.nan, math.nan, math.nan, math.nan, None)
    return AtRpm(rpm, s.r, peak_of(s.point.qs), peak_of(s.point.dyn) if s.ok else math.nan,
                 s.errors.history if s.ok else math.nan, None if s.ok else s.point.error_type)


def claims(summaries: Sequence[FamilySummary]) -> Claims:
    """The findings behind the two thesis claims (doubling for +100 rpm; the cognate's different deflection)."""
    fams = [fs for fs in summaries if fs.rpm_points and fs.damping == 0.02 and fs.direction == "ccw"]
    src = {(fs.linkage, fs.mass_model): fs for fs in fams if fs.mechanism == "source"}
    return Claims(
        doubling=tuple((fs, *(at_rpm(fs, x) for x in THESIS_RPM)) for fs in fams),
        cognate=tuple((fs, at_rpm(src[(fs.linkage, fs.mass_model)], rpm), at_rpm(fs, rpm)) for fs in fams
                      if fs.mechanism == "cognate" and (fs.linkage, fs.mass_model) in src for rpm in THESIS_RPM))
