"""``ked study tiers``: where the quasi-static error comes from, and which model holds how far.

For the validity campaigns (reference families: 2 % damping, ccw crank) every stored scene has the
quasi-static, linear (with and without prestress) and Exudyn solutions.  Against the Exudyn steady state
d_dyn the quasi-static error splits into

* the **dynamic part** max|d_lin - d_qs| / max|d_dyn| (the inertia of the elastic motion, which the
  linear model adds) and
* the **nonlinear part** max|d_dyn - d_lin| / max|d_dyn| (large deflections, geometric nonlinearity),

all vector history errors of the coupler point (``compare.metrics``).  The limits are the validity
study's first crossings: the last grid r below which every grid scene solved and stayed under the
tolerance, never interpolated (:class:`compare.limits.Limit`), with the grid step to the
first ratio that failed stated beside it.
The study runs nothing of its own: the validity campaigns list the linear solvers, so
``ked study validity`` (or this study without ``--report-only``) adds them to the stored scenes.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from compare import metrics, store
from compare.limits import TOLERANCES, Limit, validity_limit
from compare.markdown import table
from compare.paths import CONFIG_DIR, StudyPaths
from compare.sections import write_section
from ked_quasi.massmodel import MASS_MODELS
from ked_research.validity import study as validity
from ked_research.validity.data import linkage_json, read_points

SECTION = "tiers"
MODELS = ("quasi_static", "linear", "linear_classic")
FIGURE = "tiers_error_parts.png"
COARSE_STEP = 0.02
"""A first crossing known only to a grid step above this is called coarse in the report."""


@dataclass(frozen=True)
class TierPoint:
    """One reference scene: speed ratio r, errors against Exudyn [1] (nan when a solution is missing),
    the two parts of the quasi-static error, the peak deflection over the shortest link [1], and the
    linear model's largest |Floquet multiplier|."""

    linkage: str
    mechanism: str
    mass_model: str
    r: float
    dyn_ok: bool
    dyn_reason: str
    error: dict[str, float]
    dynamic_part: float
    nonlinear_part: float
    deflection_ratio: float
    floquet_max_abs: float


def _reason(sol: object) -> str:
    """"<failure class>: <message>" of a failed dynamic solution."""
    if sol is None:
        return "not run: -"
    return f"{sol.failure_class or 'unclassified'}: {sol.message}"


def tier_point(p: object, r: object) -> TierPoint:
    """Errors of one stored scene (``p``: the validity study's Point, ``r``: its SceneResult)."""
    nan = math.nan
    dyn = metrics.vector(r.dynamic) if r.solutions.get("dynamic") is not None and r.solutions["dynamic"].ok else None
    hist = {m: metrics.vector(r.history(m)) for m in MODELS}
    hist = {m: h for m, h in hist.items() if h is not None and r.solutions[m].ok}
    err = {m: metrics.history_error(h, dyn) if dyn is not None else nan for m, h in hist.items()}
    qs, lin = hist.get("quasi_static"), hist.get("linear")
    ok = dyn is not None and qs is not None and lin is not None
    fb = r.spec.fourbar() if r.spec.linkage.full_turn else None
    shortest = min(fb.crank, fb.coupler, fb.follower, fb.extender, fb.ground) if fb is not None else nan
    lin_sol = r.solutions.get("linear")
    return TierPoint(
        linkage=p.linkage, mechanism=p.mechanism, mass_model=p.mass_model, r=p.r, dyn_ok=dyn is not None,
        dyn_reason="" if dyn is not None else _reason(r.solutions.get("dynamic")),
        error={m: err.get(m, nan) for m in MODELS},
        dynamic_part=metrics.max_abs_error(lin, qs) / metrics.peak(dyn) if ok else nan,
        nonlinear_part=metrics.max_abs_error(dyn, lin) / metrics.peak(dyn) if ok else nan,
        deflection_ratio=metrics.peak(dyn) / shortest if dyn is not None else nan,
        floquet_max_abs=float(lin_sol.stats.get("floquet_max_abs", nan)) if lin_sol is not None else nan,
    )


def load(files: Sequence[Path]) -> list[TierPoint]:
    """The reference scenes (2 % damping, ccw, not refined) of the validity files."""
    out, labels = [], {}
    for f in files:
        if not f.exists():
            continue
        results = {r.key: r for r in store.read_scenes(f)}
        for p in read_points(f, labels=labels):
            labels.setdefault(linkage_json(p.spec), p.linkage)  # a four-bar keeps its first file's label
            if p.refined or p.damping != 0.02 or p.direction != "ccw" or p.key not in results:
                continue
            out.append(tier_point(p, results[p.key]))
    return out


def families(points: Sequence[TierPoint]) -> dict[tuple[str, str, str], list[TierPoint]]:
    """Scenes by (linkage, mechanism, mass model), in report order, each sorted by r (one r once)."""
    fams: dict[tuple[str, str, str], list[TierPoint]] = {}
    for p in sorted(points, key=lambda p: (p.linkage, p.mechanism != "source", MASS_MODELS.index(p.mass_model), p.r)):
        fams.setdefault((p.linkage, p.mechanism, p.mass_model), []).append(p)
    return fams


def limits(fam: Sequence[TierPoint], model: str, tolerance: float) -> Limit:
    """The model's validity limit over a family's speed ratios (a failed Exudyn run ends the walk)."""
    return validity_limit([p.r for p in fam], [p.error[model] for p in fam],
                          [p.dyn_ok and math.isfinite(p.error[model]) for p in fam], tolerance)


@dataclass(frozen=True)
class FamilyLimits:
    """One family's validity limits: (model, tolerance [1]) -> :class:`Limit` (speed ratios r [1])."""

    linkage: str
    mechanism: str
    mass_model: str
    limits: dict[tuple[str, float], Limit]


@dataclass(frozen=True)
class TiersFindings:
    """What the stored scenes say: each family's limits; per mass model the range (min, max) [1] over the
    linkages of the limits crossed on the grid, per (model, tolerance) (nan, nan when none crossed); the
    linkages with a grid step above COARSE_STEP; among the scenes with all three solutions, how many have
    r <= 0.1 and in how many of those the dynamic part is the larger, how many have a peak deflection above
    10 % of the shortest link and in how many of those the nonlinear part is the larger (``parts`` counts
    the scenes with both parts); the scenes where Exudyn found no periodic steady state."""

    families: tuple[FamilyLimits, ...]
    spans: dict[str, dict[tuple[str, float], tuple[float, float]]]
    coarse: tuple[str, ...]
    parts: int
    low_r: int
    low_r_dynamic_larger: int
    large_deflection: int
    large_deflection_nonlinear_larger: int
    failures: tuple[TierPoint, ...]


def _range(values: list[float]) -> tuple[float, float]:
    v = [x for x in values if math.isfinite(x)]
    return (min(v), max(v)) if v else (math.nan, math.nan)


def analyse(points: Sequence[TierPoint]) -> TiersFindings:
    """Limits, their ranges per mass model, where the error comes from, and the failures."""
    fams = [FamilyLimits(lk, mech, mm, {(m, t): limits(fam, m, t) for m in MODELS for t in TOLERANCES})
            for (lk, mech, mm), fam in families(points).items()]
    crossed: dict[str, dict[tuple[str, float], list[float]]] = {}
    for f in fams:
        for k, lim in f.limits.items():
            crossed.setdefault(f.mass_model, {}).setdefault(k, []).append(
                lim.r_limit if lim.status == "crossed" else math.nan)
    ok = [p for p in points if math.isfinite(p.dynamic_part) and math.isfinite(p.nonlinear_part)]
    below = [p for p in ok if p.r <= 0.1]
    big = [p for p in ok if p.deflection_ratio > 0.1]
    return TiersFindings(
        families=tuple(fams), spans={mm: {k: _range(v) for k, v in d.items()} for mm, d in crossed.items()},
        coarse=tuple(sorted({f.linkage for f in fams for lim in f.limits.values() if lim.step > COARSE_STEP})),
        parts=len(ok), low_r=len(below), low_r_dynamic_larger=sum(p.dynamic_part > p.nonlinear_part for p in below),
        large_deflection=len(big), large_deflection_nonlinear_larger=sum(p.nonlinear_part > p.dynamic_part
                                                                         for p in big),
        failures=tuple(sorted((p for p in points if not p.dyn_ok),
                              key=lambda p: (p.linkage, p.mechanism, p.mass_model, p.r))))


def _span(lo_hi: tuple[float, float]) -> str:
    lo, hi = lo_hi
    return f"{lo:.3f}-{hi:.3f}" if math.isfinite(lo) else "-"


_HEAD = ("linkage", "mechanism", "mass model", "quasi-static 5 %", "quasi-static 10 %", "linear 5 %", "linear 10 %",
         "linear, no prestress 5 %", "linear, no prestress 10 %")


def markdown(f: TiersFindings, figure: Path | None, readme: Path) -> str:
    """The README section, formatted from the findings only."""
    L = ["## Three tiers: quasi-static, linear, nonlinear", "",
         "Regenerate: `ked study tiers` (reads the validity campaigns' HDF5 files, whose configs list the "
         "quasi-static, linear (with and without prestress) and Exudyn solvers; `ked study validity` computes "
         "any missing solution). Errors: vector history errors of the coupler point against the Exudyn steady "
         "state (`compare.metrics.history_error`); the quasi-static error splits into a **dynamic part** "
         "max|d_lin - d_qs| / max|d_dyn| and a **nonlinear part** max|d_dyn - d_lin| / max|d_dyn|. Limits: the "
         "largest r = Omega/omega1_min below which every scene of the family solved and stayed under the "
         "tolerance, as the first crossing on the validity study's r grid: **r (+step)** means every grid scene up "
         "to r passed and the next grid ratio, r + step, did not; the crossing lies in between, never interpolated (a "
         "resonance peak between the two can cross the tolerance anywhere there). Where the step is wide, the "
         "limit is only known to that step.", ""]
    L += table(_HEAD, [[fam.linkage, fam.mechanism, fam.mass_model, *(lim.text for lim in fam.limits.values())]
                       for fam in f.families], dense=True)
    if f.coarse:
        L += ["", f"Grid steps above {COARSE_STEP:g} (on the {', '.join(f.coarse)} linkage(s)): there the stored grid "
              "is too coarse to place the first crossing or to see a resonance between the two ratios; the limit is "
              "the last passing ratio, a lower bound known to that step. The thesis linkage's linear limits come from "
              "a grid of step 0.01 between 0.15 and 0.33 (`studies/validity_fine_*.toml`, 112 scenes); "
              "the same grid for another linkage costs 16 scenes per mass model and mechanism."]
    L += ["", "**The answer, per mass model** (range over the linkages of the limits that were crossed on the "
          "grid: first crossings, see the steps in the table):", ""]
    for mm, s in f.spans.items():
        L.append(f"* {mm}: quasi-static holds to r = {_span(s['quasi_static', 0.05])} (5 %) / "
                 f"{_span(s['quasi_static', 0.1])} (10 %); the linear model to r = {_span(s['linear', 0.05])} "
                 f"(5 %) / {_span(s['linear', 0.1])} (10 %) (without prestress: "
                 f"{_span(s['linear_classic', 0.05])} / {_span(s['linear_classic', 0.1])}); beyond that the "
                 "nonlinear model is needed.")
    L += ["", _parts_text(f), *_failures(f.failures)]
    if figure is not None:
        L += ["", f"![tiers]({os.path.relpath(figure.resolve(), readme.resolve().parent)})"]
    return "\n".join(L) + "\n"


def _parts_text(f: TiersFindings) -> str:
    if not f.parts:
        return "No scene has all three solutions yet."
    return (f"Where the error comes from: in {f.low_r_dynamic_larger} of the {f.low_r} scenes with r <= 0.1 the "
            "dynamic part is the larger one (the quasi-static answer fails because it ignores the inertia of the "
            "elastic motion, which the linear model restores); in "
            f"{f.large_deflection_nonlinear_larger} of the {f.large_deflection} "
            "scenes whose peak deflection exceeds 10 % of the shortest link the nonlinear part is the larger one.")


def _failures(failed: Sequence[TierPoint]) -> list[str]:
    if not failed:
        return []
    L = ["", "Scenes where Exudyn found no periodic steady state, with the linear model's largest |Floquet "
         "multiplier| (>= 1: the linear model has no stable periodic steady state either):", ""]
    rows = []
    for p in failed:
        cls, _, why = p.dyn_reason.partition(": ")
        why = why.split(" (time=")[0].split(". Likely cause")[0].split(" [")[0]
        rows.append([p.linkage, p.mechanism, p.mass_model, f"{p.r:g}", f"{p.floquet_max_abs:.3f}", cls, why[:90]])
    return L + table(("linkage", "mechanism", "mass model", "r", "linear max abs(mu)", "Exudyn failure class",
                      "Exudyn"), rows, dense=True)


def figure(points: Sequence[TierPoint], path: Path) -> Path:
    """Error parts against r, and the nonlinear part against peak deflection / shortest link."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(12, 4.5), layout="constrained")
    ax1, ax2 = fig.subplots(1, 2)
    for mm, marker in zip(MASS_MODELS, "osD^"):
        sel = [p for p in points if p.mass_model == mm and math.isfinite(p.dynamic_part)]
        if not sel:
            continue
        r = [p.r for p in sel]
        ax1.scatter(r, [p.error["quasi_static"] for p in sel], marker=marker, s=14, label=f"{mm}: quasi-static")
        ax1.scatter(r, [p.nonlinear_part for p in sel], marker=marker, s=14, facecolors="none",
                    label=f"{mm}: linear (nonlinear part)")
        ax2.scatter([p.deflection_ratio for p in sel], [p.nonlinear_part for p in sel], marker=marker, s=14, label=mm)
    for ax in (ax1, ax2):
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.grid(alpha=0.3, which="both")
        for tol in TOLERANCES:
            ax.axhline(tol, color="r", lw=0.8, ls=":")
    ax1.set_xlabel("speed ratio r = Omega / omega1_min")
    ax1.set_ylabel("history error against Exudyn [1]")
    ax1.set_title("quasi-static error (filled) and linear model error (open)", fontsize=10)
    ax2.set_xlabel("peak deflection of P / shortest link (Exudyn)")
    ax2.set_ylabel("nonlinear part max|d_dyn - d_lin| / max|d_dyn|")
    ax2.set_title("the linear model's error grows with the deflection", fontsize=10)
    ax1.legend(fontsize=7, ncol=2)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    return path


def run(paths: StudyPaths, *, workers: int = 2, fresh: bool = False, report_only: bool = False,
        progress: bool = False, echo: Callable[[str], object] = print) -> dict:
    """The study with the common signature (see :func:`ked_research.run`); computing means resuming
    the validity campaigns (which adds missing linear solutions); ``fresh`` is the validity study's."""
    configs = [CONFIG_DIR / c for c in validity.CONFIGS]
    if not report_only:
        validity.run(paths, workers=workers, fresh=fresh, progress=progress, echo=echo, retry=False, refine=False)
    files = [paths.studies / (c.stem + ".h5") for c in configs]
    points = load(files)
    fig = figure(points, paths.figures / FIGURE) if points else None
    write_section(paths.readme, SECTION, markdown(analyse(points), fig, paths.readme))
    return {"scenes": len(points), "figure": str(fig) if fig else None, "readme": str(paths.readme)}
