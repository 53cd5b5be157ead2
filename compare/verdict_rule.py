"""The design check's quasi-static call from its prediction, stated once (numpy only: ``ked check``
imports it at start-up, :mod:`compare.atlas.calibration` measures it against Exudyn).

With e the predicted quasi-static error [1] (quasi-static vs linear), r the speed ratio [1] and r_linear
the linear model's lower-band limit [1], for a tolerance ``tol`` and margins ``holds_below`` <=
``fails_above`` (multipliers of ``tol``), :func:`calls` says

* "quasi-static" where e < holds_below x tol and the linear model is inside its own range there (a linear
  solution without flags and r < r_linear; r_linear nan: unknown, never granted),
* "borderline" where holds_below x tol <= e < fails_above x tol inside that range,
* "not quasi-static" otherwise.

:func:`compare.check.tier` grants its quasi-static tier exactly where this says quasi-static; its
borderline tier is wider than this one (e = fails_above x tol, and e <= fails_above x tol outside the
linear range, are borderline there, not quasi-static here): both are "not granted", so the calibrated
unsafe rate is the check's.
"""

from __future__ import annotations

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


def stratum(kind: str, mass_model: str, mechanism: str) -> str:
    """The calibration stratum of a scene: linkage kind x mass model x mechanism (e.g.
    ``four-bar/distributed/cognate``); margins are calibrated and published per stratum, never pooled."""
    return f"{kind}/{mass_model}/{mechanism}"
