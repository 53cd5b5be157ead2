"""Classification of a run without a periodic steady state: "numerical", "physical" or "undecided".

Evidence from the constant-speed cycles of a run (exudyn_models.cycles.SteadyTracker):
    growth: per-cycle growth of the cycle peak |d|, (peak_last / peak_{last-3})^(1/3) (needs 4 cycles);
    contraction, scatter, trend, window: the per-cycle factor of the cycle changes, exp of the
        least-squares slope of log(change) over the last half of the changes (at least MIN_WINDOW), the
        RMS of the fit's residuals, the fitted change at the last cycle, and the number of changes fitted
        (an estimate of the slowest Floquet multiplier's modulus while a transient decays; the long
        window sees through beats of two close modes);
    nonharmonic: fraction of the spectral energy of dx + i dy over the last 4 cycles (on the scene grid,
        mean removed) that lies off the crank harmonics (a periodic response, even with a decaying
        transient of small amplitude, has ~0 there; quasi-periodic or subharmonic motion does not);
    change: the last relative cycle change.
"Decays": contraction < DECAY_LIMIT and the slope is significant, |slope| > SIGNIFICANCE x its standard
error (a decay, not cycle changes that jump up and down). Then the cycles still needed to settle are
predicted, n = log(steady_tol / trend) / log(contraction). The refinement ladder (exudyn_models.simulate) grants
ceil(GRANT_FACTOR n) + 2 more cycles, at most SETTLE_LIMIT, when that fits its wall-time budget (a rerun
with max_cycles raised: rung "cycles +N"), and the cycles' evidence is then read again.

"Stuck": the changes do not shrink: contraction >= DECAY_LIMIT, or no significant decay and even the
fastest plausible one (2 standard errors) would need more than SETTLE_LIMIT cycles.
Rule (after the granted cycles, if any):
    numerical, "stalled at the noise floor": not decaying at a change < STALL_LEVEL (steady_tol below
        what the discretization and Newton tolerance resolve);
    physical, "grows without bound": stuck and growth > GROWTH_LIMIT;
    physical, "no periodic orbit": stuck with energy off the crank harmonics > NONHARMONIC_LIMIT
        (quasi-periodic / subharmonic), or not decaying after the granted cycles ran without settling
        although the contraction measured before predicted it;
    numerical, "more cycles would settle it": the granted cycles ran and the change fell to within a
        factor CONFIRM_FACTOR of what the contraction predicted (the decay is confirmed) but not below
        steady_tol;
    undecided, with the numbers, otherwise: too few cycles; a decay too slow to settle within
        SETTLE_LIMIT more cycles; the granted cycles not run (budget, refine=False, Newton failure); a decay
        slower than predicted; cycle changes with neither a significant decay nor evidence against one
        (not stuck: e.g. a slow decay hidden under beats).
A Newton failure left after the refinement ladder is numerical unless an attempt that completed >= 4
cycles shows the growth above (then physical: the response grew until the integrator gave up).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

GROWTH_LIMIT = 1.02
DECAY_LIMIT = 0.995
MIN_WINDOW = 4
SIGNIFICANCE = 3.0
STALL_LEVEL = 1e-3
NONHARMONIC_LIMIT = 1e-4
SETTLE_LIMIT = 120
"""At most this many cycles beyond max_cycles are granted to a decaying transient (with the default
max_cycles = 80: 200 in all)."""
GRANT_FACTOR = 1.5
CONFIRM_FACTOR = 10.0

NUMERICAL, PHYSICAL, UNDECIDED = "numerical", "physical", "undecided"


@dataclass(frozen=True)
class Evidence:
    """growth, contraction [per cycle], scatter [log units], nonharmonic [fraction of energy], change
    [fraction of the peak]: see module doc (NaN when there were too few cycles); cycles: constant-speed
    cycles; peak_m [m]: the last cycle's peak |d|."""

    growth: float
    contraction: float
    nonharmonic: float
    change: float
    cycles: int
    peak_m: float
    scatter: float = math.nan
    trend: float = math.nan
    window: int = 0

    @property
    def decays(self) -> bool:
        """The cycle changes fall significantly (module doc)."""
        c = self.contraction
        if not (math.isfinite(c) and math.isfinite(self.scatter) and c < DECAY_LIMIT and self.window >= MIN_WINDOW):
            return False
        return -math.log(c) > SIGNIFICANCE * self.stderr

    @property
    def stderr(self) -> float:
        """Standard error of the fitted log contraction."""
        n = self.window
        return self.scatter * math.sqrt(12.0 / (n * (n * n - 1.0))) if n >= MIN_WINDOW else math.nan

    def stuck(self, steady_tol: float) -> bool:
        """The cycle changes do not shrink: fitted contraction >= DECAY_LIMIT, or no significant decay and
        even the fastest plausible one (log contraction - 2 standard errors) would not settle within
        SETTLE_LIMIT more cycles."""
        c = self.contraction
        if not math.isfinite(c) or self.decays:
            return False
        if c >= DECAY_LIMIT:
            return True
        fast = math.log(c) - 2.0 * self.stderr
        return self.trend > steady_tol and math.log(steady_tol / self.trend) / fast > SETTLE_LIMIT

    def cycles_to_settle(self, steady_tol: float) -> float:
        """Cycles still needed for the change to fall below steady_tol at the measured contraction
        (inf when it does not decay; 0 if already below)."""
        if not self.decays:
            return math.inf
        if self.trend <= steady_tol:
            return 0.0
        return math.log(steady_tol / self.trend) / math.log(self.contraction)

    def text(self) -> str:
        return (f"{self.cycles} cycles, peak |d| {1e3 * self.peak_m:.4g} mm, last change {self.change:.3g}, "
                f"growth x{self.growth:.3g}/cycle, "
                f"cycle change x{self.contraction:.3g}/cycle over the last {self.window} (scatter {self.scatter:.2g}, "
                f"trend {self.trend:.3g}), "
                f"off-harmonic energy {100 * self.nonharmonic:.3g} %")


@dataclass(frozen=True)
class Extension:
    """The cycles granted to a decaying transient: before: the evidence at the end of the first run;
    predicted: cycles it predicted; granted: cycles beyond its max_cycles given (0 if none); ran: the
    extended run completed; note: why not granted / what happened ("" when it ran)."""

    before: Evidence
    predicted: float
    granted: int
    ran: bool
    note: str = ""

    def text(self) -> str:
        head = (f"x{self.before.contraction:.3g}/cycle at cycle {self.before.cycles} (change trend "
                f"{self.before.trend:.3g}) predicted settling in {math.ceil(self.predicted)} more cycles")
        if self.ran:
            return f"{head}; {self.granted} more granted"
        return f"{head}; not granted: {self.note}"


def _growth(peaks: list[float]) -> float:
    if len(peaks) < 4 or not peaks[-4] > 0.0:
        return math.nan
    return float((peaks[-1] / peaks[-4]) ** (1.0 / 3.0))


def contraction_fit(changes: list[float]) -> tuple[float, float, float, int]:
    """(per-cycle factor, RMS log residual, fitted last change, window) of the last half of the changes
    (at least MIN_WINDOW; NaN if fewer positive finite ones)."""
    window = max(MIN_WINDOW, len(changes) // 2)
    c = np.array([x for x in changes[-window:] if math.isfinite(x)], dtype=float)
    if c.size < MIN_WINDOW or c.min() <= 0.0:
        return math.nan, math.nan, math.nan, 0
    k = np.arange(c.size, dtype=float)
    slope, intercept = np.polyfit(k, np.log(c), 1)
    resid = np.log(c) - (slope * k + intercept)
    trend = math.exp(intercept + slope * k[-1])
    return float(math.exp(slope)), float(np.sqrt(np.mean(resid**2))), float(trend), int(c.size)


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
    contraction, scatter, trend, window = contraction_fit(list(tracker.changes))
    return Evidence(growth=_growth(peaks), contraction=contraction, scatter=scatter, trend=trend, window=window,
                    nonharmonic=nonharmonic_fraction(list(tracker.history)), change=float(tracker.change),
                    cycles=tracker.cycles, peak_m=peaks[-1] if peaks else math.nan)


def cycles_to_grant(ev: Evidence, steady_tol: float) -> tuple[float, int]:
    """(predicted cycles to settle, cycles to grant; 0 when the prediction is beyond SETTLE_LIMIT or the
    changes do not decay)."""
    n = ev.cycles_to_settle(steady_tol)
    if not n <= SETTLE_LIMIT:
        return n, 0
    return n, min(SETTLE_LIMIT, math.ceil(GRANT_FACTOR * n) + 2)


def classify(ev: Evidence, steady_tol: float, extension: Extension | None = None) -> tuple[str, str]:
    """(failure class, reason) of a run that did not settle (module doc). ev: the evidence of the
    returned run (after the granted cycles if they ran); extension: what was granted (None: nothing was
    predicted, e.g. too few cycles or no decay)."""
    ext = f" ({extension.text()})" if extension is not None else ""
    if not math.isfinite(ev.contraction):
        return UNDECIDED, f"too few cycles to judge ({ev.cycles}); raise max_cycles"
    if not ev.decays and ev.change < STALL_LEVEL:
        return NUMERICAL, (f"the cycle changes stalled at {ev.change:.2e}: steady_tol is below what this "
                           f"discretization and Newton tolerance resolve{ext}")
    if ev.stuck(steady_tol):
        if math.isfinite(ev.growth) and ev.growth > GROWTH_LIMIT:
            return PHYSICAL, f"the response grows without bound{ext}"
        if math.isfinite(ev.nonharmonic) and ev.nonharmonic > NONHARMONIC_LIMIT:
            return PHYSICAL, ("no periodic orbit at the crank period (quasi-periodic or subharmonic response: "
                              f"the cycles keep differing without decaying){ext}")
    if not ev.decays:
        if extension is not None and extension.ran:
            return PHYSICAL, (f"no periodic orbit reached: no settling within {ev.cycles} cycles although the "
                              f"measured contraction predicted it{ext}")
        return UNDECIDED, ("the cycle changes show neither a significant decay nor evidence against one "
                           f"(x{ev.contraction:.3g} per cycle over the last {ev.window}, scatter {ev.scatter:.2g})"
                           f"{ext}")
    n = ev.cycles_to_settle(steady_tol)
    if extension is not None and extension.ran:
        b = extension.before
        expected = b.trend * b.contraction ** (ev.cycles - b.cycles)
        if ev.trend <= CONFIRM_FACTOR * expected:
            return NUMERICAL, (f"the transient decays as predicted (x{ev.contraction:.3g} per cycle, change trend "
                               f"{b.trend:.3g} -> {ev.trend:.3g}): about {math.ceil(n)} more cycles would settle "
                               f"it{ext}")
        return UNDECIDED, (f"the transient decays more slowly than predicted (x{ev.contraction:.3g} per cycle, "
                           f"change trend {b.trend:.3g} -> {ev.trend:.3g}, ~{math.ceil(n)} more cycles){ext}")
    if n > SETTLE_LIMIT:
        return UNDECIDED, (f"the transient decays too slowly to judge (x{ev.contraction:.3g} per cycle: ~{n:.0f} "
                           f"more cycles, more than the {SETTLE_LIMIT} the ladder grants){ext}")
    return UNDECIDED, f"the transient still decays (x{ev.contraction:.3g} per cycle, ~{math.ceil(n)} more cycles){ext}"


def classify_newton_failure(peaks_per_attempt: list[tuple[float, ...]]) -> tuple[str, str]:
    """(class, reason) of a Newton failure left after the ladder (module doc)."""
    for peaks in peaks_per_attempt:
        g = _growth(list(peaks))
        if math.isfinite(g) and g > GROWTH_LIMIT and all(b >= a for a, b in zip(peaks[-4:], peaks[-3:])):
            return PHYSICAL, (f"the response grew x{g:.3g} per cycle over the last cycles before Newton failed "
                              f"(peaks {', '.join(f'{1e3 * p:.3g}' for p in peaks[-4:])} mm)")
    return NUMERICAL, "Newton failed on every rung tried, without evidence of growth"
