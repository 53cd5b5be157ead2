"""The metrics: how far one solver's coupler-point deflection history is from another's.

Every error the harness reports is defined here, once.  Histories are sampled on one uniform,
periodic crank-angle grid (one full cycle, the last sample not repeating the first).  A *component*
is ``dx``, ``dy`` [m], ``rotation`` [rad], or ``vector``: the deflection vector d = (dx, dy) [m],
whose size is |d|.  For a solver history ``a`` measured against a reference ``b``:

* ``history_error``  max_k |a_k - b_k| / max_k |b_k|   (the whole cycle: amplitude and phase; for
  ``vector``, |.| is the vector norm)
* ``peak_error``     |max_k |a_k| - max_k |b_k|| / max_k |b_k|   (the peak only)
* ``max_abs_error``  max_k |a_k - b_k|, ``rms_error`` sqrt(mean_k (a_k - b_k)^2) [unit]
* ``amplification``  max_k |b_k| / max_k |a_k|   (reference over solver: the dynamic amplification
  when the solver is quasi-static and the reference dynamic)
* ``phase_shift``    time lag [rad of crank rotation] of the reference's peak behind the solver's

The **verdict** of a scene (``ked run``'s "holds"/"FAILS", ``ked check``'s tiers, the studies and the
atlas) uses one measure, :data:`VERDICT_METRIC`: the ``vector`` history error of the quasi-static
deflection d = (dx, dy) of P against the scene's reference (the highest-fidelity solver that ran),
max_k |d_k - d_ref,k| / max_k |d_ref,k| (independent of the frame), compared with the tolerance.  The
rotation's error is reported as its own number and never enters a verdict.  (Before this measure the
campaign verdict used the worst history error of dx, dy and rotation; that number is still available as
:attr:`PairMetrics.worst_component_error`.)  A pair without both dx and dy (a campaign whose outputs
lack one) is judged on the translation component it has; with neither it has no verdict error (NaN)
and does not hold.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from compare.solvers import COMPONENT_UNITS, COMPONENTS, STRESS_PREFIX

VECTOR = "vector"
VERDICT_METRIC = "history error of the deflection vector (dx, dy)"
"""What the verdict of a scene compares with the tolerance (see the module docstring)."""


def vector(history: Mapping[str, np.ndarray]) -> np.ndarray | None:
    """(n, 2) deflection vector (dx, dy) of P [m] from a component -> history mapping; None without both."""
    if "dx" not in history or "dy" not in history:
        return None
    return np.column_stack([np.asarray(history["dx"], dtype=float), np.asarray(history["dy"], dtype=float)])


def safe_ratio(num: float, den: float) -> float:
    """num / den with 0/0 -> 0 and x/0 -> inf (both non-negative here)."""
    if den == 0.0:
        return 0.0 if num == 0.0 else math.inf
    return num / den


def size(y: np.ndarray) -> np.ndarray:
    """|y_k| (n,): absolute value of a (n,) history, vector norm of a (n, 2) one (for stress see
    :func:`stress_metrics`)."""
    y = np.asarray(y, dtype=float)
    return np.abs(y) if y.ndim == 1 else np.hypot(y[:, 0], y[:, 1])


def is_stress(component: str) -> bool:
    """Whether a component is a link's stress (``stress_<link>``)."""
    return component.startswith(STRESS_PREFIX)


def peak(y: np.ndarray) -> float:
    """max_k |y_k| [unit of y]."""
    return float(np.max(size(y)))


def max_abs_error(a: np.ndarray, b: np.ndarray) -> float:
    """max_k |a_k - b_k| [unit of the inputs]."""
    return peak(np.asarray(a, dtype=float) - np.asarray(b, dtype=float))


def rms_error(a: np.ndarray, b: np.ndarray) -> float:
    """Root-mean-square of |a_k - b_k| over the cycle [unit of the inputs]."""
    return float(np.sqrt(np.mean(size(np.asarray(a, dtype=float) - np.asarray(b, dtype=float)) ** 2)))


def history_error(a: np.ndarray, b: np.ndarray) -> float:
    """max_k |a_k - b_k| / max_k |b_k| [1] (``b`` the reference)."""
    return safe_ratio(max_abs_error(a, b), peak(b))


def peak_error(a: np.ndarray, b: np.ndarray) -> float:
    """|max_k |a_k| - max_k |b_k|| / max_k |b_k| [1] (``b`` the reference)."""
    return safe_ratio(abs(peak(a) - peak(b)), peak(b))


def amplification(a: np.ndarray, b: np.ndarray) -> float:
    """max_k |b_k| / max_k |a_k| [1]: the reference's peak over the solver's."""
    return safe_ratio(peak(b), peak(a))


def peak_angle(crank_angle: np.ndarray, y: np.ndarray) -> float:
    """Crank angle [rad] of the peak of |y| on a uniform periodic grid, refined by a parabola
    through the peak sample and its two (periodic) neighbours."""
    theta = np.asarray(crank_angle, dtype=float)
    a = size(y)
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


def phase_shift(crank_angle: np.ndarray, a: np.ndarray, b: np.ndarray, direction_sign: int = 1) -> float:
    """Time lag [rad of crank rotation] of the peak of ``b`` behind the peak of ``a``, in (-pi, pi].

    ``direction_sign`` is +1 for ccw (crank angle grows with time) and -1 for cw.
    """
    return wrap_angle(direction_sign * (peak_angle(crank_angle, b) - peak_angle(crank_angle, a)))


@dataclass(frozen=True)
class ComponentMetrics:
    """Every metric of one component (see the module docstring); ``solver_peak``/``reference_peak``
    = max_k |a_k| / max_k |b_k| [unit]; ``holds``: history_error < tolerance."""

    component: str
    units: str
    history_error: float
    peak_error: float
    max_abs_error: float
    rms_error: float
    phase_shift: float
    amplification: float
    solver_peak: float
    reference_peak: float
    holds: bool


def component_metrics(component: str, crank_angle: np.ndarray, a: np.ndarray, b: np.ndarray, tolerance: float,
                      direction_sign: int = 1) -> ComponentMetrics:
    """All metrics of one component: ``a`` the solver's history, ``b`` the reference's ((n,), or (n, 2)
    for ``vector``)."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if a.shape != b.shape or a.shape[0] != np.shape(crank_angle)[0]:
        raise ValueError(f"shape mismatch: crank_angle {np.shape(crank_angle)}, {a.shape}, {b.shape}")
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
        raise ValueError(f"non-finite deflection values in component {component!r}")
    h = history_error(a, b)
    return ComponentMetrics(
        component=component, units=COMPONENT_UNITS.get(component, "m"), history_error=h,
        peak_error=peak_error(a, b), max_abs_error=max_abs_error(a, b), rms_error=rms_error(a, b),
        phase_shift=phase_shift(crank_angle, a, b, direction_sign), amplification=amplification(a, b),
        solver_peak=peak(a), reference_peak=peak(b), holds=bool(h < tolerance),
    )


def stress_metrics(component: str, crank_angle: np.ndarray, a: np.ndarray, b: np.ndarray, tolerance: float,
                   direction_sign: int = 1) -> ComponentMetrics:
    """All metrics of a link's stress ``stress_<link>``: ``a``, ``b`` (n, 2) fibre stresses [Pa] (largest,
    smallest) of the solver and the reference; |.| the larger fibre magnitude (see the module docstring)."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if a.shape != b.shape or a.ndim != 2 or a.shape[0] != np.shape(crank_angle)[0]:
        raise ValueError(f"shape mismatch in {component!r}: crank_angle {np.shape(crank_angle)}, {a.shape}, {b.shape}")
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
        raise ValueError(f"non-finite stress values in component {component!r}")
    ea, eb, ediff = (np.max(np.abs(x), axis=1) for x in (a, b, a - b))  # envelopes over the two fibres (n,)
    h = safe_ratio(float(ediff.max()), float(eb.max()))
    return ComponentMetrics(
        component=component, units="Pa", history_error=h, peak_error=peak_error(ea, eb),
        max_abs_error=float(ediff.max()), rms_error=float(np.sqrt(np.mean(ediff ** 2))),
        phase_shift=phase_shift(crank_angle, ea, eb, direction_sign), amplification=amplification(ea, eb),
        solver_peak=peak(ea), reference_peak=peak(eb), holds=bool(h < tolerance))


@dataclass(frozen=True)
class PairMetrics:
    """One solver measured against a reference solver on one scene.

    ``omega`` [rad/s] crank speed, ``omega1_min`` [rad/s] lowest first natural circular frequency
    over the cycle, ``speed_ratio`` = omega / omega1_min [1], ``tolerance`` [1];
    ``components``: dx, dy, rotation (those both solvers have), then ``vector`` if dx and dy exist, then
    ``stress_<link>`` of the links both have stresses for.
    """

    solver: str
    reference: str
    omega: float
    omega1_min: float
    speed_ratio: float
    tolerance: float
    components: tuple[ComponentMetrics, ...]

    @property
    def name(self) -> str:
        return pair_name(self.solver, self.reference)

    def component(self, name: str) -> ComponentMetrics:
        for c in self.components:
            if c.component == name:
                return c
        raise KeyError(name)

    @property
    def scalar_components(self) -> tuple[ComponentMetrics, ...]:
        """dx, dy and rotation (those present)."""
        return tuple(c for c in self.components if c.component in COMPONENTS)

    @property
    def stress_components(self) -> tuple[ComponentMetrics, ...]:
        """``stress_<link>`` of every link both solvers gave stresses for."""
        return tuple(c for c in self.components if is_stress(c.component))

    @property
    def stress_worst(self) -> ComponentMetrics | None:
        """The link stress with the largest history error (None without stresses)."""
        return max(self.stress_components, key=lambda c: c.history_error, default=None)

    @property
    def stress_error(self) -> float:
        """The stress verdict's measure: the worst link's stress history error [1] (NaN without stresses)."""
        worst = self.stress_worst
        return math.nan if worst is None else worst.history_error

    @property
    def stress_holds(self) -> bool | None:
        """Every link's stress within the tolerance (None without stresses)."""
        return None if not self.stress_components else bool(self.stress_error < self.tolerance)

    @property
    def verdict_error(self) -> float:
        """The :data:`VERDICT_METRIC`: history error of the deflection vector (dx, dy) [1] (see the
        module docstring for pairs without both components)."""
        names = {c.component for c in self.components}
        if VECTOR in names:
            return self.component(VECTOR).history_error
        return max((c.history_error for c in self.components if c.component in ("dx", "dy")), default=math.nan)

    @property
    def holds(self) -> bool:
        """The solver is within tolerance of the reference (:data:`VERDICT_METRIC` < tolerance)."""
        return bool(self.verdict_error < self.tolerance)

    @property
    def worst_component_error(self) -> float:
        """Worst history error of dx, dy and rotation [1]: the campaign verdict's measure before the
        vector one (kept for the ``max_relative_error`` key); not a verdict."""
        return max((c.history_error for c in self.scalar_components), default=math.nan)

    @property
    def max_amplification(self) -> float:
        return max((c.amplification for c in self.scalar_components), default=math.nan)

    @property
    def max_relative_error(self) -> float:
        """Alias of :attr:`worst_component_error` (the old verdict measure; not a verdict)."""
        return self.worst_component_error


def pair_name(solver: str, reference: str) -> str:
    """The name of a pair, e.g. ``quasi_static_vs_dynamic``."""
    return f"{solver}_vs_{reference}"


def pair_metrics(solver: str, reference: str, crank_angle: np.ndarray, a: Mapping[str, np.ndarray],
                 b: Mapping[str, np.ndarray], *, omega: float, omega1_min: float, tolerance: float,
                 direction_sign: int = 1) -> PairMetrics:
    """Metrics of every component both histories have (``a`` the solver's, ``b`` the reference's)."""
    comps = [component_metrics(c, crank_angle, a[c], b[c], tolerance, direction_sign)
             for c in COMPONENTS if c in a and c in b]
    if all(c in a and c in b for c in ("dx", "dy")):
        vec = [np.column_stack([h["dx"], h["dy"]]) for h in (a, b)]
        comps.append(component_metrics(VECTOR, crank_angle, vec[0], vec[1], tolerance, direction_sign))
    comps += [stress_metrics(c, crank_angle, a[c], b[c], tolerance, direction_sign)
              for c in a if is_stress(c) and c in b]
    return PairMetrics(solver=solver, reference=reference, omega=float(abs(omega)), omega1_min=float(omega1_min),
                       speed_ratio=safe_ratio(abs(omega), omega1_min), tolerance=float(tolerance),
                       components=tuple(comps))


def all_pairs(crank_angle: np.ndarray, histories: Mapping[str, Mapping[str, np.ndarray]],
              fidelity: Mapping[str, int], *, omega: float, omega1_min: float, tolerance: float,
              direction_sign: int = 1) -> dict[str, PairMetrics]:
    """Metrics of every pair of solvers (lower ``fidelity`` measured against higher), by pair name."""
    order = sorted(histories, key=lambda n: (fidelity.get(n, 0), n))
    out = {}
    for i, s in enumerate(order):
        for ref in order[i + 1:]:
            m = pair_metrics(s, ref, crank_angle, histories[s], histories[ref], omega=omega, omega1_min=omega1_min,
                             tolerance=tolerance, direction_sign=direction_sign)
            out[m.name] = m
    return out


def reference_of(fidelity: Mapping[str, int]) -> str | None:
    """The reference of a set of solvers (name -> fidelity): the one with the highest fidelity."""
    return max(fidelity, key=lambda n: (fidelity[n], n)) if fidelity else None


def translation_error(a: np.ndarray, b: np.ndarray) -> float:
    """max_k max(|dx_a - dx_b|, |dy_a - dy_b|) / max_k max(|dx_b|, |dy_b|) [1] of (n, >=2) histories: the
    translation components against their common peak (the work-precision and stability studies)."""
    a, b = np.asarray(a, dtype=float)[:, :2], np.asarray(b, dtype=float)[:, :2]
    return safe_ratio(float(np.max(np.abs(a - b))), float(np.max(np.abs(b))))


def cycle_error(a: np.ndarray, b: np.ndarray) -> float:
    """The worse of :func:`translation_error` and the rotation's :func:`history_error` [1] of (n, 3)
    histories (dx, dy [m], rotation [rad]); inf if ``a`` has non-finite values.  The Exudyn model's
    steady-state test compares successive cycles the same way."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if not np.all(np.isfinite(a)):
        return math.inf
    parts = [translation_error(a, b) if np.max(np.abs(b[:, :2])) > 0 else 0.0,
             history_error(a[:, 2], b[:, 2]) if np.max(np.abs(b[:, 2])) > 0 else 0.0]
    return max(parts)
