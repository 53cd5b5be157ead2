"""Work-precision study, pure analysis: errors against a fine reference, Pareto front, default choice.

A *point* is one dynamic discretization (element type, elements per link, steps per cycle, spectral
radius) of one scene *family* (a scene with its Exudyn settings left out), or the quasi-static solver
on a family. Error of a steady cycle against the reference cycle on the scene's crank-angle grid
(:func:`compare.metrics.cycle_error`): max over the grid of |d - d_ref| for dx, dy together relative to the reference
peak of |dx|, |dy|, and the same for the rotation relative to its peak; the larger of the two [1].
Wall time [s]: the dynamic solver's whole run (build, ramp, cycles, post-processing).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

#: settings (besides those of [dynamic]) that make a scene the fine reference of its family
REFERENCE = {"element": "ancf", "elements_per_link": 8, "steps_per_cycle": 2880, "spectral_radius": 0.9,
             "steady_tol": 1e-5}
#: error budgets [1] for which the cheapest discretization is reported
TARGETS = (0.01, 0.002)
#: wall times within this fraction of the cheapest count as a tie (timing noise on shared cores)
TIE = 0.15


@dataclass(frozen=True)
class Discretization:
    """Element type ("ancf"/"gebeam"), elements per link, steps per crank cycle, spectral radius."""

    element: str
    elements_per_link: int
    steps_per_cycle: int
    spectral_radius: float

    def label(self) -> str:
        return (f"{self.element} {self.elements_per_link} el/link, {self.steps_per_cycle} steps/cycle, "
                f"rho {self.spectral_radius:g}")


@dataclass(frozen=True)
class WPPoint:
    """One run: ``family`` label, its discretization, ``wall_s`` [s] (median of ``repeats`` timings,
    ``wall_spread`` = (max - min) / median of them [1]), ``error`` [1] against the family's reference
    (nan if the run failed), run statistics."""

    family: str
    disc: Discretization
    reference: bool
    ok: bool
    wall_s: float
    repeats: int
    error: float
    cycles: int
    newton_iterations: int
    message: str
    wall_spread: float = 0.0


def is_reference(settings: dict) -> bool:
    """True if resolved DynamicSettings fields ``settings`` are the reference discretization."""
    return all(settings.get(k) == v for k, v in REFERENCE.items())


def pareto_mask(cost: Sequence[float], error: Sequence[float]) -> np.ndarray:
    """Points no other point beats in both cost and error (ties kept); nan/inf points excluded."""
    c, e = np.asarray(cost, dtype=float), np.asarray(error, dtype=float)
    good = np.isfinite(c) & np.isfinite(e)
    mask = np.zeros(c.size, dtype=bool)
    for i in np.flatnonzero(good):
        dominated = good & (c <= c[i]) & (e <= e[i]) & ((c < c[i]) | (e < e[i]))
        mask[i] = not dominated.any()
    return mask


@dataclass(frozen=True)
class Choice:
    """Cheapest discretization meeting ``target`` [1] on every family: ``total_wall_s`` [s] summed over
    the families, ``worst_error`` [1] the largest error among them (None if nothing qualifies);
    ``tied``: other qualifying discretizations within TIE of its time (indistinguishable by timing)."""

    target: float
    disc: Discretization | None
    total_wall_s: float
    worst_error: float
    tied: tuple[Discretization, ...] = ()


def by_discretization(points: Sequence[WPPoint]) -> dict[Discretization, list[WPPoint]]:
    """Non-reference points grouped by discretization."""
    out: dict[Discretization, list[WPPoint]] = {}
    for p in points:
        if not p.reference:
            out.setdefault(p.disc, []).append(p)
    return out


def choose(points: Sequence[WPPoint], target: float, families: int, tie: float = TIE) -> Choice:
    """Among the discretizations that ran on all ``families`` and stayed within ``target`` on each, the
    one with the smallest total wall time; those within ``tie`` (fraction) of it are listed as tied."""
    candidates = []
    for disc, pts in by_discretization(points).items():
        if len(pts) < families or not all(p.ok for p in pts):
            continue
        worst = max(p.error for p in pts)
        if worst <= target:
            candidates.append(Choice(target, disc, sum(p.wall_s for p in pts), worst))
    if not candidates:
        return Choice(target, None, math.inf, math.nan)
    best = min(candidates, key=lambda c: c.total_wall_s)
    tied = sorted((c for c in candidates if c is not best and c.total_wall_s <= (1.0 + tie) * best.total_wall_s),
                  key=lambda c: c.total_wall_s)
    return Choice(target, best.disc, best.total_wall_s, best.worst_error, tuple(c.disc for c in tied))


def coarsest_failures(points: Sequence[WPPoint]) -> dict[tuple[str, int, float], int]:
    """(element, elements per link, spectral radius) -> the most steps per cycle at which a run of that
    kind failed on any family (where failures stop as the step shrinks)."""
    out: dict[tuple[str, int, float], int] = {}
    for p in points:
        if not p.ok:
            k = (p.disc.element, p.disc.elements_per_link, p.disc.spectral_radius)
            out[k] = max(out.get(k, 0), p.disc.steps_per_cycle)
    return out


def summary(points: Sequence[WPPoint], disc: Discretization, families: int) -> tuple[float, float] | None:
    """(total wall [s], worst error [1]) of ``disc`` over the families, None if it did not run on all."""
    pts = by_discretization(points).get(disc, [])
    if not pts or len(pts) < families or not all(p.ok for p in pts):
        return None
    return sum(p.wall_s for p in pts), max(p.error for p in pts)


@dataclass(frozen=True)
class LumpPoint:
    """Quasi-static lumps convergence: ``model`` (extender/distributed), ``placement``, ``lumps`` per
    link, ``error`` [1] against ``reference_lumps`` (cycle_error), ``wall_s`` [s] median solve time."""

    model: str
    placement: str
    lumps: int
    reference_lumps: int
    error: float
    wall_s: float


def observed_order(lumps: Sequence[int], error: Sequence[float]) -> float:
    """Slope of log(error) over log(lumps) from a least-squares line through the finite, nonzero
    errors of the finer half of the points (convergence order, positive = converging)."""
    n, e = np.asarray(lumps, dtype=float), np.asarray(error, dtype=float)
    good = np.isfinite(e) & (e > 0)
    n, e = n[good], e[good]
    if n.size < 2:
        return math.nan
    half = n >= np.median(n)
    if half.sum() < 2:
        half[:] = True
    return float(-np.polyfit(np.log(n[half]), np.log(e[half]), 1)[0])
