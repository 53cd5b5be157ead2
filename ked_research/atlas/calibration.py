"""Calibration of the design check's quasi-static call at the threshold (pure functions of column arrays).

The check (``ked check`` without ``--confirm``) predicts the quasi-static answer's error by
e = max_k |d_qs - d_lin| / max_k |d_lin| (the history error of the deflection vector against the linear
model) and calls, for a tolerance ``tol`` and margins ``holds_below`` <= ``fails_above`` (multipliers of
``tol``):

* "quasi-static" where e < holds_below x tol and the linear model is inside its own range there (a
  linear solution without flags, r below the atlas's lower-band linear limit
  :func:`ked_research.atlas.analysis.lower_band` of the mass model),
* "borderline" (run ``--confirm``) where holds_below x tol <= e < fails_above x tol inside that range,
* "not quasi-static" otherwise.

:func:`calls` (:mod:`ked_check.verdict_rule`) states that rule once, vectorized; the check calls it.
Measured against Exudyn on the atlas's threshold sample (:mod:`ked_research.atlas.threshold`: measured error
m = quasi-static vs Exudyn, the same history error), a call is **unsafe** when it says quasi-static and
m >= tol, **over-cautious** when it says not quasi-static and m < tol; a borderline call is never unsafe
(it says: confirm) and is counted apart. Rates are over every threshold scene with an Exudyn steady
state, each with its two-sided 95 % Clopper-Pearson interval (:func:`clopper_pearson`).

:func:`choose_margins` takes the more cautious of two criteria on each side.  ``holds_below``: (a) the
largest multiplier on :data:`HOLDS_GRID` whose unsafe-call rate has an upper 95 % bound <=
:data:`MAX_UNSAFE_UPPER95` (the unsafe count grows with the multiplier, so every smaller one meets it too),
and (b) at most 1 / q95 of the measured-over-predicted ratio m / e of the scenes predicted near the
tolerance (e within +-20 % of it; all scenes if fewer than :data:`MIN_NEAR`), q95 its distribution-free
95 % / 95 % upper tolerance bound (:func:`tolerance_bound`): a call at the margin is then right with at least
95 % probability, at 95 % confidence.  ``fails_above``: (a) the smallest multiplier >= 1 on
:data:`FAILS_GRID` whose over-cautious calls *made by the prediction* (e >= fails_above x tol, m < tol) meet
the same bound, and (b) at least 1 / q05 of the same ratio (its lower tolerance bound).  The band between
them is the measured uncertainty of the prediction at the threshold.  When no multiplier meets the bound (too
few scenes: with no unsafe call at all the bound needs n >= 122), ``holds_below`` is 0 (the prediction alone never
grants the quasi-static tier) and ``bound_met`` is False.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
from scipy.stats import beta

from compare import store as base_store

# re-exported: the calibration's vocabulary
from ked_check.verdict_rule import (  # noqa: F401
    BORDERLINE,
    CALL_NAMES,
    NOT_QUASI_STATIC,
    QUASI_STATIC,
    VerdictMargins,
    calls,
    from_record,
    stratum,
)
from ked_quasi.limits import MAX_DEFLECTION_FRACTION
from ked_research.atlas import store
from ked_research.atlas.analysis import default_path, limits, lower_band
from ked_research.atlas.threshold import BAND, TABLE

FOUR_BAR = "four-bar"
"""The linkage kind of every atlas scene."""
MIN_STRATUM = 100
"""Fewest Exudyn-confirmed threshold scenes of a stratum whose margins may grant the quasi-static tier (with no
unsafe call the 3 % bound needs 122 anyway)."""

MAX_UNSAFE_UPPER95 = 0.03
"""Largest allowed upper 95 % bound of the unsafe-call rate at the threshold [1]."""
HOLDS_GRID = tuple(round(0.01 * i, 2) for i in range(1, 101))
"""Candidate ``holds_below`` multipliers: 0.01 ... 1.00."""
FAILS_GRID = tuple(round(1.0 + 0.01 * i, 2) for i in range(0, 201))
"""Candidate ``fails_above`` multipliers: 1.00 ... 3.00."""
NEAR = 0.20
"""Scenes predicted within +-20 % of the tolerance measure the prediction's scatter at the decision."""
MIN_NEAR = 59
"""Fewest scenes whose largest value is a 95 % / 95 % upper tolerance bound (1 - 0.95^59 > 0.95): with
fewer near the tolerance, every scene of the sample measures the scatter."""


def tolerance_bound(x: np.ndarray, coverage: float = 0.95, confidence: float = 0.95) -> float:
    """Distribution-free upper tolerance bound of a sample: the smallest order statistic that lies above
    the ``coverage`` quantile of the population with probability ``confidence`` (binomial order-statistic
    bound); the sample's largest value when no order statistic reaches the confidence (too few values)."""
    from scipy.stats import binom

    x = np.sort(np.asarray(x, float))
    n = x.size
    k = np.arange(1, n + 1)
    ok = binom.cdf(k - 1, n, coverage) >= confidence
    return float(x[int(np.argmax(ok))] if ok.any() else x[-1]) if n else math.nan


@dataclass(frozen=True)
class Rate:
    """k of n with its two-sided 95 % Clopper-Pearson interval (fractions; nan when n = 0)."""

    k: int
    n: int
    rate: float
    low95: float
    high95: float


def clopper_pearson(k: int, n: int, confidence: float = 0.95) -> Rate:
    """Exact binomial interval of k successes in n trials (beta quantiles)."""
    if n <= 0:
        return Rate(k, n, math.nan, math.nan, math.nan)
    a = 0.5 * (1.0 - confidence)
    lo = 0.0 if k == 0 else float(beta.ppf(a, k, n - k + 1))
    hi = 1.0 if k == n else float(beta.ppf(1.0 - a, k + 1, n - k))
    return Rate(int(k), int(n), k / n, lo, hi)


@dataclass(frozen=True)
class CallStats:
    """How the calls of one rule compare with the measured errors at the threshold."""

    n: int
    quasi_static: int
    borderline: int
    borderline_measured_fail: int
    not_quasi_static: int
    unsafe: Rate
    overcautious: Rate
    agreement: Rate
    """Decisive calls (quasi-static or not) that agree with the measurement, of the decisive calls."""


def call_stats(call: np.ndarray, measured: np.ndarray, tolerance: float) -> CallStats:
    """Unsafe / over-cautious / agreement of ``call`` against the measured errors (finite ones only)."""
    m = np.asarray(measured, float)
    keep = np.isfinite(m)
    c, fail = np.asarray(call)[keep], m[keep] >= tolerance
    n = int(keep.sum())
    qs, bl, no = c == QUASI_STATIC, c == BORDERLINE, c == NOT_QUASI_STATIC
    decisive = int(qs.sum() + no.sum())
    agree = int(np.sum(qs & ~fail) + np.sum(no & fail))
    return CallStats(n, int(qs.sum()), int(bl.sum()), int(np.sum(bl & fail)), int(no.sum()),
                     clopper_pearson(int(np.sum(qs & fail)), n), clopper_pearson(int(np.sum(no & ~fail)), n),
                     clopper_pearson(agree, decisive))


@dataclass(frozen=True)
class Margins:
    """The chosen margins (multipliers of ``tolerance``) and the threshold statistics of the rule."""

    tolerance: float
    holds_below: float
    fails_above: float
    bound_met: bool
    stats: CallStats
    plain: CallStats
    """The plain rule for context: quasi-static iff e < tolerance, no margin, no linear-range gate."""
    holds_below_rate: float
    holds_below_scatter: float
    fails_above_rate: float
    fails_above_scatter: float
    ratio_q05: float
    ratio_q95: float
    n_near: int
    """Scenes behind the ratio quantiles (measured / predicted error near the tolerance)."""


def choose_margins(e: np.ndarray, measured: np.ndarray, r: np.ndarray, r_linear: np.ndarray,
                   linear_ok: np.ndarray, tolerance: float = 0.10,
                   max_unsafe_upper95: float = MAX_UNSAFE_UPPER95) -> Margins:
    """The margins of the module docstring from threshold data (arrays per scene; ``measured`` nan where
    Exudyn failed: such scenes are left out)."""
    m = np.asarray(measured, float)
    keep = np.isfinite(m)
    e, m, r, r_lin, ok = (np.asarray(x)[keep] for x in (e, m, r, r_linear, linear_ok))
    e = np.asarray(e, float)
    n = int(keep.sum())

    def rule(hb: float, fa: float) -> np.ndarray:
        return calls(e, r, r_lin, ok, tolerance, hb, fa)

    hb, met = 0.0, False
    for cand in HOLDS_GRID:
        if call_stats(rule(cand, cand), m, tolerance).unsafe.high95 > max_unsafe_upper95:
            break
        hb, met = cand, True
    fa = FAILS_GRID[-1]
    for cand in FAILS_GRID:
        k = int(np.sum(np.isfinite(e) & (e >= cand * tolerance) & (m < tolerance)))
        if clopper_pearson(k, n).high95 <= max_unsafe_upper95:
            fa = cand
            break
    good = np.isfinite(e) & (e > 0)
    near = good & (np.abs(e / tolerance - 1.0) <= NEAR)
    pick = near if near.sum() >= MIN_NEAR else good
    ratio = m[pick] / e[pick]
    q05, q95 = (-tolerance_bound(-ratio), tolerance_bound(ratio)) if ratio.size else (math.nan, math.nan)
    hb_scatter = math.floor(100.0 / q95 + 1e-9) / 100.0 if q95 > 0 else 0.0
    fa_scatter = math.ceil(100.0 / q05 - 1e-9) / 100.0 if q05 > 0 else FAILS_GRID[-1]
    holds = min(hb, hb_scatter) if met else 0.0
    fails = max(fa, fa_scatter, holds, 1.0)
    plain = np.where(np.isfinite(e) & (e < tolerance), QUASI_STATIC, NOT_QUASI_STATIC)
    return Margins(tolerance, holds, fails, met, call_stats(rule(holds, fails), m, tolerance),
                   call_stats(plain, m, tolerance), hb, hb_scatter, fa, fa_scatter, q05, q95, int(pick.sum()))


def margins_record(mg: Margins, source: str) -> dict[str, object]:
    """The JSON-able record of the chosen margins stored in the atlas file (attribute ``verdict_margins``,
    keyed by the tolerance in percent)."""
    s = mg.stats
    return {"tolerance": mg.tolerance, "holds_below": mg.holds_below, "fails_above": mg.fails_above,
            "bound_met": mg.bound_met, "max_unsafe_upper95": MAX_UNSAFE_UPPER95, "n_scenes": s.n,
            "unsafe_rate": s.unsafe.rate, "unsafe_upper95": s.unsafe.high95,
            "overcautious_rate": s.overcautious.rate, "overcautious_upper95": s.overcautious.high95,
            "agreement": s.agreement.rate, "agreement_low95": s.agreement.low95,
            "agreement_high95": s.agreement.high95, "source": source, "holds_below_rate": mg.holds_below_rate,
            "holds_below_scatter": mg.holds_below_scatter, "fails_above_rate": mg.fails_above_rate,
            "fails_above_scatter": mg.fails_above_scatter, "ratio_q05": mg.ratio_q05, "ratio_q95": mg.ratio_q95,
            "n_near": mg.n_near,
            "stats": _jsonable(asdict(s)), "plain": _jsonable(asdict(mg.plain))}


def _jsonable(x: object) -> object:
    if isinstance(x, dict):
        return {k: _jsonable(v) for k, v in x.items()}
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x


# --------------------------------------------------------------------------------------------------
# from the atlas file

ATTR = "verdict_margins"
"""Atlas file attribute holding the chosen margins (JSON: tolerance in percent -> :func:`margins_record`)."""


@dataclass(frozen=True)
class ThresholdData:
    """Per threshold scene, with an Exudyn answer or not: predicted error ``e`` (quasi-static vs linear),
    measured error (quasi-static vs Exudyn, nan where Exudyn failed), speed ratio ``r``, the mass model's
    lower-band linear limit ``r_linear``, ``linear_ok`` (a linear solution without flags); all [1].
    ``sample``: "threshold" (the threshold table) or "confirm" (a scene of the confirmed sample inside the
    band)."""

    e: np.ndarray
    measured: np.ndarray
    r: np.ndarray
    r_linear: np.ndarray
    linear_ok: np.ndarray
    mass_model: np.ndarray
    mechanism: np.ndarray
    factor: np.ndarray
    sample: np.ndarray
    linkage: np.ndarray


def threshold_data(path: object, tolerance: float = 0.10) -> ThresholdData:
    """The threshold scenes of an atlas file: the /threshold table and the /confirm scenes within the band
    (r within +-25 % of the family's r10), joined with each mass model's lower-band linear limit
    (:func:`ked_research.atlas.analysis.limits`, :func:`ked_research.atlas.analysis.lower_band`).  A scene whose Exudyn
    answer failed, or lies beyond the small-deflection range (peak deflection over the shortest link above
    ``ked_quasi.limits.MAX_DEFLECTION_FRACTION``: not a valid reference), has no measured error."""
    p = Path(path)  # type: ignore[arg-type]
    thr, conf = store.read(p, TABLE), store.read(p, "confirm")
    in_band = np.abs(np.asarray(conf.get("factor", []), float) - 1.0) <= BAND + 1e-12
    cols = ("qs_vs_linear", "linear_flags", "status", "qs_vs_dyn", "r", "mass_model", "mechanism", "factor",
            "linkage", "deflection_ratio")
    t = {c: np.concatenate([np.asarray(thr.get(c, []), dtype=object), np.asarray(conf.get(c, []),
                                                                                 dtype=object)[in_band]])
         for c in cols}
    sample = np.array(["threshold"] * len(thr.get("key", [])) + ["confirm"] * int(in_band.sum()), dtype=object)
    mm = t["mass_model"]
    bands = {m: lower_band(limits(m, p), tolerance) for m in sorted(set(mm))}
    e = t["qs_vs_linear"].astype(float)
    ok = np.isfinite(e) & (t["linear_flags"].astype(int) == 0)
    # an Exudyn answer beyond the small-deflection range (ked_quasi.limits) is no valid reference: left out
    valid = (t["status"] == "ok") & ~(t["deflection_ratio"].astype(float) > MAX_DEFLECTION_FRACTION)
    measured = np.where(valid, t["qs_vs_dyn"].astype(float), math.nan)
    return ThresholdData(e, measured, t["r"].astype(float), np.array([bands[m] for m in mm], float), ok, mm,
                         t["mechanism"], t["factor"].astype(float), sample, t["linkage"].astype(int))


def threshold_margins(path: object, tolerance: float = 0.10) -> Margins:
    """:func:`choose_margins` on the threshold table of an atlas file."""
    d = threshold_data(path, tolerance)
    return choose_margins(d.e, d.measured, d.r, d.r_linear, d.linear_ok, tolerance)


def strata_margins(path: object, tolerance: float = 0.10) -> dict[str, Margins]:
    """:func:`choose_margins` on each stratum (the file's linkage kind x mass model x mechanism,
    :func:`ked_check.verdict_rule.stratum`) of the threshold scenes alone: a stratum's bias never hides behind
    the others.  A stratum with fewer than :data:`MIN_STRATUM` Exudyn answers grants no quasi-static tier
    (``holds_below`` 0, ``bound_met`` False)."""
    from dataclasses import replace

    from ked_research.atlas.kinds import kind_of

    d = threshold_data(path, tolerance)
    kind = kind_of(Path(path)).name  # type: ignore[arg-type]
    out = {}
    for mm, mech in sorted(set(zip(d.mass_model, d.mechanism))):
        s = (d.mass_model == mm) & (d.mechanism == mech)
        mg = choose_margins(d.e[s], d.measured[s], d.r[s], d.r_linear[s], d.linear_ok[s], tolerance)
        if mg.stats.n < MIN_STRATUM and mg.holds_below > 0:
            e, r, r_lin, ok = d.e[s], d.r[s], d.r_linear[s], d.linear_ok[s]
            stats = call_stats(calls(e, r, r_lin, ok, tolerance, 0.0, mg.fails_above), d.measured[s], tolerance)
            mg = replace(mg, holds_below=0.0, bound_met=False, stats=stats)
        out[stratum(kind, str(mm), str(mech))] = mg
    return out


def store_margins(path: object, tolerance: float = 0.10) -> dict[str, object] | None:
    """Choose the margins from the file's threshold table and store them (attribute :data:`ATTR`) when they
    changed; returns the record (None without a threshold table)."""
    p = Path(path)  # type: ignore[arg-type]
    if not store.read(p, TABLE):
        return None
    where = (f"atlas {p.name}: Exudyn-confirmed scenes within +-25 % of their family's quasi-static 10 % "
             "limit (threshold sample and the confirmed sample's scenes in that band)")
    rec = margins_record(threshold_margins(p, tolerance), f"{where}, every stratum pooled (context only)")
    rec["strata"] = {k: margins_record(m, f"{where}, stratum {k}") for k, m in strata_margins(p, tolerance).items()}
    old = store.attrs(p).get(ATTR, {})
    old = old if isinstance(old, dict) else {}
    key = f"{100 * tolerance:g}"
    if json.loads(json.dumps(old.get(key))) != json.loads(json.dumps(rec)):
        with base_store.writer_lock(p):
            store.write(p, {ATTR: {**old, key: rec}})
    return rec


def _uncalibrated(source: str) -> VerdictMargins:
    return VerdictMargins(source=source)


def verdict_margins(tolerance: float = 0.10, path: object = None, stratum: str | None = None) -> VerdictMargins:
    """The margins stored in the atlas file (default: the committed ``results/atlas/atlas.h5``, read like
    :func:`ked_research.atlas.analysis.limits`) for ``stratum`` (None: every stratum pooled, context only: the
    check uses a stratum's).  Never raises for a missing or unreadable file, a file without calibration, an
    uncalibrated tolerance or stratum: it returns the uncalibrated margins (holds_below 0: no quasi-static tier
    from a prediction; n_scenes 0) with ``source`` saying why."""
    p = Path(path) if path is not None else default_path()  # type: ignore[arg-type]
    if not p.exists():
        return _uncalibrated(f"no atlas file {p}: margins not calibrated")
    try:
        store.check_atlas(p)
        stored = store.attrs(p).get(ATTR, {})
    except (OSError, ValueError) as exc:
        return _uncalibrated(f"atlas file {p} unreadable ({exc}): margins not calibrated")
    rec = stored.get(f"{100 * tolerance:g}") if isinstance(stored, dict) else None
    if not isinstance(rec, dict):
        have = ", ".join(f"{k} %" for k in stored) if isinstance(stored, dict) and stored else "none"
        return _uncalibrated(f"atlas file {p}: no margins calibrated at {100 * tolerance:g} % (calibrated: {have})")

    if stratum is not None:
        rec = rec.get("strata", {}).get(stratum)
        if not isinstance(rec, dict):
            return _uncalibrated(f"atlas file {p}: stratum {stratum} not calibrated at {100 * tolerance:g} %")

    try:
        return from_record(rec)
    except (KeyError, TypeError, ValueError):  # no valid multipliers stored: as uncalibrated
        return _uncalibrated(f"atlas file {p}: the margins stored for {stratum or 'the pool'} are not valid")
