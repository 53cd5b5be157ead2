"""What the atlas's README section states, computed from the stored tables (the analyse step of the
report: :mod:`ked_research.atlas.report` formats these findings only).  Speed ratios r = Omega/omega1_min and
errors are [1], fractions of scenes or families [1], counts of scenes or families, wall times [s]."""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass
from typing import Any

import numpy as np

from compare.limits import TOLERANCES
from ked_quasi.massmodel import MASS_MODELS
from ked_research.atlas import calibration as cal
from ked_research.atlas.analysis import (
    TOLERANCE_TAGS,
    TierLimits,
    crossed,
    linear_limits,
    linear_of,
    median_spread,
    rule_constant,
    spearman,
    tier_limits,
    within,
)


def quantile(values: Any, q: float) -> float:
    """The q-th percentile of the finite values (nan if none)."""
    v = np.asarray(values, float)
    v = v[np.isfinite(v)]
    return float(np.percentile(v, q)) if v.size else math.nan


@dataclass(frozen=True)
class Headline:
    """The section's answer over the families whose 10 % limit r* [1] crossed on the atlas grid."""

    families: int
    r10_median: float
    r10_p10: float
    r10_p90: float
    r10_step_median: float
    """Median grid step [1] behind the first crossings."""
    r5_median: float
    mass_model_spread: float
    """Largest minus smallest median r* (10 %) of the mass models [1]."""
    widest: float
    """Largest 10-90 % width of r* (10 %) within one mass model [1]."""
    correlations: tuple[tuple[str, float], ...]
    """The three features with the strongest Spearman rank correlation with r* (10 %): (name, rho)."""
    one_mode_within: float
    """Fraction of the families whose one-mode estimate of r* (10 %) lies within +-25 %."""


def headline(dist: tuple[Distribution, ...], rho: dict[str, tuple[float, ...]], pred: Predictions,
             step_median: float) -> Headline:
    """The answer, from the other findings (``dist[-1]``: every family; ``rho``'s last column: over all)."""
    r10, per_mm = dist[-1].r10, [d.r10 for d in dist[:-1] if d.r10.size]
    top = sorted(rho, key=lambda k: -abs(np.nan_to_num(rho[k][-1])))[:3]
    return Headline(r10.size, float(np.median(r10)), float(np.percentile(r10, 10)), float(np.percentile(r10, 90)),
                    step_median, float(np.median(dist[-1].r5)), float(np.ptp([float(np.median(v)) for v in per_mm])),
                    max(float(np.ptp(np.percentile(v, [10, 90]))) for v in per_mm),
                    tuple((k, rho[k][-1]) for k in top), pred.one_mode[0.10][0])


@dataclass(frozen=True)
class StratumCalls:
    """The check's calls on the threshold scenes of one mass model and mechanism (counts)."""

    mass_model: str
    mechanism: str
    scenes: int
    exudyn_ok: int
    measured_fail: int
    """Scenes whose measured error (quasi-static vs Exudyn) reached the tolerance."""
    unsafe: int
    borderline: int
    overcautious: int


@dataclass(frozen=True)
class ThresholdFindings:
    """The threshold calibration: the sample, measured over predicted errors, the over-cautious calls and
    the calls per stratum (``margins``: the chosen margins with their rates)."""

    margins: cal.Margins
    strata_min: int
    strata_max: int
    factor_min: float
    factor_max: float
    """Range of the drawn factors f of r = f x r* [1]."""
    threshold_scenes: int
    joined: int
    """Scenes of the confirmed sample in the same band."""
    scenes: int
    exudyn_ok: int
    ratio_median: float
    ratio_q05: float
    ratio_q95: float
    """Measured error over predicted error [1]: median, 5th and 95th percentile."""
    near: int
    """Scenes predicted within +-20 % of the tolerance."""
    near_diff_median: float
    near_diff_max: float
    """|measured - predicted| error [1] of those scenes."""
    measured_fail: int
    gated: int
    """Scenes the margin alone would have called quasi-static, withheld by the linear-range gate."""
    overcautious: int
    overcautious_flagged: int
    flagged: int
    """Scenes whose linear solution carries a large-deflection / large-rotation flag."""
    overcautious_gate: int
    overcautious_prediction: int
    strata: tuple[StratumCalls, ...]
    early: tuple[int, int, int, int] | None
    """Threshold scenes below their family's interpolated r*: (below, with error >= tolerance, of those
    between the first-crossing limit and the interpolated one, at or below the first-crossing limit);
    None without the families."""


def _early(d: cal.ThresholdData, fam: dict[str, np.ndarray], tol: float) -> tuple[int, int, int, int]:
    row = {(int(k), str(m), str(mm)): i for i, (k, m, mm) in enumerate(zip(fam["linkage"], fam["mechanism"],
                                                                          fam["mass_model"]))}
    r_first = np.array([fam["r10"][row[(int(k), str(m), str(mm))]] if (int(k), str(m), str(mm)) in row else np.nan
                        for k, m, mm in zip(d.linkage, d.mechanism, d.mass_model)], float)
    below = (d.sample == "threshold") & np.isfinite(d.e) & (d.factor < 1.0)
    early = below & (d.e >= tol)
    unseen = early & (d.r <= r_first)
    return int(below.sum()), int(early.sum()), int((early & ~unseen).sum()), int(unseen.sum())


def threshold(d: cal.ThresholdData | None, mg: cal.Margins | None,
              fam: dict[str, np.ndarray] | None = None) -> ThresholdFindings | None:
    """The findings of the threshold sample (None without one)."""
    if d is None or mg is None or not d.e.size:
        return None
    tol = mg.tolerance
    ok = np.isfinite(d.measured)
    e, m = d.e[ok], d.measured[ok]
    thr = d.sample == "threshold"
    strata = Counter(zip(d.mass_model[thr], d.mechanism[thr]))
    near = (e >= 0.8 * tol) & (e <= 1.2 * tol)
    c = cal.calls(d.e, d.r, d.r_linear, d.linear_ok, tol, mg.holds_below, mg.fails_above)
    oc = ok & (c == cal.NOT_QUASI_STATIC) & (d.measured < tol)
    flagged, gate = oc & ~d.linear_ok, oc & d.linear_ok & ~(d.r < d.r_linear)
    rows = []
    for mm in MASS_MODELS:
        for mech in ("source", "cognate"):
            sel = (d.mass_model == mm) & (d.mechanism == mech)
            so = sel & ok
            fail = so & (d.measured >= tol)
            rows.append(StratumCalls(mm, mech, *(int(np.sum(x)) for x in (
                sel, so, fail, fail & (c == cal.QUASI_STATIC), so & (c == cal.BORDERLINE),
                so & ~fail & (c == cal.NOT_QUASI_STATIC)))))
    return ThresholdFindings(
        mg, min(strata.values()), max(strata.values()), float(np.min(d.factor)), float(np.max(d.factor)),
        int(thr.sum()), int((~thr).sum()), int(d.e.size), int(ok.sum()), quantile(m / e, 50), quantile(m / e, 5),
        quantile(m / e, 95), int(near.sum()), quantile(np.abs(m - e)[near], 50), quantile(np.abs(m - e)[near], 100),
        *(int(np.sum(x)) for x in (m >= tol, ok & np.isfinite(d.e) & (d.e < mg.holds_below * tol) & ~(d.r < d.r_linear),
                                   oc, flagged, ~d.linear_ok, gate, oc & ~flagged & ~gate)),
        tuple(rows), _early(d, fam, tol) if fam is not None else None)


@dataclass(frozen=True)
class ConfirmFindings:
    """The Exudyn-confirmed sample: counts, the plain 10 % call against the reference, the linear model
    against Exudyn."""

    scenes: int
    families: int
    exudyn_ok: int
    wall_median_s: float
    agree: int
    """Scenes where the plain 10 % call (quasi-static vs linear) and the reference (vs Exudyn) agree."""
    agree_at: int
    at: int
    """Of those, at r = r*; the scenes at r = r*."""
    diff_median: float
    diff_p90: float
    """|quasi-static vs linear - quasi-static vs Exudyn| error [1]."""
    linear_within: dict[float, float]
    """Tolerance [1] -> fraction of the scenes with the linear model within it of Exudyn."""
    factor_max: float
    linear_status: dict[str, int]
    """Status of the families' linear 10 % limits -> count."""
    failures: tuple[tuple[str, int], ...]
    """The five most common Exudyn failure reasons (shortened) with their counts."""


def confirm(conf: dict[str, np.ndarray]) -> ConfirmFindings | None:
    """The findings of the confirmed sample (None without one)."""
    n = len(conf.get("key", []))
    if not n:
        return None
    ok = np.asarray(conf["status"], dtype=object) == "ok"
    qd, ql, ld = conf["qs_vs_dyn"][ok], conf["qs_vs_linear"][ok], conf["linear_vs_dyn"][ok]
    same = (ql < 0.10) == (qd < 0.10)
    at = np.isclose(np.asarray(conf["factor"], float)[ok], 1.0)
    reasons = Counter(str(r).split(":")[0] + ": " + str(r).split(":")[1][:60] if ":" in str(r) else str(r)
                      for r in np.asarray(conf["reason"], dtype=object)[~ok])
    return ConfirmFindings(
        n, len({k.rsplit("/", 1)[0] for k in conf["key"]}), int(ok.sum()), float(np.nanmedian(conf["dyn_wall_s"])),
        int(same.sum()), int(same[at].sum()), int(at.sum()), float(np.nanmedian(np.abs(ql - qd))),
        float(np.nanpercentile(np.abs(ql - qd), 90)), {tol: float((ld < tol).mean()) for tol in (0.05, 0.10)},
        float(np.max(conf["factor"])), Counter(x.status for (_, tol), x in linear_limits(conf).items() if tol == 0.10),
        tuple(reasons.most_common(5)))


@dataclass(frozen=True)
class Distribution:
    """The limits r* [1] of one mass model ("all": every family): the crossed 5 % and 10 % limits, their
    10 % range, and the count of each 10 % status."""

    mass_model: str
    families: int
    r5: np.ndarray
    r10: np.ndarray
    r10_range: tuple[float, float] | None
    status: dict[str, int]


def distribution(fam: dict[str, np.ndarray]) -> tuple[Distribution, ...]:
    out = []
    for mm in (*MASS_MODELS, None):
        sel = np.ones(len(fam["mass_model"]), bool) if mm is None else np.asarray(fam["mass_model"], dtype=object) == mm
        r10 = np.asarray(fam["r10"], float)[sel & crossed(fam, "r10")]
        out.append(Distribution(mm or "all", int(sel.sum()), np.asarray(fam["r5"], float)[sel & crossed(fam, "r5")],
                                r10, (float(r10.min()), float(r10.max())) if r10.size else None,
                                Counter(np.asarray(fam["r10_status"], dtype=object)[sel])))
    return tuple(out)


@dataclass(frozen=True)
class Flags:
    """Families whose linear answer carries a large-deflection / large-rotation flag anywhere on the sweep
    and at or below their r* (10 %); the largest Floquet |mu| [1] at or below r* (10 %): median and max."""

    anywhere: int
    early: int
    mu_median: float
    mu_max: float


def flags(fam: dict[str, np.ndarray], ratios: np.ndarray) -> Flags:
    below = np.asarray(ratios, float)[None, :] <= np.nan_to_num(np.asarray(fam["r10"], float), nan=np.inf)[:, None]
    f = np.asarray(fam["flags"], int) > 0
    mu = np.nanmax(np.where(below, fam["floquet_max_abs"], np.nan), axis=1)
    return Flags(int(f.any(axis=1).sum()), int((f & below).any(axis=1).sum()), float(np.nanmedian(mu)),
                 float(np.nanmax(mu)))


def correlations(fam: dict[str, np.ndarray], feats: dict[str, np.ndarray]) -> dict[str, tuple[float, ...]]:
    """Feature -> Spearman rank correlation with r* (10 %) per mass model and over all (last)."""
    def rho(x: np.ndarray, mm: str | None) -> float:
        m = crossed(fam, "r10", mm)
        return spearman(np.asarray(x, float)[m], np.asarray(fam["r10"], float)[m])

    return {name: tuple(rho(x, mm) for mm in (*MASS_MODELS, None)) for name, x in feats.items()}


@dataclass(frozen=True)
class Predictions:
    """How well r* is predicted.  ``one_mode``: tolerance [1] -> (fraction of the crossed families whose
    one-mode estimate lies within +-25 %, their number, median predicted / atlas); the rule k_sig r <= c:
    ``c`` [1] per mass model and "all", the fraction within +-25 % with one c and with c per mass model;
    ``rule``: r* (10 %) [1] the rule with c per mass model predicts, per family."""

    one_mode: dict[float, tuple[float, int, float]]
    c: dict[str, float]
    within_one_c: float
    within_per_mass_model: float
    rule: np.ndarray


def predictions(fam: dict[str, np.ndarray]) -> Predictions:
    rule = np.full(len(fam["r10"]), math.nan)
    cs = {}
    for mm in MASS_MODELS:
        m = crossed(fam, "r10", mm)
        cs[mm] = rule_constant(fam["k_sig_1"][m], fam["r10"][m])
        sel = np.asarray(fam["mass_model"], dtype=object) == mm
        rule[sel] = cs[mm] / fam["k_sig_1"][sel]
    m = crossed(fam, "r10")
    cs["all"] = rule_constant(fam["k_sig_1"][m], fam["r10"][m])
    one = {}
    for tag, tol in zip(TOLERANCE_TAGS, TOLERANCES):
        k = crossed(fam, tag)
        one[tol] = (float(within(fam[f"one_mode_{tag}"][k], fam[tag][k]).mean()), int(k.sum()),
                    float(np.nanmedian(fam[f"one_mode_{tag}"][k] / fam[tag][k])))
    return Predictions(one, cs, float(within(cs["all"] / fam["k_sig_1"][m], fam["r10"][m]).mean()),
                       float(within(rule[m], fam["r10"][m]).mean()), rule)


@dataclass(frozen=True)
class Worst:
    """A family the one-mode estimate predicts worst: its r* (10 %), the one-mode and the rule's
    predictions [1], k_sig at 1 % / 5 %, f1 max / f1 min [1], minimum transmission angle [deg]."""

    family: str
    r10: float
    one_mode: float
    rule: float
    k_sig: tuple[int, int]
    f1_ratio: float
    min_transmission_deg: float


def worst(fam: dict[str, np.ndarray], rule: np.ndarray, n: int = 6) -> tuple[Worst, ...]:
    m = np.flatnonzero(crossed(fam, "r10"))
    dev = np.abs(np.log(fam["one_mode_r10"][m] / fam["r10"][m]))
    return tuple(Worst(family_name(fam, i), fam["r10"][i], fam["one_mode_r10"][i], rule[i],
                       (int(fam["k_sig_1"][i]), int(fam["k_sig_5"][i])),
                       fam["f1_max_hz"][i] / fam["f1_min_hz"][i], fam["min_transmission_deg"][i])
                 for i in m[np.argsort(-dev)][:n])


def tiers(fam: dict[str, np.ndarray], conf: dict[str, np.ndarray]) -> tuple[tuple[TierLimits, tuple[float, ...]], ...]:
    """Per mass model its tier limits with the median grid steps [1] of the first crossings behind them
    (quasi-static 5 %, 10 %, linear 5 %, 10 %)."""
    lins = linear_limits(conf)
    out = []
    for mm in MASS_MODELS:
        sel = np.asarray(fam["mass_model"], dtype=object) == mm
        steps = [median_spread(np.asarray(fam[f"{tag}_step"], float)[sel])[0] for tag in TOLERANCE_TAGS]
        out.append((tier_limits(fam, conf, mm), (*steps, *(median_spread([x.step for x in linear_of(lins, mm, tol)])[0]
                                                          for tol in TOLERANCES))))
    return tuple(out)


@dataclass(frozen=True)
class LinearLimits:
    """The linear model's own limits against Exudyn of one mass model at one tolerance [1]: the confirmed
    families, the crossed limits [1] with their median grid step, how many never reached the tolerance
    with the median of their lower bounds [1], how many were already above it at the smallest ratio or
    ended by an Exudyn failure."""

    mass_model: str
    tolerance: float
    families: int
    crossed: np.ndarray
    step: float
    not_reached: int
    not_reached_median: float
    below: int
    failed: int


def linear_table(conf: dict[str, np.ndarray]) -> tuple[LinearLimits, ...]:
    lims = linear_limits(conf)
    out = []
    for mm in MASS_MODELS:
        for tol in TOLERANCES:
            x = linear_of(lims, mm, tol)
            above = [v.r_pass for v in x if v.status == "above_grid"]
            out.append(LinearLimits(mm, tol, len(x), np.array([v.r_pass for v in x if v.status == "crossed"]),
                                    median_spread([v.step for v in x if v.status == "crossed"])[0], len(above),
                                    median_spread(above)[0],
                                    sum(v.status == "below_grid" for v in x), sum(v.status == "failure" for v in x)))
    return tuple(out)


@dataclass(frozen=True)
class SampleFindings:
    """The drawn linkages: the seed, accepted of the candidates, accepted with a crank-drivable cognate,
    the rejects' reasons with their counts (most common first), the drawing ranges (stored attributes)."""

    seed: object
    accepted: int
    candidates: int
    cognates: int
    rejected: tuple[tuple[str, int], ...]
    ranges: dict[str, Any]


def sample(links: dict[str, np.ndarray], info: dict[str, Any]) -> SampleFindings:
    acc = np.asarray(links["accepted"]).astype(bool)
    reasons = Counter(str(r).split(":")[0].split(" (")[0] for r in np.asarray(links["reason"], dtype=object)[~acc])
    cog = sum(1 for m in np.asarray(links["mechanisms"], dtype=object)[acc] if "cognate" in str(m))
    return SampleFindings(info.get("seed"), int(acc.sum()), acc.size, cog, tuple(reasons.most_common()),
                          info.get("ranges", {}))


def family_name(fam: dict[str, np.ndarray], i: int) -> str:
    return f"linkage {int(fam['linkage'][i])} {fam['mechanism'][i]} {fam['mass_model'][i]}"


@dataclass(frozen=True)
class AtlasFindings:
    """Everything the atlas's README section states: the stored attributes, the number of families, the
    grid steps [1] behind the first crossings (median at 5 %, at 10 %, largest at 10 %) and the findings
    of each part (None: no threshold or confirmed sample yet)."""

    info: dict[str, Any]
    families: int
    steps: tuple[float, float, float]
    headline: Headline
    margins: cal.Margins | None
    sample: SampleFindings
    distribution: tuple[Distribution, ...]
    flags: Flags
    correlations: dict[str, tuple[float, ...]]
    predictions: Predictions
    worst: tuple[Worst, ...]
    tiers: tuple[tuple[TierLimits, tuple[float, ...]], ...]
    threshold: ThresholdFindings | None
    confirm: ConfirmFindings | None
    linear: tuple[LinearLimits, ...]


def analyse(info: dict[str, Any], fam: dict[str, np.ndarray], links: dict[str, np.ndarray],
            conf: dict[str, np.ndarray], thr: cal.ThresholdData | None, margins: cal.Margins | None,
            feats: dict[str, np.ndarray], ratios: np.ndarray) -> AtlasFindings:
    """The findings of the stored atlas tables (``fam`` with first-crossing limits, ``feats`` per family)."""
    pred, dist, rho = predictions(fam), distribution(fam), correlations(fam, feats)
    steps = (quantile(fam["r5_step"], 50), quantile(fam["r10_step"], 50), quantile(fam["r10_step"], 100))
    return AtlasFindings(info, len(fam["linkage"]), steps, headline(dist, rho, pred, steps[1]), margins,
                         sample(links, info), dist, flags(fam, ratios), rho, pred,
                         worst(fam, pred.rule), tiers(fam, conf), threshold(thr, margins, fam), confirm(conf),
                         linear_table(conf) if conf else ())
