"""What the atlas's README section states, computed from the stored tables (the analyse step of the
report: :mod:`compare.atlas.report` formats these findings only).  Speed ratios r = Omega/omega1_min and
errors are [1], fractions of scenes or families [1], counts of scenes or families, wall times [s]."""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass
from typing import Any

import numpy as np

from compare.atlas import calibration as cal
from compare.atlas.analysis import crossed, linear_limits, spearman, within
from ked_quasi.massmodel import MASS_MODELS


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


def headline(fam: dict[str, np.ndarray], feats: dict[str, np.ndarray]) -> Headline:
    m = crossed(fam, "r10")
    r10 = fam["r10"][m]
    rho = {k: spearman(np.asarray(v, float)[m], r10) for k, v in feats.items()}
    per_mm = [v for v in (fam["r10"][crossed(fam, "r10", mm)] for mm in MASS_MODELS) if v.size]
    return Headline(int(m.sum()), float(np.median(r10)), float(np.percentile(r10, 10)), float(np.percentile(r10, 90)),
                    quantile(fam["r10_step"], 50), float(np.median(fam["r5"][crossed(fam, "r5")])),
                    float(np.ptp([float(np.median(v)) for v in per_mm])),
                    max(float(np.ptp(np.percentile(v, [10, 90]))) for v in per_mm),
                    tuple((k, rho[k]) for k in sorted(rho, key=lambda k: -abs(np.nan_to_num(rho[k])))[:3]),
                    float(within(fam["one_mode_r10"][m], r10).mean()))


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
