"""Classification of a run without a periodic steady state: "numerical" or "physical", with evidence.

Evidence from the constant-speed cycles of a run (exudyn_models.cycles.SteadyTracker):
    growth: per-cycle growth of the cycle peak |d|, (peak_last / peak_{last-3})^(1/3) (needs 4 cycles);
    contraction: median ratio of successive cycle changes over the last 4 (an estimate of the
        slowest Floquet multiplier's modulus while a transient decays; ~1 if the cycles never settle);
    nonharmonic: fraction of the spectral energy of dx + i dy over the last 4 cycles (on the scene grid,
        mean removed) that lies off the crank harmonics (a periodic response, even with a decaying
        transient of small amplitude, has ~0 there; quasi-periodic or subharmonic motion does not).
    change: the last relative cycle change.
Rule (GROWTH_LIMIT, CONTRACTION_LIMIT, STALL_LEVEL, NONHARMONIC_LIMIT); "stuck" = contraction >=
CONTRACTION_LIMIT (the cycle changes no longer shrink):
    physical, "grows without bound": stuck and growth > GROWTH_LIMIT;
    physical, "no periodic orbit (quasi-periodic / subharmonic)": stuck, change >= STALL_LEVEL and
        nonharmonic > NONHARMONIC_LIMIT (the cycles keep differing by a visible amount);
    numerical, "stalled at the noise floor": stuck with change < STALL_LEVEL (steady_tol below what the
        discretization and Newton tolerance resolve);
    numerical, "still decays": contraction < CONTRACTION_LIMIT (more cycles, or periodic="anderson",
        would settle it); numerical, "too few cycles to judge" when the numbers are missing.
A Newton failure left after the refinement ladder is numerical unless an attempt that completed >= 4
cycles shows the growth above (then physical: the response grew until the integrator gave up).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

GROWTH_LIMIT = 1.02
CONTRACTION_LIMIT = 0.97
STALL_LEVEL = 1e-3
NONHARMONIC_LIMIT = 1e-4


@dataclass(frozen=True)
class Evidence:
    """growth, contraction [per cycle], nonharmonic [fraction of energy], change [fraction of the peak]: see
    module doc (NaN when there were too few cycles); cycles: constant-speed cycles; peak_m [m]: the last
    cycle's peak |d|."""

    growth: float
    contraction: float
    nonharmonic: float
    change: float
    cycles: int
    peak_m: float

    def text(self) -> str:
        return (f"{self.cycles} cycles, peak |d| {1e3 * self.peak_m:.4g} mm, last change {self.change:.3g}, "
                f"growth x{self.growth:.3g}/cycle, "
                f"cycle change x{self.contraction:.3g}/cycle, off-harmonic energy {100 * self.nonharmonic:.3g} %")


def _growth(peaks: list[float]) -> float:
    if len(peaks) < 4 or not peaks[-4] > 0.0:
        return math.nan
    return float((peaks[-1] / peaks[-4]) ** (1.0 / 3.0))


def _contraction(changes: list[float]) -> float:
    c = [x for x in changes[-5:] if math.isfinite(x)]
    if len(c) < 3 or min(c) <= 0.0:
        return math.nan
    return float(np.median(np.array(c[1:]) / np.array(c[:-1])))


def nonharmonic_fraction(cycles: list[np.ndarray]) -> float:
    """Energy fraction of dx + i dy (mean removed) off the crank harmonics over the given cycles."""
    if len(cycles) < 2:
        return math.nan
    z = np.concatenate([c[:, 0] + 1j * c[:, 1] for c in cycles])
    spec = np.abs(np.fft.fft(z - z.mean())) ** 2
    total = float(spec.sum())
    if total <= 0.0:
        return 0.0
    off = np.arange(spec.size) % len(cycles) != 0
    return float(spec[off].sum() / total)


def evidence_of(tracker) -> Evidence:
    """Evidence from a SteadyTracker (see module doc)."""
    peaks = list(tracker.peaks)
    return Evidence(growth=_growth(peaks), contraction=_contraction(list(tracker.changes)),
                    nonharmonic=nonharmonic_fraction(list(tracker.history)), change=float(tracker.change),
                    cycles=tracker.cycles,
                    peak_m=peaks[-1] if peaks else math.nan)


def classify(ev: Evidence) -> tuple[str, str]:
    """(failure class, reason) of a run that did not settle (module doc)."""
    stuck = math.isfinite(ev.contraction) and ev.contraction >= CONTRACTION_LIMIT
    if stuck and math.isfinite(ev.growth) and ev.growth > GROWTH_LIMIT:
        return "physical", "the response grows without bound"
    if stuck and ev.change >= STALL_LEVEL and math.isfinite(ev.nonharmonic) and ev.nonharmonic > NONHARMONIC_LIMIT:
        return "physical", ("no periodic orbit at the crank period (quasi-periodic or subharmonic response: the "
                            "cycles keep differing without decaying)")
    if stuck:
        return "numerical", (f"the cycle changes stalled at {ev.change:.2e}: steady_tol is below what this "
                             "discretization and Newton tolerance resolve")
    if math.isfinite(ev.contraction) and ev.contraction < CONTRACTION_LIMIT:
        return "numerical", (f"the transient still decays (x{ev.contraction:.3g} per cycle): more cycles "
                             "(max_cycles) or periodic='anderson' would settle it")
    return "numerical", "too few cycles to judge; raise max_cycles"


def classify_newton_failure(peaks_per_attempt: list[tuple[float, ...]]) -> tuple[str, str]:
    """(class, reason) of a Newton failure left after the ladder (module doc)."""
    for peaks in peaks_per_attempt:
        g = _growth(list(peaks))
        if math.isfinite(g) and g > GROWTH_LIMIT and all(b >= a for a, b in zip(peaks[-4:], peaks[-3:])):
            return "physical", (f"the response grew x{g:.3g} per cycle over the last cycles before Newton failed "
                                f"(peaks {', '.join(f'{1e3 * p:.3g}' for p in peaks[-4:])} mm)")
    return "numerical", "Newton failed on every rung tried, without evidence of growth"
