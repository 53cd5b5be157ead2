"""The design check's quasi-static call from its prediction, stated once (numpy only: ``ked check``
imports it at start-up, :mod:`ked_research.atlas.calibration` measures it against Exudyn).

With e the predicted quasi-static error [1] (quasi-static vs linear), r the speed ratio [1] and r_linear
the linear model's lower-band limit [1], for a tolerance ``tol`` and margins ``holds_below`` <=
``fails_above`` (multipliers of ``tol``), :func:`calls` says

* "quasi-static" where e < holds_below x tol and the linear model is inside its own range there (a linear
  solution without flags and r < r_linear; r_linear nan: unknown, never granted),
* "borderline" where holds_below x tol <= e < fails_above x tol inside that range,
* "not quasi-static" otherwise.

:func:`ked_check.check.tier` grants its quasi-static tier exactly where this says quasi-static; its
borderline tier is wider than this one (e = fails_above x tol, and e <= fails_above x tol outside the
linear range, are borderline there, not quasi-static here): both are "not granted", so the calibrated
unsafe rate is the check's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

QUASI_STATIC, BORDERLINE, NOT_QUASI_STATIC = 0, 1, 2
CALL_NAMES = ("quasi-static", "borderline", "not quasi-static")


def calls(e: np.ndarray, r: np.ndarray, r_linear: np.ndarray, linear_ok: np.ndarray, tolerance: float,
          holds_below: float, fails_above: float) -> np.ndarray:
    """The call (:data:`QUASI_STATIC`, :data:`BORDERLINE`, :data:`NOT_QUASI_STATIC`) per scene.

    ``e`` predicted error [1] (quasi-static vs linear), ``r`` speed ratio [1], ``r_linear`` the lower-band
    linear limit at each scene [1] (nan: unknown, the quasi-static tier is not granted), ``linear_ok`` a
    linear solution without flags; ``holds_below`` / ``fails_above`` multipliers of ``tolerance``."""
    e, r, r_lin = (np.asarray(x, float) for x in (e, r, r_linear))
    inside = np.asarray(linear_ok, bool) & np.isfinite(e) & np.isfinite(r_lin) & (r < r_lin)
    out = np.full(e.shape, NOT_QUASI_STATIC, dtype=int)
    out[inside & (e < fails_above * tolerance)] = BORDERLINE
    out[inside & (e < holds_below * tolerance)] = QUASI_STATIC
    return out


@dataclass(frozen=True)
class VerdictMargins:
    """Where a predicted quasi-static error decides, in one stratum (:func:`stratum`): below ``holds_below`` x
    tolerance the call is quasi-static, above ``fails_above`` x tolerance it is not, in between borderline
    (multipliers [1] of the tolerance, :func:`calls`).  The statistics of that rule at the atlas's threshold
    (``n_scenes`` Exudyn-confirmed scenes; rates and their 95 % Clopper-Pearson bounds as fractions [1]: the
    unsafe calls, the overcautious ones, the agreement) and ``source``, where the numbers come from.  The default
    is a stratum without calibration: ``holds_below`` 0 (a prediction never grants the quasi-static tier),
    ``fails_above`` 1.4, statistics NaN."""

    holds_below: float = 0.0
    fails_above: float = 1.4
    n_scenes: int = 0
    unsafe_rate: float = math.nan
    unsafe_upper95: float = math.nan
    overcautious_rate: float = math.nan
    overcautious_upper95: float = math.nan
    agreement: float = math.nan
    agreement_low95: float = math.nan
    agreement_high95: float = math.nan
    source: str = "not calibrated against Exudyn for this stratum"

    def __post_init__(self) -> None:
        if not (0.0 <= self.holds_below <= 1.0 <= self.fails_above and math.isfinite(self.fails_above)):
            raise ValueError(f"verdict margins: need 0 <= holds_below <= 1 <= fails_above, got "
                             f"{self.holds_below!r}, {self.fails_above!r}")

    @property
    def calibrated(self) -> bool:
        """Whether the prediction may grant the quasi-static tier in this stratum."""
        return self.holds_below > 0.0


UNCALIBRATED = VerdictMargins()
"""The margins of a stratum without calibration (the default of every function that takes margins)."""


def from_record(rec: dict) -> VerdictMargins:
    """The margins of a stored or published record (field -> value; null / absent statistics NaN).  Raises
    KeyError, TypeError or ValueError for a record without valid multipliers."""

    def num(k: str) -> float:
        v = rec.get(k)
        return float(v) if isinstance(v, (int, float)) else math.nan

    stats = ("unsafe_rate", "unsafe_upper95", "overcautious_rate", "overcautious_upper95", "agreement",
             "agreement_low95", "agreement_high95")
    return VerdictMargins(holds_below=float(rec["holds_below"]), fails_above=float(rec["fails_above"]),
                          n_scenes=int(rec.get("n_scenes") or 0), **{k: num(k) for k in stats},
                          source=str(rec.get("source", "")))


def stratum(kind: str, mass_model: str, mechanism: str) -> str:
    """The calibration stratum of a scene: linkage kind x mass model x mechanism (e.g.
    ``four-bar/distributed/cognate``); margins are calibrated and published per stratum, never pooled."""
    return f"{kind}/{mass_model}/{mechanism}"
