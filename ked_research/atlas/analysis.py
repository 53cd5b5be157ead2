"""What the atlas says, from its stored tables only (pure functions of column arrays).

* per mass model, the distribution of the quasi-static 5 %/10 % limits r* (the dynamic part: quasi-static
  against the linear model) and their median with a spread;
* the linear model's own limits, from the Exudyn sample: per confirmed family the walk up its ratios of
  the linear-vs-Exudyn history error (a family whose error never reached the tolerance gives a lower
  bound: its largest confirmed ratio);
* how well the one-mode estimate and the rule k_sig r <= c predict r*.

A tier limit is the **median** over the families, with the **spread** median - 10th percentile: the
limit minus its spread is exceeded by 90 % of the atlas's families (a design check counts it against
the limit).

Every limit is a **first crossing** on its grid (:func:`first_crossings`): the last grid ratio below which
every scene passed, never a value interpolated between the last passing and the first failing ratio
(between two grid ratios a resonance peak can cross the tolerance unseen); the grid step to the first
failing ratio is kept beside it (the crossing lies in [r, r + step)).  The interpolated r5 / r10 the
atlas file stores per family are kept as ``r5_interpolated`` / ``r10_interpolated``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from compare.limits import TOLERANCES, Limit, validity_limit
from compare.paths import ATLAS_FILE
from ked_research.atlas import store
from ked_research.atlas.compute import OK

TOLERANCE_TAGS = ("r5", "r10")


@dataclass(frozen=True)
class TierLimits:
    """Speed-ratio limits r = Omega/omega1_min of a mass model from the atlas: the quasi-static and the
    linear model within 5 % / 10 % (history error of the coupler-point deflection), each with its spread
    (median - 10th percentile over the families) and the number of families behind it."""

    mass_model: str
    quasi_static_r5: float
    quasi_static_r5_spread: float
    quasi_static_r10: float
    quasi_static_r10_spread: float
    linear_r5: float
    linear_r5_spread: float
    linear_r10: float
    linear_r10_spread: float
    families: int
    confirmed_families: int


def median_spread(values: Sequence[float]) -> tuple[float, float]:
    """(median, median - 10th percentile) of the finite values; (nan, nan) if none."""
    v = np.asarray([x for x in values if math.isfinite(x)], float)
    if not v.size:
        return math.nan, math.nan
    med = float(np.median(v))
    return med, med - float(np.percentile(v, 10))


def crossed(fam: dict[str, np.ndarray], tag: str, mass_model: str | None = None) -> np.ndarray:
    """Row mask: the family's limit ``tag`` (r5, r10) was crossed on the grid (and its mass model)."""
    m = np.asarray(fam.get(f"{tag}_status", []), dtype=object) == "crossed"
    if mass_model is not None:
        m &= np.asarray(fam["mass_model"], dtype=object) == mass_model
    return m


def first_crossings(fam: dict[str, np.ndarray], ratios: Sequence[float]) -> dict[str, np.ndarray]:
    """A copy of the /families columns whose limits r5 / r10 are first crossings on ``ratios`` (the last
    passing grid ratio; above_grid: the largest ratio computed, a lower bound; below_grid, failure: nan)
    with ``r5_step`` / ``r10_step`` (first failing minus last passing grid ratio, nan unless crossed) and
    the stored interpolated values as ``r5_interpolated`` / ``r10_interpolated``."""
    out = dict(fam)
    err = np.asarray(fam.get("history_error", np.empty((0, len(ratios)))), float)
    ok = np.asarray(fam.get("code", np.empty((0, len(ratios)))), int) == OK
    for tag, tol in zip(TOLERANCE_TAGS, TOLERANCES):
        if tag not in fam:
            continue
        lims = [validity_limit(ratios, err[i], ok[i], tol) for i in range(err.shape[0])]
        out[f"{tag}_interpolated"] = fam[tag]
        out[tag] = np.array([bound(x) for x in lims])
        out[f"{tag}_step"] = np.array([x.step for x in lims])
    return out


Family = tuple[int, str, str]
"""A family of the atlas: (linkage index, mechanism, mass model)."""


def bound(lim: Limit) -> float:
    """A first-crossing limit as the atlas counts it [1]: the last passing ratio (crossed) or the largest
    ratio passed (above_grid, a lower bound); nan otherwise."""
    return lim.r_pass if lim.status in ("crossed", "above_grid") else math.nan


def linear_limits(confirm: dict[str, np.ndarray]) -> dict[tuple[Family, float], Limit]:
    """Per confirmed family and tolerance [1], the linear model's limit against Exudyn: the walk up its
    confirmed ratios of the linear-vs-Exudyn history error (:func:`compare.limits.validity_limit`)."""
    fams: dict[Family, list[int]] = {}
    for i in range(len(confirm.get("key", []))):
        fams.setdefault((int(confirm["linkage"][i]), str(confirm["mechanism"][i]), str(confirm["mass_model"][i])),
                        []).append(i)
    out = {}
    for fam, rows in fams.items():
        r = [float(confirm["r"][i]) for i in rows]
        e = [float(confirm["linear_vs_dyn"][i]) for i in rows]
        ok = [confirm["status"][i] == "ok" and math.isfinite(e[j]) for j, i in enumerate(rows)]
        out.update({(fam, tol): validity_limit(r, e, ok, tol) for tol in TOLERANCES})
    return out


def linear_of(lins: dict[tuple[Family, float], Limit], mass_model: str, tolerance: float) -> list[Limit]:
    """The linear limits of one mass model at one tolerance [1]."""
    return [lim for (f, tol), lim in lins.items() if f[2] == mass_model and tol == tolerance]


def tier_limits(fam: dict[str, np.ndarray], confirm: dict[str, np.ndarray], mass_model: str) -> TierLimits:
    """The :class:`TierLimits` of one mass model (``fam`` with first-crossing limits:
    :func:`first_crossings`)."""
    qs = {t: median_spread(np.asarray(fam[t], float)[crossed(fam, t, mass_model)]) for t in TOLERANCE_TAGS}
    lins = linear_limits(confirm)
    lin = {t: median_spread([bound(x) for x in linear_of(lins, mass_model, tol)])
           for t, tol in zip(TOLERANCE_TAGS, TOLERANCES)}
    n = int(np.sum(np.asarray(fam.get("mass_model", []), dtype=object) == mass_model))
    return TierLimits(mass_model, *qs["r5"], *qs["r10"], *lin["r5"], *lin["r10"], families=n,
                      confirmed_families=len({f for f, _ in lins if f[2] == mass_model}))


def default_path() -> Path:
    """The committed atlas file of this checkout."""
    return ATLAS_FILE


def limits(mass_model: str, path: str | Path | None = None) -> TierLimits:
    """The atlas's tier limits for ``mass_model`` (tip, joints, extender, distributed), read from the
    stored atlas (default: ``results/atlas/atlas.h5``).  FileNotFoundError if there is no atlas file,
    ValueError if it holds no family of that mass model."""
    p = Path(path) if path is not None else default_path()
    if not p.exists():
        raise FileNotFoundError(f"{p}: no atlas file; run `ked study atlas` to compute it")
    store.check_atlas(p)
    fam = store.read(p, "families")
    if not np.any(np.asarray(fam.get("mass_model", []), dtype=object) == mass_model):
        raise ValueError(f"the atlas {p} has no family of mass model {mass_model!r}")
    fam = first_crossings(fam, store.attrs(p).get("ratios", ()))
    return tier_limits(fam, store.read(p, "confirm"), mass_model)


def lower_band(t: TierLimits, tolerance: float = 0.10) -> float:
    """The linear model's lower-band limit of a mass model: its limit minus its spread (10 % limits for a
    tolerance >= 10 %, else the 5 % ones; a nan spread counts as 0)."""
    lim, spread = (t.linear_r10, t.linear_r10_spread) if tolerance >= 0.10 else (t.linear_r5, t.linear_r5_spread)
    return lim - (spread if math.isfinite(spread) else 0.0)


# --------------------------------------------------------------------------------------------------
# predictors


def within(pred: np.ndarray, actual: np.ndarray, band: float = 0.25) -> np.ndarray:
    """|pred / actual - 1| <= band, elementwise."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.abs(np.asarray(pred, float) / np.asarray(actual, float) - 1.0) <= band


def rule_constant(k_sig: np.ndarray, r_lim: np.ndarray) -> float:
    """c of the rule k_sig r <= c: the median of k_sig r* over the families."""
    v = np.asarray(k_sig, float) * np.asarray(r_lim, float)
    v = v[np.isfinite(v)]
    return float(np.median(v)) if v.size else math.nan


def spearman(x: np.ndarray, y: np.ndarray) -> float:
    """Spearman rank correlation of the finite pairs, ties at their average rank (scipy); nan with fewer
    than 3 pairs or a constant variable."""
    from scipy.stats import spearmanr

    x, y = np.asarray(x, float), np.asarray(y, float)
    m = np.isfinite(x) & np.isfinite(y)
    if m.sum() < 3 or np.ptp(x[m]) == 0 or np.ptp(y[m]) == 0:
        return math.nan
    return float(spearmanr(x[m], y[m]).statistic)
