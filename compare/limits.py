"""Validity limits, pure analysis (used by the validity and tiers studies and the atlas): errors of the
quasi-static solution against the dynamic steady state, the largest speed ratio at which it stays within
a tolerance (:class:`Limit`, the first crossing on a ratio grid), and the harmonic rule.

Deflection d(theta) = (dx, dy) of the coupler point P [m] on a uniform full-turn crank-angle grid.
Speed ratio r = Omega / omega1_min [1].  Errors are dimensionless fractions:

* peak error      |max|d_qs| - max|d_dyn|| / max|d_dyn|   (the peak deflection magnitude)
* history error   max|d_qs - d_dyn| / max|d_dyn|           (the whole cycle: amplitude and phase)
* amplification   max|d_dyn| / max|d_qs|
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from compare import metrics
from ked_quasi.harmonics import harmonic_amplitudes, one_mode_dynamic_estimate

TOLERANCES = (0.05, 0.10)
ERROR_KINDS = ("peak", "history")


@dataclass(frozen=True)
class Errors:
    """Errors of one scene (dimensionless, see module docstring)."""

    peak: float
    history: float
    amplification: float

    def of(self, kind: str) -> float:
        return self.peak if kind == "peak" else self.history


def magnitude(d: np.ndarray) -> np.ndarray:
    """|d| (n,) [m] of a (n, 2) deflection history."""
    return np.hypot(d[:, 0], d[:, 1])


def errors(qs: np.ndarray, dyn: np.ndarray) -> Errors:
    """Peak and history errors (:mod:`compare.metrics`, vector |d|) and the amplification of ``dyn``
    against ``qs`` (both (n, 2) [m])."""
    if metrics.peak(dyn) <= 0.0:
        return Errors(math.nan, math.nan, math.nan)
    amp = metrics.amplification(qs, dyn)
    return Errors(peak=metrics.peak_error(qs, dyn), history=metrics.history_error(qs, dyn),
                  amplification=amp if math.isfinite(amp) else math.nan)


@dataclass(frozen=True)
class Limit:
    """Largest speed ratio below which the error stays under ``tolerance`` on a ratio grid.

    The limit is the **first crossing** of the tolerance walking up the grid, stated as ``r_limit``: the
    last grid ratio below it (the crossing lies in [r_limit, r_limit + ``step``)).  ``r_cross``, the value
    interpolated linearly in the error between ``r_pass`` and ``r_fail``, is kept for reference only and
    never reported as a limit: between two grid ratios a resonance peak can cross the tolerance unseen
    (interpolating across it overstates the limit).

    ``status``: "crossed" (error reaches the tolerance between ``r_pass`` and ``r_fail``),
    "below_grid" (already at the smallest ratio, ``r_fail``), "above_grid" (never reached up to
    ``r_pass``, the largest ratio), "failure" (the dynamic solver failed at ``r_fail`` before the error
    reached the tolerance; the limit is only known to be >= ``r_pass``), "no_data".
    """

    tolerance: float
    status: str
    r_pass: float = math.nan
    r_fail: float = math.nan
    r_cross: float = math.nan

    @property
    def r_limit(self) -> float:
        """The limit [1]: the last grid ratio below the first crossing (crossed), the largest ratio passed
        (above_grid: a lower bound; failure: a lower bound, nan if none passed); nan below the grid."""
        return self.r_pass if self.status in ("crossed", "above_grid", "failure") else math.nan

    @property
    def step(self) -> float:
        """Grid step [1] from ``r_limit`` to the first ratio at or above the tolerance (nan unless crossed)."""
        return self.r_fail - self.r_pass if self.status == "crossed" else math.nan

    @property
    def half_bracket(self) -> float:
        """Half width of the bracketing grid interval (the r-grid uncertainty) [1]."""
        return 0.5 * (self.r_fail - self.r_pass) if self.status == "crossed" else math.nan

    @property
    def r_record(self) -> float:
        """The value the atlas file stores as its r5 / r10 column [1]: ``r_cross`` (crossed: a record only,
        never reported), ``r_fail`` (below_grid), else ``r_pass``."""
        return {"crossed": self.r_cross, "below_grid": self.r_fail}.get(self.status, self.r_pass)

    @property
    def text(self) -> str:
        """The limit as a table states it: '0.060 (+0.020)' (crossed: the limit and the step to the first
        failing ratio), '>= 0.5' (never reached: a lower bound), '< 0.02' (already at the smallest ratio),
        '>= 0.1 (Exudyn failed at 0.2)' (ended by a failed dynamic run), '-' (no data)."""
        if self.status == "crossed":
            return f"{self.r_limit:.3f} (+{self.step:.3f})"
        if self.status == "above_grid":
            return f">= {self.r_pass:g}"
        if self.status == "below_grid":
            return f"< {self.r_fail:g}"
        if self.status == "failure" and math.isfinite(self.r_pass):
            return f">= {self.r_pass:g} (Exudyn failed at {self.r_fail:g})"
        return "-"


def validity_limit(r: Sequence[float], err: Sequence[float], ok: Sequence[bool], tolerance: float) -> Limit:
    """Walk up the ratio grid: the largest ratio below which every scene solved and had err < tol.

    ``r`` ratios, ``err`` errors (nan where failed), ``ok`` dynamic solution available.
    """
    order = np.argsort(np.asarray(r, float))
    if order.size == 0:
        return Limit(tolerance, "no_data")
    last_r, last_e = math.nan, math.nan
    for i in order:
        ri, ei = float(r[i]), float(err[i])
        if not ok[i] or not math.isfinite(ei):
            return Limit(tolerance, "failure", r_pass=last_r, r_fail=ri)
        if ei >= tolerance:
            if not math.isfinite(last_r):
                return Limit(tolerance, "below_grid", r_fail=ri)
            frac = (tolerance - last_e) / (ei - last_e)
            return Limit(tolerance, "crossed", r_pass=last_r, r_fail=ri,
                         r_cross=last_r + frac * (ri - last_r))
        last_r, last_e = ri, ei
    return Limit(tolerance, "above_grid", r_pass=last_r)


def crossing(r_lo: float, e_lo: float, r_hi: float, e_hi: float, tolerance: float) -> float:
    """Ratio at which the error, linear between two bracketing scenes, equals ``tolerance`` (nan if
    the pair does not bracket it)."""
    if not (math.isfinite(e_lo) and math.isfinite(e_hi)) or not (e_lo < tolerance <= e_hi):
        return math.nan
    return r_lo + (tolerance - e_lo) / (e_hi - e_lo) * (r_hi - r_lo)


# --------------------------------------------------------------------------------------------------
# harmonic rule


def harmonic_spectrum(signal: np.ndarray, k_max: int = 8) -> np.ndarray:
    """Amplitudes of harmonics 1..k_max, normalized by the largest of them [1]."""
    a = harmonic_amplitudes(signal)[1:k_max + 1]
    return a / a.max()


def one_mode_errors(qs: np.ndarray, r: float, damping: float) -> Errors:
    """Errors the one-mode estimate predicts at ratio ``r`` (each crank harmonic k of the quasi-static
    history amplified by 1 / (1 - (k r)^2 + 2 i zeta k r), omega1 taken as omega1_min;
    ``ked_quasi.harmonics.one_mode_dynamic_estimate``)."""
    est = one_mode_dynamic_estimate(qs, r, damping)
    return errors(qs, est)


def one_mode_curves(qs: np.ndarray, rs: np.ndarray, damping: float) -> dict[str, np.ndarray]:
    """Vectorized :func:`one_mode_errors` over ratios ``rs``: {"peak", "history", "amplification"}
    arrays (same estimate as ``ked_quasi.harmonics.one_mode_dynamic_estimate``)."""
    x = np.asarray(qs, dtype=float)
    n = x.shape[0]
    c = np.fft.rfft(x, axis=0)
    c[np.abs(c) < 1e-12 * np.abs(c).max()] = 0.0
    kr = np.asarray(rs, float)[:, None] * np.arange(c.shape[0])[None, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        H = 1.0 / (1.0 - kr**2 + 2j * damping * kr)
    est = np.fft.irfft(np.where(c[None] == 0, 0.0, H[:, :, None] * c[None]), n=n, axis=1)
    p_qs = magnitude(x).max()
    mag = np.hypot(est[..., 0], est[..., 1])
    p_dyn = mag.max(axis=1)
    diff = est - x[None]
    hist = np.hypot(diff[..., 0], diff[..., 1]).max(axis=1) / p_dyn
    return {"peak": np.abs(p_qs - p_dyn) / p_dyn, "history": hist, "amplification": p_dyn / p_qs}


def first_crossing(rs: np.ndarray, es: np.ndarray, tolerance: float) -> float:
    """Largest r of an ascending grid below which ``es`` < tolerance (linear interpolation at the
    first crossing; the last r if never reached, 0 if already at the first)."""
    bad = np.flatnonzero(~(es < tolerance))
    if not bad.size:
        return float(rs[-1])
    i = int(bad[0])
    if i == 0:
        return 0.0
    c = crossing(float(rs[i - 1]), float(es[i - 1]), float(rs[i]), float(es[i]), tolerance)
    return c if math.isfinite(c) else float(rs[i - 1])


def one_mode_limit(qs: np.ndarray, tolerance: float, damping: float, kind: str,
                   r_max: float = 1.2, n: int = 1200) -> float:
    """Largest r (grid of ``n`` points up to ``r_max``) below which the one-mode estimate keeps the
    error of ``kind`` under ``tolerance``; linear interpolation at the crossing."""
    rs = np.linspace(r_max / n, r_max, n)
    return first_crossing(rs, one_mode_curves(qs, rs, damping)[kind], tolerance)


# --------------------------------------------------------------------------------------------------
# small helpers for tables


def peak_ratio(a: float, b: float) -> float:
    """a / b, nan if either is missing or b is 0."""
    return a / b if (math.isfinite(a) and math.isfinite(b) and b != 0) else math.nan


def peak_of(d: np.ndarray | None) -> float:
    """max |d| [m] of a (n, 2) history, nan if absent."""
    return float(magnitude(d).max()) if d is not None else math.nan
