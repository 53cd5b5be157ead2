"""Critical speeds of a linkage: the crank speeds where its free vibrations are least damped.

Over a speed range the largest |Floquet multiplier| of the linear model peaks at the parametric
resonances (a crank harmonic of the varying stiffness meeting twice a frozen natural frequency, or a
sum of two): those local maxima are the **critical speeds**, where a real linkage rings longest and a
time-marching model settles slowest or never.  The local maxima of the amplification (linear peak over
quasi-static peak) are the forced resonances; both are listed.

:func:`critical_speeds` is a pure function of the sampled speeds and max |mu|, optionally refined by a
callable (the Floquet part of the linear model alone, cheap: no periodic solve): a finer sweep between
the samples, then a search by Brent's method on each local maximum.  :func:`floquet_max_abs` is that
callable for a campaign scene.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

NEAR = 0.05
"""A speed within this fraction of a critical speed is "near" it (the verdict says so)."""


@dataclass(frozen=True)
class CriticalSpeed:
    """A local maximum of max |Floquet multiplier| over crank speed: rpm [rev/min], max_abs [1]."""

    rpm: float
    max_abs: float


PROMINENCE = 0.01
"""Least prominence of a local maximum of max |mu| counted as a critical speed (its height above the
higher of the two minima that separate it from higher ground, scipy's definition): bumps smaller than
this are within the Floquet tolerances and mean nothing to a designer."""


def local_maxima(x: Sequence[float], y: Sequence[float], prominence: float = 0.0) -> list[int]:
    """Indices of the interior local maxima of y(x) (x increasing) with at least ``prominence``
    (``scipy.signal.find_peaks``; a plateau counts once, at its middle); NaN values count as the lowest."""
    from scipy.signal import find_peaks

    y = np.asarray(y, dtype=float)
    if not np.any(np.isfinite(y)):
        return []
    filled = np.where(np.isfinite(y), y, np.nanmin(y) - 1.0)
    return [int(i) for i in find_peaks(filled, prominence=prominence)[0]]


def _golden(f: Callable[[float], float], a: float, b: float, c: float, fb: float, xtol: float) -> tuple[float, float]:
    """Maximum of f on [a, c] bracketed by b (f(b) >= f(a), f(c)), golden-section search to ``xtol``."""
    g = (3.0 - math.sqrt(5.0)) / 2.0
    while c - a > xtol:
        x = b + g * (c - b) if c - b > b - a else b - g * (b - a)
        fx = f(x)
        if not math.isfinite(fx):
            break
        if fx > fb:
            a, c = (b, c) if x > b else (a, b)
            b, fb = x, fx
        else:
            a, c = (a, x) if x > b else (x, c)
    return b, fb


def _refine(f: Callable[[float], float], a: float, b: float, c: float, fa: float, fb: float, fc: float,
            rtol: float) -> tuple[float, float]:
    """Maximum of f on [a, c] bracketed by b (f(b) > f(a), f(c): the values given, not evaluated again):
    Brent's method (``scipy.optimize``: parabolic steps, golden-section ones where they do not pay) until
    the bracket is below ``rtol`` of the speed, the criterion of :func:`_golden`, which a bracket that is
    not strict (a plateau) or a failed evaluation falls back to.  Measured on the Floquet sweeps: 4 to 8
    evaluations per maximum where the golden section takes 6 to 9, and closer to the peak."""
    from scipy.optimize import minimize_scalar

    known = {a: fa, b: fb, c: fc}
    best = [b, fb]

    def negative(x: float) -> float:
        y = known[x] if x in known else f(x)
        if not math.isfinite(y):
            raise ArithmeticError(x)
        if y > best[1]:
            best[:] = [x, y]
        return -y

    if not (fb > fa and fb > fc):
        return _golden(f, a, b, c, fb, rtol * b)
    try:
        # scipy's brent stops once its bracket is below 4 xtol |x| (tol1 = xtol |x|, |x - mid| <= 2 tol1 - half)
        minimize_scalar(negative, bracket=(a, b, c), method="brent", options={"xtol": rtol / 4.0})
    except ArithmeticError:
        pass
    return best[0], best[1]


def fine_speeds(rpms: Sequence[float], fine: int = 4) -> np.ndarray:
    """The speeds the sweep adds: ``fine`` - 1 evenly between each pair of neighbouring samples (sorted)."""
    x = np.sort(np.asarray(rpms, dtype=float))
    if x.size < 2 or fine <= 1:
        return np.zeros(0)
    return np.concatenate([np.linspace(a, b, fine + 1)[1:-1] for a, b in zip(x[:-1], x[1:])])


def critical_speeds(rpms: Sequence[float], max_abs: Sequence[float],
                    floquet: Callable[[float], float] | None = None, fine: int = 4,
                    rpm_tol: float = 2e-3, prominence: float = PROMINENCE) -> tuple[CriticalSpeed, ...]:
    """The critical speeds (local maxima of max |mu|) of the samples ``rpms`` [rev/min] (any order) and
    their ``max_abs``.  With ``floquet`` (rpm -> max |mu|): ``fine`` - 1 more speeds between neighbouring
    samples first, then each local maximum of at least ``prominence`` refined (Brent's method,
    :func:`_refine`) to ``rpm_tol`` of its speed.
    A maximum at either end of the range is no critical speed (its peak may lie outside)."""
    order = np.argsort(np.asarray(rpms, dtype=float))
    x = np.asarray(rpms, dtype=float)[order]
    y = np.asarray(max_abs, dtype=float)[order]
    if floquet is not None and x.size >= 2 and fine > 1:
        extra = fine_speeds(x, fine)
        x = np.concatenate([x, extra])
        y = np.concatenate([y, [floquet(float(r)) for r in extra]])
        order = np.argsort(x)
        x, y = x[order], y[order]
    found = []
    for i in local_maxima(x, y, prominence):
        r, m = float(x[i]), float(y[i])
        if floquet is not None:
            r, m = _refine(floquet, float(x[i - 1]), r, float(x[i + 1]), float(y[i - 1]), m, float(y[i + 1]), rpm_tol)
        found.append(CriticalSpeed(rpm=r, max_abs=m))
    return tuple(found)


def amplification_peaks(rpms: Sequence[float], amplification: Sequence[float]) -> tuple[float, ...]:
    """Speeds [rev/min] of the interior local maxima of the amplification (linear / quasi-static peak)."""
    order = np.argsort(np.asarray(rpms, dtype=float))
    x = np.asarray(rpms, dtype=float)[order]
    return tuple(float(x[i]) for i in local_maxima(x, np.asarray(amplification, dtype=float)[order]))


def near(rpm: float, speeds: Sequence[float], fraction: float = NEAR) -> float | None:
    """The critical speed within ``fraction`` of ``rpm`` (the closest), or None."""
    close = [s for s in speeds if abs(rpm - s) <= fraction * s]
    return min(close, key=lambda s: abs(rpm - s)) if close else None


SWEEP_STEPS = 2048
"""Propagator steps per cycle of the sweep: one fixed count at every speed, so that the discretization
error varies smoothly with speed and moves no maximum (the automatic count of each linear solve can
differ from one speed to the next by a factor 2 and its result by its error estimate, ~0.005)."""


def floquet_max_abs(spec: object, steps: int = SWEEP_STEPS) -> Callable[[float], float]:
    """rpm -> max |Floquet multiplier| of the linear model of a campaign scene (``compare.scenes.SceneSpec``)
    at that speed, with the scene's linear settings and ``steps`` per cycle: only the Floquet part (no
    periodic solve).  With the default ``steps``, the reduced system's converged value where
    ``ked_linear.solver.reduced_stability`` gives one (damped four-bar models of
    ``ked_linear.solver.REDUCE_FROM`` coordinates or more, where the reduction vouches for half the Floquet
    tolerance: its error, ~1e-4, is below the fixed-step one's, so it moves no maximum either), else the
    full model at ``steps``."""
    from compare.execute import settings_of
    from compare.solvers import get as get_solver
    from ked_linear import linkage_system, multipliers
    from ked_linear.solver import reduced_stability

    settings = settings_of(get_solver("linear"), spec)

    def f(rpm: float) -> float:
        scene = spec.scene(rpm)
        system = linkage_system(scene, settings).system
        red = reduced_stability(scene, system, settings) if steps == SWEEP_STEPS else None
        if red is not None:
            return red.max_abs
        return float(np.abs(multipliers(system, steps)[0]))

    return f


def mark_near(rows: Sequence[object], speeds: Sequence[CriticalSpeed]) -> list[object]:
    """The check rows (``compare.check.CheckRow``), each verdict near a critical speed saying so."""
    from dataclasses import replace

    out = []
    for row in rows:
        s = near(row.rpm, [c.rpm for c in speeds])
        if s is not None:
            mu = next(c.max_abs for c in speeds if c.rpm == s)
            row = replace(row, verdict=f"{row.verdict}; within {NEAR:.0%} of the critical speed {s:.4g} rpm (a local "
                                       f"maximum of max |Floquet multiplier|, {mu:.3g}: free vibrations least damped, "
                                       "keep the operating speed away from it)")
        out.append(row)
    return out


def check_critical(rows: Sequence[object], source: object, mechanism: str, mass_model: object, bar: Any = None,
                   **spec_kw: object) -> tuple[tuple[CriticalSpeed, ...], tuple[float, ...], list[object]]:
    """For the rows of a design check (:func:`compare.check.check`, same linkage and keywords of
    :func:`compare.check.spec_for`): its critical speeds (refined with the Floquet part alone), the
    amplification peaks, and the rows with the verdicts near a critical speed annotated.  ``bar``: a
    progress bar (``compare.check.progress``) advanced per Floquet evaluation."""
    from compare.check import advance, spec_for
    from ked_linear.solver import single_threaded_blas

    spec = spec_for(source, mechanism, mass_model, rows[0].rpm, **spec_kw)
    rpms = [r.rpm for r in rows]
    sweep = floquet_max_abs(spec)

    def f(rpm: float) -> float:
        if bar is not None:
            bar.set_postfix_str(f"critical speeds, {rpm:.4g} rpm")
        value = sweep(rpm)
        if bar is not None:
            advance(bar)
        return value

    # one BLAS thread, as in solve_linear: the evaluations are small batched calls where threads only cost
    # (measured on the loaded 2-core machine: the sweep 3-8x slower with threads)
    with single_threaded_blas():
        crit = critical_speeds(rpms, [f(r) for r in rpms], f)
    amp = amplification_peaks(rpms, [r.linear_peak_m / r.quasi_static_peak_m if r.quasi_static_peak_m > 0
                                     else math.nan for r in rows])
    return crit, amp, mark_near(rows, crit)


def sweep_evaluations(rows: Sequence[object], fine: int = 4) -> int:
    """Floquet evaluations :func:`check_critical` makes on ``rows`` before refining its maxima: the rows'
    speeds and the fine ones."""
    return len(rows) + fine_speeds([r.rpm for r in rows], fine).size
