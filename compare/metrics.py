"""Comparison metrics between quasi-static and dynamic coupler-point deflection histories.

Pure functions on arrays sampled on one uniform, periodic crank-angle grid (one full cycle,
``theta_k = theta_0 + k * step``, the last sample not repeating the first).  Units follow the
component: dx, dy in m, rotation in rad; ratios are dimensionless; angles in rad.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from compare.scenes import COMPONENT_UNITS


@dataclass(frozen=True)
class ComponentMetrics:
    """Agreement of one deflection component over one cycle.

    - ``max_abs_error`` [unit]: max_k |dyn_k - qs_k|
    - ``rms_error`` [unit]: sqrt(mean_k (dyn_k - qs_k)^2)
    - ``relative_error`` [1]: max_abs_error / dynamic_peak (inf if the dynamic peak is 0 and the error
      is not, 0 if both are 0)
    - ``phase_shift`` [rad]: time lag of the dynamic peak behind the quasi-static peak, wrapped to
      (-pi, pi]; positive = the dynamic peak comes later in the cycle (sub-grid parabolic estimate)
    - ``amplification`` [1]: dynamic_peak / quasi_static_peak
    - ``dynamic_peak``, ``quasi_static_peak`` [unit]: max_k |.|
    - ``holds`` : relative_error < tolerance
    """

    component: str
    units: str
    max_abs_error: float
    rms_error: float
    relative_error: float
    phase_shift: float
    amplification: float
    dynamic_peak: float
    quasi_static_peak: float
    holds: bool


@dataclass(frozen=True)
class SceneMetrics:
    """Scene-level summary.

    ``omega`` [rad/s] crank speed magnitude, ``omega1_min`` [rad/s] lowest first natural circular
    frequency over the cycle, ``speed_ratio`` = omega / omega1_min [1], ``tolerance`` [1] on the
    relative error, ``holds`` = every component holds (the quasi-static assumption is accepted),
    ``max_relative_error`` [1] over the components.
    """

    omega: float
    omega1_min: float
    speed_ratio: float
    tolerance: float
    components: tuple[ComponentMetrics, ...]

    @property
    def holds(self) -> bool:
        return all(c.holds for c in self.components)

    @property
    def max_relative_error(self) -> float:
        return max((c.relative_error for c in self.components), default=float("nan"))

    @property
    def max_amplification(self) -> float:
        return max((c.amplification for c in self.components), default=float("nan"))

    def component(self, name: str) -> ComponentMetrics:
        for c in self.components:
            if c.component == name:
                return c
        raise KeyError(name)


def max_abs_error(qs: np.ndarray, dyn: np.ndarray) -> float:
    """max |dyn - qs| [unit of the inputs]."""
    return float(np.max(np.abs(np.asarray(dyn) - np.asarray(qs))))


def rms_error(qs: np.ndarray, dyn: np.ndarray) -> float:
    """Root-mean-square of dyn - qs over the cycle [unit of the inputs]."""
    d = np.asarray(dyn) - np.asarray(qs)
    return float(np.sqrt(np.mean(d * d)))


def peak(y: np.ndarray) -> float:
    """max |y| [unit of y]."""
    return float(np.max(np.abs(np.asarray(y))))


def safe_ratio(num: float, den: float) -> float:
    """num / den with 0/0 -> 0 and x/0 -> inf (both non-negative here)."""
    if den == 0.0:
        return 0.0 if num == 0.0 else math.inf
    return num / den


def relative_error(qs: np.ndarray, dyn: np.ndarray) -> float:
    """max |dyn - qs| / max |dyn| [1]."""
    return safe_ratio(max_abs_error(qs, dyn), peak(dyn))


def amplification(qs: np.ndarray, dyn: np.ndarray) -> float:
    """Dynamic amplification max |dyn| / max |qs| [1]."""
    return safe_ratio(peak(dyn), peak(qs))


def peak_angle(crank_angle: np.ndarray, y: np.ndarray) -> float:
    """Crank angle [rad] of the peak of |y| on a uniform periodic grid, refined by a parabola
    through the peak sample and its two (periodic) neighbours."""
    theta = np.asarray(crank_angle, dtype=float)
    a = np.abs(np.asarray(y, dtype=float))
    n = a.size
    k = int(np.argmax(a))
    if n < 3:
        return float(theta[k])
    step = (theta[-1] - theta[0]) / (n - 1)
    ym, y0, yp = a[(k - 1) % n], a[k], a[(k + 1) % n]
    den = ym - 2.0 * y0 + yp
    delta = 0.0 if den == 0.0 else 0.5 * (ym - yp) / den
    return float(theta[k] + max(-0.5, min(0.5, delta)) * step)


def wrap_angle(x: float) -> float:
    """Wrap an angle [rad] to (-pi, pi]."""
    y = math.fmod(x + math.pi, 2.0 * math.pi)
    if y <= 0.0:
        y += 2.0 * math.pi
    return y - math.pi


def phase_shift(crank_angle: np.ndarray, qs: np.ndarray, dyn: np.ndarray, direction_sign: int = 1) -> float:
    """Time lag [rad of crank rotation] of the dynamic peak behind the quasi-static peak, in (-pi, pi].

    ``direction_sign`` is +1 for ccw (crank angle grows with time) and -1 for cw.
    """
    shift = peak_angle(crank_angle, dyn) - peak_angle(crank_angle, qs)
    return wrap_angle(direction_sign * shift)


def component_metrics(
    component: str,
    crank_angle: np.ndarray,
    qs: np.ndarray,
    dyn: np.ndarray,
    tolerance: float,
    direction_sign: int = 1,
) -> ComponentMetrics:
    """All metrics of one component (see :class:`ComponentMetrics`)."""
    qs = np.asarray(qs, dtype=float)
    dyn = np.asarray(dyn, dtype=float)
    if qs.shape != dyn.shape or qs.shape != np.shape(crank_angle):
        raise ValueError(f"shape mismatch: crank_angle {np.shape(crank_angle)}, qs {qs.shape}, dyn {dyn.shape}")
    if not (np.all(np.isfinite(qs)) and np.all(np.isfinite(dyn))):
        raise ValueError(f"non-finite deflection values in component {component!r}")
    rel = relative_error(qs, dyn)
    return ComponentMetrics(
        component=component,
        units=COMPONENT_UNITS[component],
        max_abs_error=max_abs_error(qs, dyn),
        rms_error=rms_error(qs, dyn),
        relative_error=rel,
        phase_shift=phase_shift(crank_angle, qs, dyn, direction_sign),
        amplification=amplification(qs, dyn),
        dynamic_peak=peak(dyn),
        quasi_static_peak=peak(qs),
        holds=bool(rel < tolerance),
    )


def scene_metrics(
    crank_angle: np.ndarray,
    quasi_static: dict[str, np.ndarray],
    dynamic: dict[str, np.ndarray],
    *,
    omega: float,
    omega1_min: float,
    tolerance: float,
    direction_sign: int = 1,
) -> SceneMetrics:
    """Metrics of every component present in both ``quasi_static`` and ``dynamic`` (same order as
    ``quasi_static``).  ``omega``, ``omega1_min`` in rad/s."""
    comps = tuple(
        component_metrics(c, crank_angle, quasi_static[c], dynamic[c], tolerance, direction_sign)
        for c in quasi_static
        if c in dynamic
    )
    return SceneMetrics(
        omega=float(abs(omega)),
        omega1_min=float(omega1_min),
        speed_ratio=safe_ratio(abs(omega), omega1_min),
        tolerance=float(tolerance),
        components=comps,
    )
