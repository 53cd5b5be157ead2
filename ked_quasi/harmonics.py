"""Crank-harmonic content of periodic signals and a one-mode estimate of the quasi-static error.

At constant crank speed Omega every inertia load is periodic in the crank angle, so it is a sum of
crank harmonics k*Omega.  If the structure's response is dominated by its first mode (frequency
omega1), harmonic k of the quasi-static deflection is amplified dynamically by
H(k r) = 1 / (1 - (k r)^2 + 2 i zeta k r), r = Omega / omega1.  The quasi-static answer is good while
the significant harmonics stay well below omega1: this module makes that rule quantitative.
"""

from __future__ import annotations

import numpy as np


def harmonic_amplitudes(signal: np.ndarray) -> np.ndarray:
    """Amplitude of each crank harmonic k = 0..n//2 of a signal sampled on a uniform full-turn grid.

    ``signal`` (n, ...) with n samples over 0 <= theta < 2 pi; returns (n//2 + 1,) amplitudes, the
    Euclidean norm over the trailing axes (e.g. all nodes and components of a load history).
    """
    x = np.asarray(signal, dtype=float)
    n = x.shape[0]
    c = np.fft.rfft(x, axis=0) / n
    c[1:] *= 2.0
    if n % 2 == 0:
        c[-1] /= 2.0
    return np.sqrt((np.abs(c) ** 2).reshape(c.shape[0], -1).sum(axis=1))


def significant_harmonic(signal: np.ndarray, fraction: float = 0.01) -> int:
    """Highest crank harmonic k >= 1 whose amplitude is at least ``fraction`` of the largest k >= 1."""
    a = harmonic_amplitudes(signal)[1:]
    return int(np.flatnonzero(a >= fraction * a.max()).max()) + 1


def one_mode_dynamic_estimate(quasi_static: np.ndarray, speed_ratio: float, damping_ratio: float = 0.0) -> np.ndarray:
    """Steady-state response estimated from a quasi-static history by amplifying each harmonic k by
    1 / (1 - (k r)^2 + 2 i zeta k r).  quasi_static (n, ...) on a uniform full-turn grid; r = Omega/omega1."""
    x = np.asarray(quasi_static, dtype=float)
    n = x.shape[0]
    c = np.fft.rfft(x, axis=0)
    c[np.abs(c) < 1e-12 * np.abs(c).max()] = 0.0  # round-off content is not excited
    kr = np.arange(c.shape[0]) * speed_ratio
    with np.errstate(divide="ignore", invalid="ignore"):
        H = (1.0 / (1.0 - kr**2 + 2j * damping_ratio * kr)).reshape((-1,) + (1,) * (x.ndim - 1))
        amplified = np.where(c == 0, 0.0, c * H)
    return np.fft.irfft(amplified, n=n, axis=0)


def one_mode_error(quasi_static: np.ndarray, speed_ratio: float, damping_ratio: float = 0.0) -> float:
    """Predicted relative error of the quasi-static peak: max|est - qs| / max|est| (one-mode estimate)."""
    est = one_mode_dynamic_estimate(quasi_static, speed_ratio, damping_ratio)
    return float(np.abs(est - quasi_static).max() / np.abs(est).max())


def predicted_validity_limit(quasi_static: np.ndarray, tolerance: float, damping_ratio: float = 0.0,
                             r_max: float = 1.2) -> float:
    """Largest speed ratio r (on a fine grid up to r_max) below which the one-mode estimate keeps the
    quasi-static error under ``tolerance``."""
    rs = np.linspace(1e-3, r_max, 1200)
    errs = np.array([one_mode_error(quasi_static, r, damping_ratio) for r in rs])
    bad = np.flatnonzero(errs >= tolerance)
    return float(rs[bad[0] - 1]) if bad.size and bad[0] > 0 else (float(rs[-1]) if not bad.size else 0.0)
