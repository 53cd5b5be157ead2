"""Work-precision study, pure analysis: errors against a fine reference, Pareto front, default choice.

A *point* is one dynamic discretization (element type, elements per link, steps per cycle, spectral
radius) of one scene *family* (a scene with its Exudyn settings left out), or the quasi-static solver
on a family. Error of a steady cycle against the reference cycle on the scene's crank-angle grid
(:func:`compare.metrics.cycle_error`): max over the grid of |d - d_ref| for dx, dy together relative to the reference
peak of |dx|, |dy|, and the same for the rotation relative to its peak; the larger of the two [1].
Wall time [s]: the dynamic solver's whole run (build, ramp, cycles, post-processing).
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ked_linear import UNRESOLVED_ESTIMATE
from ked_quasi.massmodel import MASS_MODELS
from ked_research.study_io import rows

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


def _json(x: Any) -> Any:
    return json.loads(x) if isinstance(x, str) else x


def wp_points(tables: dict[str, dict[str, np.ndarray]]) -> list[WPPoint]:
    """The stored ``dynamic`` table as :class:`WPPoint` records."""
    out = []
    for r in rows(tables.get("dynamic", {})):
        disc = disc_of({k.removeprefix("disc_"): v for k, v in r.items() if k.startswith("disc_")})
        out.append(WPPoint(r["family"], disc, bool(r["reference"]), bool(r["ok"]), float(r["wall_s"]),
                           int(r["repeats"]), float(r["error"]), int(r["cycles"]), int(r["newton_iterations"]),
                           str(r["message"]), float(r.get("wall_spread", 0.0))))
    return out


def disc_of(d: Any) -> Discretization:
    """The discretization of a stored settings dict (or its JSON)."""
    d = _json(d)
    return Discretization(d["element"], int(d["elements_per_link"]), int(d["steps_per_cycle"]),
                          float(d["spectral_radius"]))


def families(points: Sequence[WPPoint]) -> list[str]:
    """The scene families, in mass-model order."""
    return sorted({p.family for p in points if not p.reference},
                  key=lambda f: (MASS_MODELS.index(f.split()[0]) if f.split()[0] in MASS_MODELS else 9, f))


def front(points: Sequence[WPPoint], family: str) -> list[WPPoint]:
    """Pareto front of one family's dynamic runs (cheapest first)."""
    pts = [p for p in points if p.family == family and not p.reference and p.ok and p.error > 0]
    mask = pareto_mask([p.wall_s for p in pts], [p.error for p in pts])
    return sorted((p for p, m in zip(pts, mask) if m), key=lambda p: p.wall_s)


@dataclass(frozen=True)
class DefaultFindings:
    """The default discretization over the ``families`` scenes: (total wall [s], worst error [1]) or None
    when it did not run on all; the scenes on whose Pareto front it lies; the cheapest choice within the
    first budget; per spectral radius the most steps per cycle at which a run with the default's element
    and elements per link still failed (Newton)."""

    default: Discretization
    cost: tuple[float, float] | None
    on_front: tuple[str, ...]
    families: int
    choice: Choice
    failed_steps: dict[float, int]


@dataclass(frozen=True)
class LinearFindings:
    """The linear KED model (errors [1] against the dynamic reference, times [s]): ``scenes`` solved,
    ``pairs`` with a quasi-static point of the same scene and on how many (``better``) its error is lower,
    the median ratio of the two errors; the damping ratios [1] and timing repeats used; its median, min and
    max solve time, the quasi-static median solve time (nan: none) and the dynamic reference's median run
    time; the median timing spread [1]; (mass model, r) of the scenes without a stable steady state and
    (mass model, r, estimate [1]) of those whose own error estimate exceeds UNRESOLVED_ESTIMATE; per scene
    with dynamic runs (family, wall [s] of the cheapest run at least as accurate or nan, linear wall [s]);
    the speed ratios (2 digits) and per mass model the cells (linear error, quasi-static error or None,
    linear time, dynamic reference time) per ratio (None: no scene)."""

    scenes: int
    pairs: int
    better: int
    median_ratio: float
    damping_ratios: tuple[float, ...]
    repeats: tuple[int, ...]
    wall_s: tuple[float, float, float]
    quasi_wall_s: float
    dynamic_wall_s: float
    spread: float
    unstable: tuple[tuple[str, float], ...]
    unresolved: tuple[tuple[str, float, float], ...]
    matched: tuple[tuple[str, float, float], ...]
    ratios: tuple[str, ...]
    cells: dict[str, list[tuple[float, float | None, float, float] | None]]


@dataclass(frozen=True)
class LumpsFindings:
    """Quasi-static lumps convergence against ``reference`` lumps per link: the lumps ``ns`` run, per
    (model, placement) the error [1] per n and the observed order [1], the distributed midpoint solve times
    [s] at the first n, n = 5 and the last n (None: not run), and the fewest lumps meeting 1 % and 0.1 %
    (None: more than the last n)."""

    reference: int
    ns: tuple[int, ...]
    errors: dict[tuple[str, str], dict[int, float]]
    orders: dict[tuple[str, str], float]
    times_s: tuple[float, float, float] | None
    needed: dict[tuple[str, str], dict[float, int | None]]


@dataclass(frozen=True)
class WPFindings:
    """Everything the work-precision section states, from the stored tables and attributes: the run's
    attributes (``attrs``, with ``defaults`` and ``reference`` settings decoded), the tables added later,
    the scene families, the errors [1] of the non-reference runs at the reference's own discretization,
    the runs timed three times and their median spread [1], the reference checks, the Pareto fronts, the
    choices per budget in TARGETS, the default, the failed runs, the quasi-static rows, the linear model
    and the lumps convergence (None when not stored)."""

    attrs: dict
    updated: tuple[str, ...]
    families: tuple[str, ...]
    transient: tuple[tuple[float, str], ...]
    timed: int
    spread: float
    refcheck: tuple[dict, ...]
    fronts: dict[str, list[WPPoint]]
    choices: tuple[Choice, ...]
    default: DefaultFindings
    failed: tuple[WPPoint, ...]
    quasi: tuple[dict, ...]
    linear: LinearFindings | None
    lumps: LumpsFindings | None


def analyse(tables: dict, attrs: dict) -> WPFindings:
    """The findings of the stored ``/study`` tables and attributes."""
    points, dflt = wp_points(tables), disc_of(attrs["defaults"])
    fams = families(points)
    ref_disc = disc_of(attrs["reference"])
    spreads = [p.wall_spread for p in points if p.repeats > 1]
    fronts = {fam: front(points, fam) for fam in fams}
    choices = tuple(choose(points, t, len(fams)) for t in TARGETS)
    same = {k[2]: v for k, v in coarsest_failures(points).items()
            if k[0] == dflt.element and k[1] == dflt.elements_per_link}
    default = DefaultFindings(dflt, summary(points, dflt, len(fams)),
                              tuple(f for f in fams if any(p.disc == dflt for p in fronts[f])), len(fams), choices[0],
                              dict(sorted(same.items())))
    quasi = rows(tables.get("quasi_static", {}))
    linear = rows(tables.get("linear", {}))
    return WPFindings(
        attrs=dict(attrs, defaults=_json(attrs["defaults"]), reference=_json(attrs["reference"])),
        updated=tuple(json.loads(attrs.get("updated_tables", "[]"))), families=tuple(fams),
        transient=tuple((p.error, p.family) for p in points if p.disc == ref_disc and not p.reference and p.ok),
        timed=len(spreads), spread=float(np.median(spreads)) if spreads else math.nan,
        refcheck=tuple(rows(tables.get("refcheck", {}))), fronts=fronts, choices=choices, default=default,
        failed=tuple(p for p in points if not p.ok), quasi=tuple(quasi),
        linear=analyse_linear(linear, quasi, points) if linear else None, lumps=analyse_lumps(tables))


def _family_ratio(family: str) -> float:
    """The speed ratio of a family label (``tip r=0.3``), nan if it has none."""
    m = re.search(r"r=([0-9.eE+-]+)", family)
    return float(m.group(1)) if m else math.nan


def analyse_linear(linear: list[dict], quasi: list[dict], points: Sequence[WPPoint]) -> LinearFindings:
    """Where the linear KED model sits against the quasi-static solver and the dynamic runs."""
    qs = {(q["mass_model"], f"{q['speed_ratio']:.3g}"): q for q in quasi}
    pairs = [(r, qs.get((r["mass_model"], f"{r['speed_ratio']:.3g}"))) for r in linear]
    paired = [(r, q) for r, q in pairs if q is not None]
    walls = [r["wall_s"] for r in linear]
    matched = []
    for r in linear:
        fam = [p for p in points if not p.reference and p.ok and p.family.split()[0] == r["mass_model"]
               and math.isclose(_family_ratio(p.family), r["speed_ratio"], rel_tol=1e-6)]
        if fam and math.isfinite(r["error"]):
            good = [p.wall_s for p in fam if p.error <= r["error"]]
            matched.append((fam[0].family, min(good) if good else math.nan, r["wall_s"]))
    ratios = tuple(sorted({f"{r['speed_ratio']:.2g}" for r in linear}, key=float))
    cells = {}
    for model in [m for m in MASS_MODELS if any(r["mass_model"] == m for r in linear)]:
        by_r = {f"{r['speed_ratio']:.2g}": (r["error"], q["error"] if q else None, r["wall_s"], r["dynamic_wall_s"])
                for r, q in pairs if r["mass_model"] == model}
        cells[model] = [by_r.get(k) for k in ratios]
    return LinearFindings(
        scenes=len(linear), pairs=len(paired), better=sum(1 for r, q in paired if r["error"] < q["error"]),
        median_ratio=float(np.median([r["error"] / q["error"] for r, q in paired if q["error"] > 0]))
        if paired else math.nan,
        damping_ratios=tuple(sorted({r["damping_ratio"] for r in linear})),
        repeats=tuple(sorted({int(r["repeats"]) for r in linear})),
        wall_s=(float(np.median(walls)), min(walls), max(walls)),
        quasi_wall_s=float(np.median([q["wall_s"] for q in quasi])) if quasi else math.nan,
        dynamic_wall_s=float(np.median([r["dynamic_wall_s"] for r in linear])),
        spread=float(np.median([r.get("wall_spread", math.nan) for r in linear])),
        unstable=tuple((r["mass_model"], r["speed_ratio"]) for r in linear if not r["stable"]),
        unresolved=tuple((r["mass_model"], r["speed_ratio"], r["error_estimate"]) for r in linear
                         if r["stable"] and not r["error_estimate"] <= UNRESOLVED_ESTIMATE),
        matched=tuple(matched), ratios=ratios, cells=cells)


def analyse_lumps(tables: dict) -> LumpsFindings | None:
    """The quasi-static lumps convergence (None when the table is not stored)."""
    lp = [dict(r, lumps=int(r["lumps"]), reference_lumps=int(r["reference_lumps"]))
          for r in rows(tables.get("lumps", {}))]
    if not lp:
        return None
    ns = tuple(sorted({r["lumps"] for r in lp}))
    errors: dict[tuple[str, str], dict[int, float]] = {}
    for r in lp:
        errors.setdefault((r["model"], r["placement"]), {})[r["lumps"]] = r["error"]
    errors = dict(sorted(errors.items()))
    wall = {r["lumps"]: r["wall_s"] for r in lp if r["model"] == "distributed" and r["placement"] == "midpoint"}
    return LumpsFindings(
        reference=lp[0]["reference_lumps"], ns=ns, errors=errors,
        orders={k: observed_order([n for n in ns if n in d], [d[n] for n in ns if n in d]) for k, d in errors.items()},
        times_s=(wall[ns[0]], wall.get(5, math.nan), wall[ns[-1]]) if wall else None,
        needed={k: {t: next((n for n in ns if n in d and d[n] <= t), None) for t in (0.01, 0.001)}
                for k, d in errors.items()})
