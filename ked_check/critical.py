"""Critical speeds of a linkage: the crank speeds where its free vibrations are least damped (speeds of
weakest damping), and the amplification peaks, where its steady response is largest.

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
from functools import partial
from typing import TYPE_CHECKING, Any

import numpy as np

from compare.inspect import rpm_text

if TYPE_CHECKING:
    from ked_check.checkwork import CheckWorkers

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
    """Indices of the interior local maxima of y(x) (x increasing) with at least ``prominence`` (a plateau
    counts once, at its middle; :func:`peaks`); NaN values count as the lowest."""
    filled = _filled(y)
    if filled is None:
        return []
    found = peaks(filled)
    return [i for i, p in zip(found, prominences(filled, found)[0]) if p >= prominence]


def _filled(y: Sequence[float]) -> np.ndarray | None:
    """y with NaN below its lowest finite value (None if none is finite)."""
    y = np.asarray(y, dtype=float)
    if not np.any(np.isfinite(y)):
        return None
    return np.where(np.isfinite(y), y, np.nanmin(y) - 1.0)


def peaks(y: np.ndarray) -> list[int]:
    """Indices of the interior local maxima of ``y``, a plateau once at its middle (rounded down): the
    definition of ``scipy.signal.find_peaks``, here because importing ``scipy.signal`` costs a ``ked check``
    0.3-0.8 s (measured on this project's 2-core machine), several times this whole search."""
    y = np.asarray(y, dtype=float)
    out, i, n = [], 1, y.size
    while i < n - 1:
        if y[i - 1] < y[i]:
            ahead = i + 1
            while ahead < n - 1 and y[ahead] == y[i]:
                ahead += 1
            if y[ahead] < y[i]:
                out.append((i + ahead - 1) // 2)
                i = ahead
        i += 1
    return out


def prominences(y: np.ndarray, found: Sequence[int]) -> tuple[np.ndarray, list[int], list[int]]:
    """(prominence, left base, right base) of each peak index in ``found``: its height above the higher of
    the lowest points on either side before higher ground or the end (``scipy.signal.peak_prominences``'
    definition, without a window; see :func:`peaks` for why not scipy's)."""
    y = np.asarray(y, dtype=float)
    prom, left, right = [], [], []
    for k in found:
        bases = []
        for step, stop in ((-1, -1), (1, y.size)):
            base, low, i = k, y[k], k
            while i != stop and y[i] <= y[k]:
                if y[i] < low:
                    base, low = i, y[i]
                i += step
            bases.append(base)
        left.append(bases[0])
        right.append(bases[1])
        prom.append(y[k] - max(y[bases[0]], y[bases[1]]))
    return np.asarray(prom, dtype=float), left, right


def _refine(f: Callable[[float], float], a: float, b: float, c: float, fa: float, fb: float, fc: float,
            rtol: float) -> tuple[float, float]:
    """Maximum of f on [a, c] near b, located to ``rtol`` of the speed: Brent's method
    (``scipy.optimize.minimize_scalar``) on the bracket (a, b, c) where f(b) > f(a), f(c), its bounded
    variant on [a, c] where the bracket is not strict (a plateau); the best value seen is returned (a failed
    evaluation ends the search).  ``f`` should remember its values (the sweep's does): the bracket's three
    are then not computed again.  Measured on the Floquet sweeps: 4 to 8 evaluations per maximum."""
    from scipy.optimize import minimize_scalar

    best = [b, fb]

    def negative(x: float) -> float:
        y = f(x)
        if not math.isfinite(y):
            raise ArithmeticError(x)
        if y > best[1]:
            best[:] = [x, y]
        return -y

    try:
        if fb > fa and fb > fc:
            # Brent stops once its bracket is below 4 tol |x| (tol1 = tol |x|, |x - mid| <= 2 tol1 - half)
            minimize_scalar(negative, bracket=(a, b, c), method="brent", options={"xtol": rtol / 4.0})
        else:
            minimize_scalar(negative, bounds=(a, c), method="bounded", options={"xatol": rtol * b})
    except ArithmeticError:
        pass
    return best[0], best[1]


def fine_speeds(rpms: Sequence[float], fine: int = 4) -> np.ndarray:
    """The speeds a fine sweep adds: ``fine`` - 1 evenly between each pair of neighbouring samples (sorted)."""
    x = np.sort(np.asarray(rpms, dtype=float))
    if x.size < 2 or fine <= 1:
        return np.zeros(0)
    return np.concatenate([np.linspace(a, b, fine + 1)[1:-1] for a, b in zip(x[:-1], x[1:])])


MIN_INTERVALS = 16
"""Least intervals in which the critical-speed sweep samples its range: where fewer speeds are checked,
each interval between them is divided evenly (:func:`fill_speeds`).  With up to 5 speeds that is the grid
of the former fine sweep of every interval (4 per interval); a range sampled as sparsely as that shows no
maximum for a peak between its samples (measured: the thesis joints model at 150-350 rpm in 5 speeds hides
its peak at 202 rpm, which 8 intervals or more show)."""

CANDIDATE_PROMINENCE = 1e-3
"""Least prominence of a local maximum of the samples that the sweep looks at more closely: bumps below
the Floquet tolerance (1e-3, ``ked_linear.settings``) of the samples are their noise."""


def fill_speeds(rpms: Sequence[float], intervals: int = MIN_INTERVALS) -> np.ndarray:
    """The speeds the sweep adds to the samples ``rpms`` so that their range has at least ``intervals``
    intervals: each interval divided into ceil(intervals / its count) equal parts (none when there are
    enough; sorted)."""
    x = np.unique(np.asarray(rpms, dtype=float))
    if x.size < 2 or x.size - 1 >= intervals:
        return np.zeros(0)
    return fine_speeds(x, math.ceil(intervals / (x.size - 1)))


class _Sweep:
    """The samples of a critical-speed sweep: the given speeds ``coarse`` (sorted) with their max |mu|, each
    exact (a value of ``floquet``) or approximate (known within its Floquet error: it helps find the maxima,
    ``floquet`` is evaluated there before it decides one), plus the ``fine`` - 1 speeds inside each coarse
    interval sampled finely.  Every evaluation of ``floquet`` is kept: none is made twice."""

    def __init__(self, rpms: np.ndarray, values: np.ndarray, exact: np.ndarray, floquet: Callable[[float], float],
                 fine: int, batch: Callable[[list[float]], Sequence[float]] | None = None):
        self.f, self.fine, self.batch = floquet, fine, batch
        self.coarse = rpms
        self.exact = {float(r): float(v) for r, v, e in zip(rpms, values, exact) if e}
        self.approx = {float(r): float(v) for r, v, e in zip(rpms, values, exact) if not e}
        self.intervals: set[int] = set()
        self.evaluations = 0

    def value(self, rpm: float) -> float:
        """max |mu| at ``rpm`` from ``floquet``, evaluated once."""
        rpm = float(rpm)
        if rpm not in self.exact:
            self.exact[rpm] = float(self.f(rpm))
            self.evaluations += 1
        return self.exact[rpm]

    def values(self, rpms: Sequence[float]) -> None:
        """max |mu| at each of ``rpms`` not evaluated yet, by ``batch`` (the speeds at once: they are
        independent) or one by one."""
        todo = list(dict.fromkeys(float(r) for r in rpms if float(r) not in self.exact))
        if self.batch is None or len(todo) < 2:
            for r in todo:
                self.value(r)
            return
        for r, v in zip(todo, self.batch(todo)):
            self.exact[r] = float(v)
        self.evaluations += len(todo)

    def refine_interval(self, k: int) -> list[float]:
        """Coarse interval ``k`` (between coarse speeds k and k + 1) marked as sampled finely: the speeds to
        evaluate (none if it was marked before; its ends are samples already: evaluated when they decide,
        :meth:`needs`)."""
        if k in self.intervals or not 0 <= k < self.coarse.size - 1:
            return []
        self.intervals.add(k)
        return [float(r) for r in np.linspace(self.coarse[k], self.coarse[k + 1], self.fine + 1)[1:-1]]

    def points(self) -> tuple[np.ndarray, np.ndarray]:
        """The speeds sampled so far for the maxima (coarse and finely sampled intervals; not the refinement's
        evaluations), sorted, with their values (exact where known)."""
        x = set(self.coarse.tolist())
        for k in self.intervals:
            x.update(np.linspace(self.coarse[k], self.coarse[k + 1], self.fine + 1)[1:-1].tolist())
        xs = np.array(sorted(x))
        return xs, np.array([self.exact.get(r, self.approx.get(r, math.nan)) for r in xs.tolist()])

    def around(self, rpm: float) -> list[int]:
        """The coarse intervals next to ``rpm`` (a coarse speed: both sides; else the one holding it)."""
        k = int(np.searchsorted(self.coarse, rpm))
        if k < self.coarse.size and self.coarse[k] == rpm:
            return [i for i in (k - 1, k) if 0 <= i < self.coarse.size - 1]
        return [k - 1]

    def needs(self, prominence: float) -> tuple[list[int], list[float]]:
        """What the maxima of the samples still need before they are decided: coarse intervals to sample
        finely (an end interval where the samples rise to the end of the range: a peak inside it shows on
        its fine samples; both next to every maximum of at least :data:`CANDIDATE_PROMINENCE`; those next to the
        deciding base of one whose prominence is at least half of ``prominence`` but below it: finer
        samples there can only deepen that base, and a maximum below half the threshold on its own finely
        sampled intervals is taken as settled) and speeds to evaluate exactly (a maximum and its two
        neighbours where it is listed or may be on exact values; the bases of a maximum whose prominence is
        within :data:`CANDIDATE_PROMINENCE` of the threshold: an approximate sample is good to the Floquet
        tolerance, which can move neither more)."""
        x, y = self.points()
        if x.size < 3:
            return [], []
        ends = [k for k, rising in ((0, y[0] > y[1]), (self.coarse.size - 2, y[-1] > y[-2]))
                if rising and k not in self.intervals]  # a peak in an end interval shows as a rise to the end
        found = local_maxima(x, y, CANDIDATE_PROMINENCE)
        if not found:
            return ends, []
        filled = _filled(y)
        prom, left, right = prominences(filled, found)
        intervals: list[int] = ends
        exact: list[float] = []
        for i, p, lb, rb in zip(found, prom, left, right):
            own = [k for k in self.around(float(x[i])) if k not in self.intervals]
            if own:  # its own intervals first: the rest is decided on them
                intervals += own
                continue
            if p >= prominence - 2.0 * CANDIDATE_PROMINENCE:  # listed, or may be on exact values: its bracket exact
                exact += [float(v) for v in x[i - 1:i + 2]]
                if p < prominence + CANDIDATE_PROMINENCE:  # near the threshold: decided on exact values only
                    exact += [float(x[lb]), float(x[rb])]
            if 0.5 * prominence <= p < prominence:  # undecided: the side whose minimum decides, sampled finely
                for b in (lb, rb):
                    if filled[b] == max(filled[lb], filled[rb]):
                        intervals += self.around(float(x[b]))
        return ([k for k in dict.fromkeys(intervals) if k not in self.intervals],
                [r for r in dict.fromkeys(exact) if r not in self.exact])


Bracket = tuple[float, float, float, float, float, float]
"""A local maximum to refine: speeds a < b < c [rev/min] and their max |mu| (fb above fa and fc, or a plateau)."""


def critical_speeds(rpms: Sequence[float], max_abs: Sequence[float],
                    floquet: Callable[[float], float] | None = None, fine: int = 4,
                    rpm_tol: float = 2e-3, prominence: float = PROMINENCE,
                    exact: bool | Sequence[bool] = True,
                    batch: Callable[[list[float]], Sequence[float]] | None = None,
                    refine: Callable[[list[Bracket], float], list[tuple[float, float]] | None] | None = None,
                    ) -> tuple[CriticalSpeed, ...]:
    """The critical speeds (local maxima of max |mu|) of the samples ``rpms`` [rev/min] (any order) and
    their ``max_abs``.  A maximum at either end of the range is no critical speed (its peak may lie outside).

    Without ``floquet`` (rpm -> max |mu|): the maxima of the samples of at least ``prominence``.  With it, a
    sweep that looks closer only where a maximum is bracketed (:class:`_Sweep`):

    1. the samples, with evenly spaced speeds added where they cut the range in fewer than
       :data:`MIN_INTERVALS` intervals (:func:`fill_speeds`; the fine sampling below then takes
       proportionally fewer speeds per interval);
    2. every local maximum of the samples of at least :data:`CANDIDATE_PROMINENCE` gets ``fine`` - 1 more
       speeds in each of its two intervals (an end interval too where the samples rise to that end); one
       whose prominence is then still below ``prominence`` (but at least half of it) gets them also next to
       the minimum that decides it; repeated until nothing changes (:meth:`_Sweep.needs`);
    3. each local maximum of at least ``prominence`` on those samples is refined (Brent's method,
       :func:`_refine`) to ``rpm_tol`` of its speed.

    Inside the intervals it samples this is the fine sweep of every interval (``fine`` - 1 speeds in each),
    with the same maxima and the same refinement, at a fraction of the evaluations (measured, thesis
    distributed model, 30-600 rpm in 20 speeds, the rows' own max |mu| as approximate samples: 35
    evaluations where the fine sweep of every interval took 92, the same three critical speeds to the last
    digit; 33 with exact samples, 20 of them given).  A peak that does not show as a maximum on the
    samples of step 1 (one narrower than their spacing) is not found: the samples set the resolution.
    ``exact``: whether ``max_abs`` are values of ``floquet`` (one bool, or one per sample); an approximate
    one (the linear solve's own |mu|, at its own step count) finds the maxima, and ``floquet`` is
    evaluated there before it decides one.

    ``batch`` (speeds -> their max |mu|, as ``floquet`` gives them) evaluates the speeds of one round of the
    sweep at once and ``refine`` (brackets, ``rpm_tol`` -> [(rpm, max |mu|)] per bracket, as
    :func:`refine_maximum`, or None) refines the maxima at once: both on worker processes in ``ked check``
    (:mod:`ked_check.checkwork`); the speeds evaluated and the answer are those of the one-by-one sweep."""
    order = np.argsort(np.asarray(rpms, dtype=float))
    x = np.asarray(rpms, dtype=float)[order]
    y = np.asarray(max_abs, dtype=float)[order]
    if floquet is None:
        return tuple(CriticalSpeed(rpm=float(x[i]), max_abs=float(y[i])) for i in local_maxima(x, y, prominence))
    known = np.broadcast_to(np.asarray(exact, dtype=bool), np.shape(rpms))[order]
    fill = fill_speeds(x)
    if fill.size:  # fewer intervals than MIN_INTERVALS: evenly spaced speeds added, evaluated (exact)
        x = np.concatenate([x, fill])
        y = np.concatenate([y, np.full(fill.size, math.nan)])
        known = np.concatenate([known, np.zeros(fill.size, dtype=bool)])
        order = np.argsort(x)
        x, y, known = x[order], y[order], known[order]
    # the filled intervals are sampled finely by fewer speeds: the same fine grid as the given samples'
    # (with 4: 2 in each half of an interval cut in two, none in the quarters of one cut in four)
    parts = max(round((x.size - 1) / max(x.size - 1 - fill.size, 1)), 1)
    sweep = _Sweep(x, y, known, floquet, max(math.ceil(max(int(fine), 1) / parts), 1), batch)
    sweep.values(fill)
    while True:
        intervals, points = sweep.needs(prominence)
        if not intervals and not points:
            break
        sweep.values([r for k in intervals for r in sweep.refine_interval(k)] + points)
    x, y = sweep.points()
    triples = [tuple(float(v) for v in x[i - 1:i + 2]) for i in local_maxima(x, y, prominence)]
    sweep.values([v for t in triples for v in t])
    brackets: list[Bracket] = [(a, b, c, sweep.value(a), sweep.value(b), sweep.value(c)) for a, b, c in triples]
    refined = refine(brackets, rpm_tol) if refine is not None and brackets else None
    if refined is None:
        refined = [_refine(sweep.value, *br, rpm_tol) for br in brackets]
    return tuple(CriticalSpeed(rpm=r, max_abs=m) for r, m in refined)


def refine_maximum(floquet: Callable[[float], float], bracket: Bracket, rtol: float) -> tuple[float, float, int]:
    """One maximum of a sweep refined by :func:`_refine` with ``floquet`` alone (remembering its values):
    (rpm, max |mu|, evaluations of ``floquet``), as :func:`critical_speeds` refines it."""
    seen: dict[float, float] = dict(zip(bracket[:3], bracket[3:]))
    before = len(seen)

    def f(rpm: float) -> float:
        rpm = float(rpm)  # Brent's bounded method gives numpy floats; the sweep asks with Python floats
        if rpm not in seen:
            seen[rpm] = float(floquet(rpm))
        return seen[rpm]

    r, m = _refine(f, *bracket, rtol)
    return r, m, len(seen) - before


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
    from ked_linear.lumping import dynamic_scene
    from ked_linear.solver import reduced_stability

    given = settings_of(get_solver("linear"), spec)
    reference: list[Any] = []  # the scene's damping reference, computed once (speed-free)

    def f(rpm: float) -> float:
        scene, settings = dynamic_scene(spec.scene(rpm), reference[0] if reference else given)
        reference[:1] = [settings]
        system = linkage_system(scene, settings).system
        red = reduced_stability(scene, system, settings) if steps == SWEEP_STEPS else None
        if red is not None:
            return red.max_abs
        return float(np.abs(multipliers(system, steps)[0]))

    return f


def mark_near(rows: Sequence[object], speeds: Sequence[CriticalSpeed],
              amplification: Sequence[float] = ()) -> list[object]:
    """The check rows (``ked_check.check.CheckRow``), each verdict near a speed of weakest damping or an
    amplification peak saying so.  Only an amplification peak (forced resonance: the steady response is
    largest relative to the quasi-static one) is a speed to keep away from; a speed of weakest damping
    (parametric resonance of the free vibration) is where transients die out slowest, which alone does
    not amplify the steady response (its own weakly-damped flag does where max |mu| is near 1)."""
    from dataclasses import replace

    out = []
    for row in rows:
        notes = []
        s = near(row.rpm, [c.rpm for c in speeds])
        if s is not None:
            mu = next(c.max_abs for c in speeds if c.rpm == s)
            notes.append(f"within {NEAR:.0%} of {rpm_text(s)} rpm, a speed of weakest damping (parametric "
                         f"resonance, max |Floquet multiplier| {mu:.3g}): free vibrations after a start-up or a "
                         "disturbance die out slowest there; this alone does not amplify the steady response")
        a = near(row.rpm, amplification)
        if a is not None:
            notes.append(f"within {NEAR:.0%} of the amplification peak {rpm_text(a)} rpm (forced resonance: the "
                         "dynamic response is largest relative to the quasi-static one there; keep the operating "
                         "speed away from it)")
        out.append(replace(row, verdict="; ".join([row.verdict, *notes])) if notes else row)
    return out


def check_critical(rows: Sequence[object], source: object, mechanism: str, mass_model: object, bar: Any = None,
                   workers: CheckWorkers | None = None, base: object = None,
                   **spec_kw: object) -> tuple[tuple[CriticalSpeed, ...], tuple[float, ...], list[object]]:
    """For the rows of a design check (:func:`ked_check.check.check`, same linkage and keywords of
    :func:`ked_check.check.spec_for`): its critical speeds (refined with the Floquet part alone), the
    amplification peaks, and the rows with the verdicts near a critical speed annotated.  ``bar``: a
    progress bar (``ked_check.check.progress``) advanced per Floquet evaluation.  ``workers``: a
    :class:`ked_check.checkwork.CheckWorkers` that takes a round of evaluations, or the refinements of the
    maxima, when it finds them worth its worker processes (the same evaluations, the same answer).
    ``base``: the campaign scene whose speed the sweep varies (a user file's, with its own step and solver
    settings, as its rows were checked), else :func:`ked_check.check.spec_for`'s.

    The rows' own max |mu| (their linear solves') are the sweep's samples: exact where the solve's Floquet
    analysis is the sweep's (:func:`sweep_exact`), else approximate (within their Floquet error: they find
    the maxima, and the sweep evaluates its own value where one is decided)."""
    from ked_check.check import advance, redraw, spec_for, status
    from ked_linear.solver import single_threaded_blas

    spec = base if base is not None else spec_for(source, mechanism, mass_model, rows[0].rpm, **spec_kw)
    rpms = [r.rpm for r in rows]
    sweep = floquet_max_abs(spec)

    def f(rpm: float) -> float:
        if bar is not None:
            status(bar, f"critical speeds, {rpm_text(rpm)} rpm")
        value = sweep(rpm)
        if bar is not None:
            advance(bar)
        return value

    def tick(text: str, steps: int = 1) -> None:
        if bar is not None:
            status(bar, text)
            for _ in range(steps):
                advance(bar)

    def batch(speeds: list[float]) -> list[float]:
        if workers is None:
            return [f(r) for r in speeds]
        done: list[float] = []
        for r in speeds:  # the first two evaluations of the check are timed here
            if workers.started or workers.evaluations.timed_enough:
                break
            done.append(workers.evaluations.timed(partial(f, r)))
        rest = speeds[len(done):]
        if not workers.worth(workers.evaluations, len(rest)):
            return done + [f(r) for r in rest]
        return done + workers.map(floquet_task, [(spec, r) for r in rest],
                                  [f"the critical-speed sweep at {rpm_text(r)} rpm" for r in rest],
                                  lambda i, v: tick(f"critical speeds, {rpm_text(rest[i])} rpm"), cost=rest)

    def refine(brackets: list[Bracket], rtol: float) -> list[tuple[float, float]] | None:
        if workers is None or not workers.worth(workers.evaluations, len(brackets), REFINE_EVALUATIONS):
            return None
        done = workers.map(refine_task, [(spec, b, rtol) for b in brackets],
                           [f"the critical speed near {rpm_text(b[1])} rpm" for b in brackets],
                           lambda i, res: tick(f"critical speed near {rpm_text(brackets[i][1])} rpm", res[2]))
        return [(r, m) for r, m, _ in done]

    # one BLAS thread, as in solve_linear: the evaluations are small batched calls where threads only cost
    # (measured on the loaded 2-core machine: the sweep 3-8x slower with threads)
    with single_threaded_blas():
        crit = critical_speeds(rpms, [r.floquet_max_abs for r in rows], f, exact=[sweep_exact(r) for r in rows],
                               batch=batch, refine=refine)
    if bar is not None and bar.total is not None and bar.n < bar.total:  # fewer evaluations than estimated
        bar.total = bar.n
        redraw(bar)
    amp = amplification_peaks(rpms, [r.linear_peak_m / r.quasi_static_peak_m if r.quasi_static_peak_m > 0
                                     else math.nan for r in rows])
    return crit, amp, mark_near(rows, crit, amp)


def sweep_exact(row: object) -> bool:
    """True when a check row's max |mu| is the sweep's own value (:func:`floquet_max_abs`) at its speed: the
    linear solve's Floquet analysis was the reduced system's (``floquet_reduced``: the sweep asks the same
    ``ked_linear.solver.reduced_stability`` with the same settings, which answers the same) or the full
    model's at :data:`SWEEP_STEPS` (the sweep's fixed count where the reduction does not answer)."""
    if not math.isfinite(row.floquet_max_abs):
        return False
    return bool(getattr(row, "floquet_reduced", False)) or int(getattr(row, "floquet_steps", 0)) == SWEEP_STEPS


def sweep_evaluations(rows: Sequence[object], fine: int = 4) -> int:
    """An estimate of the Floquet evaluations :func:`check_critical` makes on ``rows`` (for the progress
    bar; :func:`ked_check.check.advance` raises its total if the work outgrows it): the speeds
    :func:`fill_speeds` adds, then per local maximum of the rows' max |mu| (:data:`CANDIDATE_PROMINENCE`)
    the fine speeds of its two intervals, its own speed where the row's value is not the sweep's own, and
    a typical refinement (:data:`REFINE_EVALUATIONS`)."""
    x = [r.rpm for r in rows]
    y = [r.floquet_max_abs for r in rows]
    order = np.argsort(x)
    exact = [sweep_exact(rows[i]) for i in order]
    n = fill_speeds(x).size
    for i in local_maxima(np.asarray(x)[order], np.asarray(y)[order], CANDIDATE_PROMINENCE):
        n += 2 * (max(fine, 1) - 1) + (not exact[i]) + REFINE_EVALUATIONS
    return n


REFINE_EVALUATIONS = 6
"""Typical Floquet evaluations of the refinement of one maximum (:func:`_refine`: 4 to 8 measured)."""


def floquet_task(spec: object, rpm: float) -> Any:
    """The sweep's max |Floquet multiplier| at ``rpm`` on a worker (:func:`floquet_max_abs`), a refusal kept as
    data."""
    from ked_check.checkwork import kept

    return kept(lambda: floquet_max_abs(spec)(rpm))


def refine_task(spec: object, bracket: tuple[float, ...], rtol: float) -> Any:
    """One local maximum of the sweep refined on a worker (:func:`refine_maximum`): (rpm, max |mu|, evaluations
    made)."""
    from ked_check.checkwork import kept

    return kept(lambda: refine_maximum(floquet_max_abs(spec), bracket, rtol))
