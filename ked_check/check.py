"""The design check: for one linkage at one or more crank speeds, how wrong is the quasi-static answer,
and which model is needed.

Every speed is one campaign scene computed by :func:`compare.execute.run_scene` (the same code path,
hence the same numbers a campaign stores) with the quasi-static and the linear solver, and Exudyn too
when asked to confirm.  Every error is the campaign verdict's measure
(:data:`compare.metrics.VERDICT_METRIC`): the history error of the deflection vector d = (dx, dy) of P.

The tier rule (:func:`tier`) is safe by construction: a model is judged only against a model that is
itself inside its own range at that speed ratio r.  The linear model's limit is the atlas's **lower
band** (the 10th percentile over the atlas families of the speed ratio where the linear model leaves
the tolerance against Exudyn: :attr:`LinearRange.lower_limit`).  With e the quasi-static error predicted
against the linear model and the :class:`VerdictMargins` (multipliers of the tolerance, calibrated
against Exudyn at the threshold by the atlas, a conservative default otherwise):

* **quasi-static** when the linear model is stable, small-deflection, r is below its lower-band limit,
  and e < holds_below x tolerance;
* **borderline** when e is between holds_below and fails_above x tolerance (or r is beyond the linear
  model's limit and e <= fails_above x tolerance): the prediction cannot decide; ``--confirm`` does;
* **linear** when e > fails_above x tolerance (or the quasi-static answer is flagged) and r is below the
  linear model's lower-band limit;
* **nonlinear** otherwise (no stable linear steady state, large deflections, or beyond the linear
  model's limit): the Exudyn model is the answer (``--confirm`` runs it).

Without an atlas the linear model's limit is unknown, so neither the quasi-static nor the linear tier is
granted from a prediction.  With ``--confirm`` the measured errors against Exudyn decide instead
(:func:`measured_tier`): quasi-static if its measured error is below the tolerance, else linear if the
linear model's is, else nonlinear; the verdict says so.

The linear solve uses the default settings (at most 32 crank harmonics); when its periodic solve has not
converged there (a frozen higher mode sweeping over many harmonics in a cycle), the check solves the
scene again with up to :data:`MAX_HARMONICS` before judging, and says so in the verdict.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

from compare import metrics
from compare.config import default_dynamic
from compare.execute import run_scene
from compare.inspect import rpm_text
from compare.progress import DELAY_S, NoBar, due, progress_bar
from compare.results import SceneResult
from compare.scenes import SceneSpec, SpeedSpec
from compare.solvers import STRESS, Solution
from compare.solvers import get as get_solver
from ked_check import verdict_rule
from ked_check.verdict_rule import UNCALIBRATED, VerdictMargins, from_record
from ked_linear.settings import HARMONICS
from ked_quasi.harmonics import one_mode_dynamic_estimate
from ked_quasi.linkage import FourBar
from ked_quasi.massmodel import MassModel
from ked_quasi.slidercrank import SliderCrank

if TYPE_CHECKING:
    from ked_check.checkwork import CheckWorkers

TIERS = ("quasi-static", "borderline", "linear", "nonlinear")
DEFAULT_DYNAMIC = default_dynamic()
"""The Exudyn settings of the default campaign (so that a confirmed check is that campaign's scene)."""
MAX_HARMONICS = HARMONICS.hi
"""Crank harmonics the check allows the linear solve when the default maximum did not converge."""


@dataclass(frozen=True)
class LinearRange:
    """Where the linear model agrees with the nonlinear one (from the atlas): speed ratio limits for
    5 % and 10 % history error, each with its spread; ``source`` says where the numbers come from."""

    r5: float = math.nan
    r5_spread: float = math.nan
    r10: float = math.nan
    r10_spread: float = math.nan
    source: str = "no atlas"
    damping_ratio: float = math.nan
    """Damping ratio [1] at which the atlas measured these limits."""

    def lower_limit(self, tolerance: float) -> float:
        """The linear model's limit at ``tolerance``: the lower band of the atlas, r10 - r10_spread
        (r5 - r5_spread below a 10 % tolerance), i.e. the 10th percentile over the families [1]; NaN
        without an atlas."""
        limit, spread = (self.r10, self.r10_spread) if tolerance >= 0.10 else (self.r5, self.r5_spread)
        return limit - (spread if math.isfinite(spread) else 0.0)

    def note(self, damping_ratio: float) -> str:
        """'' or a caution when the checked scene is damped otherwise than the atlas."""
        if not math.isfinite(self.damping_ratio) or math.isclose(damping_ratio, self.damping_ratio):
            return ""
        return (f"; the atlas limit was measured at {self.damping_ratio:g} damping, this check runs at "
                f"{damping_ratio:g}: a guide only, confirm with --confirm")


def verdict_margins(tolerance: float = 0.10, stratum: str = "") -> VerdictMargins:
    """The margins the atlas calibrated at ``tolerance`` [1] for ``stratum`` (published with the package:
    :mod:`ked_check.published`), or :class:`VerdictMargins` () (no quasi-static tier from a prediction)
    when that stratum has no calibration meeting its bound at that tolerance."""
    from ked_check.published import read

    m = read().get("margins", {}).get(f"{100 * tolerance:g}", {})
    m = m.get(stratum) if isinstance(m, dict) else None
    if not isinstance(m, dict):
        return VerdictMargins(source=f"{stratum or 'this stratum'}: not calibrated against Exudyn at "
                                     f"{tolerance:.0%}")
    try:
        return from_record(m)
    except (KeyError, TypeError, ValueError):
        return VerdictMargins(source=f"{stratum}: calibration record unreadable")


@dataclass(frozen=True)
class CheckRow:
    """The check at one crank speed.  Peaks [m] of the deflection vector |d| of P; errors [1]."""

    rpm: float
    speed_ratio: float
    quasi_static_peak_m: float
    linear_peak_m: float
    linear_vs_quasi_static: float
    quasi_static_error_estimate: float
    floquet_max_abs: float
    tier: str
    verdict: str
    flags: tuple[str, ...] = ()
    confirmed: dict[str, float] = field(default_factory=dict)
    key: str = ""
    linear_harmonics: int = 0
    linear_limit_speed_ratio: float = math.nan
    """The linear model's limit used (atlas lower band, :meth:`LinearRange.lower_limit`) [1]."""
    holds_below_error: float = math.nan
    """Predicted quasi-static errors below this hold [1] (holds_below x tolerance)."""
    fails_above_error: float = math.nan
    """Predicted quasi-static errors above this fail [1] (fails_above x tolerance)."""
    margins_source: str = ""
    decided_by: str = "predicted"
    """"measured" when Exudyn's errors decided the tier (``--confirm``), else "predicted"."""
    predicted_tier: str = ""
    """The tier the prediction alone gives (equal to ``tier`` unless a measurement decided)."""
    floquet_steps: int = 0
    """Propagator steps per cycle behind ``floquet_max_abs`` (the reduced system's where its Floquet
    analysis answered; ``ked_linear.LinearResult.floquet_steps``); 0 without a linear solve."""
    floquet_reduced: bool = False
    """Whether the reduced system's Floquet analysis gave ``floquet_max_abs``
    (``ked_linear.LinearResult.floquet_reduced``); else the full model's propagator did."""
    stress: dict[str, float] = field(default_factory=dict)
    """Link stresses and fatigue factors (:func:`ked_check.stresscheck.stress_keys`); empty where not computed."""
    stress_verdict: str = ""
    """Whether the quasi-static stress holds against the linear model's, and that it grants no tier
    (:func:`ked_check.stresscheck.stress_verdict`); empty where the stresses were not computed."""
    fatigue_criterion: str = ""
    """The criterion of the ``safety_factor_*`` stress keys (goodman, gerber, asme-elliptic); empty without a
    material."""


def spec_for(source: FourBar | SliderCrank, mechanism: str, mass_model: MassModel, rpm: float, *,
             stiffness_scale: float = 1.0, damping_ratio: float = 0.02, direction: str = "ccw",
             step_deg: float = 10.0, tolerance: float = 0.10, confirm: bool = False) -> SceneSpec:
    """The campaign scene of one check (the default campaign's grid settings: 3 modes, all outputs)."""
    solvers = ("quasi_static", "linear", "dynamic") if confirm else ("quasi_static", "linear")
    dyn = tuple(sorted(dict(DEFAULT_DYNAMIC, damping_ratio=damping_ratio).items()))
    return SceneSpec(linkage=source, mechanism=mechanism, mass_model=mass_model, speed=SpeedSpec("rpm", float(rpm)),
                     stiffness_scale=stiffness_scale, damping_ratio=damping_ratio, direction=direction,
                     step_deg=step_deg, n_modes=3, outputs=("dx", "dy", "rotation"), tolerance=tolerance, dynamic=dyn,
                     solvers=solvers)


def tier(r: SceneResult, linear_range: LinearRange, tolerance: float,
         margins: VerdictMargins = UNCALIBRATED) -> tuple[str, str]:
    """(tier, one-line verdict) of a checked scene from the prediction (see the module docstring)."""
    qs, lin = r.solutions.get("quasi_static"), r.solutions.get("linear")
    ratio = r.speed_ratio
    if qs is None or not qs.ok:
        return "nonlinear", f"no quasi-static answer ({qs.message if qs else 'not run'}): use the nonlinear model"
    if lin is not None and not lin.ok and lin.failure_class != "physical":  # not a verdict on the physics
        why = lin.message if lin.failure_class == "numerical" else f"the linear model failed: {lin.message}"
        return "nonlinear", f"{why}: no linear prediction; use the nonlinear model (--confirm)"
    if lin is None or not lin.ok:
        why = lin.message if lin is not None else "the linear model did not run"
        return "nonlinear", f"no stable linear steady state ({why}): use the nonlinear model (--confirm)"
    if "weakly_damped" in lin.flags:
        from ked_linear.solver import WEAKLY_DAMPED

        mu, err = lin.stats.get("floquet_max_abs", math.nan), lin.stats.get("floquet_error", math.nan)
        bound = f"{mu:.3g} (+- {err:.1g})" if math.isfinite(err) else f"{mu:.3g}"  # the flag counts the error
        return "nonlinear", (f"weakly damped: max |Floquet multiplier| {bound} not < {WEAKLY_DAMPED:g}, near a "
                             "critical speed (parametric resonance): the linear periodic answer is not valid and the "
                             "nonlinear model may never settle; avoid this speed or add damping")
    large = [f for f in lin.flags if f not in ("unresolved", "weakly_damped")]
    if large:
        return "nonlinear", (f"deflections beyond the small-deflection range ({', '.join(large)}): "
                             "use the nonlinear model (--confirm)")
    if "unresolved" in lin.flags:
        return "nonlinear", (f"the linear model's periodic solve did not converge at "
                             f"{int(lin.stats.get('harmonics', 0))} crank harmonics (estimated error "
                             f"{lin.stats.get('error_estimate', math.nan):.2g} of the peak): use the nonlinear model "
                             "(--confirm)")
    err = metrics.history_error(metrics.vector(qs.deflection), metrics.vector(lin.deflection))
    limit = linear_range.lower_limit(tolerance)
    lo, hi = margins.holds_below * tolerance, margins.fails_above * tolerance
    note = linear_range.note(r.spec.damping_ratio)
    in_range = bool(ratio < limit)  # False when either is NaN (no atlas): never granted blind
    where = (f"r = {ratio:.3g} {'<' if in_range else '>='} {limit:.3g}, the linear model's limit (atlas lower "
             f"band{note})" if math.isfinite(limit) else
             f"r = {ratio:.3g}, the linear model's own limit unknown (no atlas)")
    if qs.flags:
        pass  # a flagged quasi-static answer is never granted: linear or nonlinear below
    elif verdict_rule.calls(err, ratio, limit, True, tolerance, margins.holds_below,
                            margins.fails_above) == verdict_rule.QUASI_STATIC:
        return "quasi-static", (f"quasi-static holds: {err:.1%} off the linear model < {lo:.1%} "
                                f"({margins.holds_below:g} x tolerance; {where})")
    elif err <= hi and not margins.calibrated:
        return "borderline", (f"borderline: quasi-static {err:.1%} off the linear model, and the prediction is "
                              f"not calibrated against Exudyn here ({margins.source}); run --confirm")
    elif err <= hi:
        return "borderline", (f"borderline: quasi-static {err:.1%} off the linear model, between "
                              f"{lo:.1%} and {hi:.1%} where the prediction cannot decide" if in_range else
                              f"borderline: quasi-static {err:.1%} off the linear model, which is not "
                              f"safely in range ({where})") + "; run --confirm"
    if in_range:
        return "linear", f"quasi-static {err:.0%} off: use the linear model ({where})"
    return "nonlinear", f"quasi-static {err:.0%} off, and {where}: use the nonlinear model (--confirm)"


def measured_tier(confirmed: dict[str, float], tolerance: float) -> tuple[str, str] | None:
    """(tier, verdict) decided by the errors measured against Exudyn, or None without a measurement:
    quasi-static if its error is below the tolerance, else linear if the linear model's is, else
    nonlinear."""
    q, lin = confirmed.get("quasi_static_vs_dynamic"), confirmed.get("linear_vs_dynamic")
    if q is None or not math.isfinite(q):
        return None
    text = f"measured: quasi-static {q:.1%} vs Exudyn"
    if q < tolerance:
        return "quasi-static", f"{text} < {tolerance:.0%}: quasi-static holds"
    text += f" >= {tolerance:.0%}, linear {lin:.1%}" if lin is not None and math.isfinite(lin) else ""
    if lin is not None and lin < tolerance:
        return "linear", f"{text} < {tolerance:.0%}: use the linear model"
    return "nonlinear", f"{text}: use the nonlinear model"


def check_row(r: SceneResult, linear_range: LinearRange, tolerance: float,
              margins: VerdictMargins = UNCALIBRATED) -> CheckRow:
    """The check's numbers of one computed scene; with an Exudyn solution its measured errors (the
    campaign's own pair metrics) decide the tier."""
    nan = math.nan
    qs, lin = r.solutions.get("quasi_static"), r.solutions.get("linear")
    ratio = r.speed_ratio
    qs_xy = metrics.vector(qs.deflection) if qs is not None and qs.ok else None
    lin_xy = metrics.vector(lin.deflection) if lin is not None and lin.ok else None
    est = nan
    if qs_xy is not None and math.isfinite(ratio):
        est = metrics.history_error(qs_xy, one_mode_dynamic_estimate(qs_xy, ratio, r.spec.damping_ratio))
    predicted, verdict = tier(r, linear_range, tolerance, margins)
    name, decided_by = predicted, "predicted"
    confirmed = {}
    dyn = r.solutions.get("dynamic")
    if dyn is not None and dyn.ok and dyn.flags:  # beyond the small-deflection range: not a valid measurement
        confirmed = {"dynamic_flagged": 1.0}
        verdict += (f" [Exudyn answer outside the small-deflection range ({', '.join(dyn.flags)}): not a valid "
                    "measurement, the prediction stands]")
    elif "dynamic" in r.solutions and r.solutions["dynamic"].ok:
        confirmed = {f"{n}_vs_dynamic": r.metrics[f"{n}_vs_dynamic"].verdict_error
                     if f"{n}_vs_dynamic" in r.metrics else nan for n in ("quasi_static", "linear")}
        measured = measured_tier(confirmed, tolerance)
        if measured is not None:
            name, verdict = measured
            decided_by = "measured"
            if predicted != name:
                verdict += f" (predicted: {predicted})"
    elif "dynamic" in r.solutions:
        confirmed = {"dynamic_failed": 1.0}
        verdict += " [Exudyn failed: the prediction stands]"
    return CheckRow(
        rpm=r.rpm, speed_ratio=ratio, quasi_static_peak_m=metrics.peak(qs_xy) if qs_xy is not None else nan,
        linear_peak_m=metrics.peak(lin_xy) if lin_xy is not None else nan,
        linear_vs_quasi_static=metrics.history_error(qs_xy, lin_xy) if lin_xy is not None and qs_xy is not None
        else nan, quasi_static_error_estimate=est,
        floquet_max_abs=float(lin.stats.get("floquet_max_abs", nan)) if lin is not None else nan,
        tier=name, verdict=verdict, flags=_row_flags(qs, lin, r.solutions.get("dynamic")),
        confirmed=confirmed, key=r.key, linear_harmonics=int(lin.stats.get("harmonics", 0)) if lin is not None else 0,
        linear_limit_speed_ratio=linear_range.lower_limit(tolerance), holds_below_error=margins.holds_below * tolerance,
        fails_above_error=margins.fails_above * tolerance, margins_source=margins.source, decided_by=decided_by,
        predicted_tier=predicted, floquet_steps=int(lin.stats.get("floquet_steps", 0)) if lin is not None else 0,
        floquet_reduced=bool(lin.stats.get("floquet_reduced", False)) if lin is not None else False,
    )


LINEAR_FAILED = "linear_failed"
"""Flag of a check row whose linear solve failed without a physical verdict (numerically, or it could not run)."""


def _row_flags(qs: Solution | None, lin: Solution | None, dyn: Solution | None) -> tuple[str, ...]:
    """The validity flags of every tier's answer (quasi-static, linear, Exudyn), plus :data:`LINEAR_FAILED`."""
    found = {*(qs.flags if qs else ()), *(lin.flags if lin else ()), *(dyn.flags if dyn is not None and dyn.ok else ())}
    if lin is not None and not lin.ok and lin.failure_class != "physical":
        found.add(LINEAR_FAILED)
    return tuple(sorted(found))


def linear_range(mass_model: str, kind: str = "four-bar") -> LinearRange:
    """The linear model's limits for a mass model of a linkage ``kind`` from its atlas (published with the
    package: :mod:`ked_check.published`); NaN limits when there are none."""
    from ked_check.published import kind_limits, read

    rec = read()
    t = kind_limits(rec, kind).get(mass_model)
    if not isinstance(t, dict):
        return LinearRange()

    def num(key: str) -> float:
        v = t.get(key)
        return float(v) if isinstance(v, (int, float)) else math.nan

    return LinearRange(r5=num("linear_r5"), r5_spread=num("linear_r5_spread"), r10=num("linear_r10"),
                       r10_spread=num("linear_r10_spread"), source="atlas",
                       damping_ratio=float(rec.get("damping_ratio", math.nan)))


def check(source: FourBar | SliderCrank, mechanism: str, mass_model: MassModel, rpms: Sequence[float], *,
          stiffness_scale: float = 1.0, damping_ratio: float = 0.02, direction: str = "ccw", step_deg: float = 10.0,
          tolerance: float = 0.10, confirm: bool = False, bar: Any = None,
          workers: CheckWorkers | None = None, specs: Sequence[SceneSpec] | None = None,
          material: Any = None) -> list[CheckRow]:
    """The design check of one linkage at each of ``rpms`` [rev/min] (see the module docstring).  A
    slider-crank (``source`` a ``SliderCrank``) uses its own atlas's limits and margins (the slider atlas: the
    four-bar atlas's do not apply); where its stratum has no calibration only a measurement (``confirm``)
    grants the quasi-static tier.  ``bar``: a progress bar (:func:`progress`) advanced per speed; default: one
    of its own.
    ``workers``: where the speeds after the first two go when their estimated work is worth worker processes
    (:class:`ked_check.checkwork.CheckWorkers`; the rows are the same).  ``specs``: the campaign scenes to check
    in place of :func:`spec_for`'s (a user file's scenes, :func:`compare.scenefile.file_scenes`: the key and the
    answer ``ked run`` gives the file).  ``material``: a :class:`ked_quasi.fatigue.Material` for the fatigue
    safety factors of the rows' stress keys (:mod:`ked_check.stresscheck`)."""
    if specs is None:
        specs = [spec_for(source, mechanism, mass_model, rpm, stiffness_scale=stiffness_scale,
                          damping_ratio=damping_ratio, direction=direction, step_deg=step_deg, tolerance=tolerance)
                 for rpm in rpms]
    else:
        specs = [replace(s, solvers=("quasi_static", "linear")) for s in specs]
    rng = linear_range(specs[0].mass_model.name, specs[0].kind)
    margins = verdict_margins(tolerance, verdict_rule.stratum(specs[0].kind, specs[0].mass_model.name,
                                                              specs[0].mechanism))
    rows: list[CheckRow] = []
    with progress(len(rpms)) if bar is None else contextlib.nullcontext(bar) as bar:
        def done_on_a_worker(j: int, row: CheckRow) -> None:
            status(bar, f"{rpm_text(row.rpm)} rpm")
            advance(bar)

        for i, spec in enumerate(specs):
            if workers is not None and workers.worth(workers.speeds, len(specs) - i):
                rest = specs[i:]
                rows += workers.map(row_task, [(s, rng, margins, confirm, None, material) for s in rest],
                                    [f"the check at {rpm_text(s.speed.value)} rpm" for s in rest], done_on_a_worker,
                                    cost=[s.speed.value for s in rest])  # faster: more harmonics, richer bases
                break

            def one(spec: SceneSpec = spec) -> CheckRow:
                return check_spec(spec, rng, margins, confirm, bar, material)

            rows.append(one() if workers is None else workers.speeds.timed(one))
            advance(bar)
    return rows


PROGRESS_DELAY_S = DELAY_S
"""A check running longer than this shows a progress bar on stderr (only on a terminal)."""


_NoBar = NoBar


def progress(total: int) -> Any:
    """The progress bar (:func:`compare.progress.progress_bar`) over ``total`` steps of a check (its
    speeds, then the critical-speed sweep's Floquet evaluations), shown after :data:`PROGRESS_DELAY_S`."""
    return progress_bar(total, "ked check", unit="step", delay=PROGRESS_DELAY_S)


def _due(bar: Any) -> bool:
    return due(bar)


def status(bar: Any, text: str) -> None:
    """Say on ``bar`` which stage runs (drawn once its delay has passed)."""
    bar.set_postfix_str(text, refresh=_due(bar))


def redraw(bar: Any) -> None:
    """Draw ``bar`` again (after its total changed) once its delay has passed."""
    if _due(bar):
        bar.refresh()


def advance(bar: Any) -> None:
    """One more step done on ``bar``, its total raised when the work outgrows it (the refinement of the
    critical speeds takes as many Floquet evaluations as their peaks need)."""
    if bar.total is not None and bar.n + 1 > bar.total:
        bar.total = bar.n + 1
        redraw(bar)
    bar.update(1)


def check_spec(spec: SceneSpec, rng: LinearRange, margins: VerdictMargins, confirm: bool = False,
                bar: Any = None, material: Any = None) -> CheckRow:
    """The check of one speed's scene (:func:`spec_for`); ``bar``: a progress bar that says which stage runs;
    ``material``: a :class:`ked_quasi.fatigue.Material` for the link stresses and fatigue safety factors (None:
    neither is computed, so a check without a material costs what it did)."""
    bar = _NoBar() if bar is None else bar
    rpm = spec.speed.value
    status(bar, f"{rpm_text(rpm)} rpm")
    r = _run(spec)
    if _unresolved(r):
        status(bar, f"{rpm_text(rpm)} rpm, {MAX_HARMONICS} harmonics")
        spec = with_more_harmonics(spec)
        r = _run(spec)
    if confirm:  # with a material, Exudyn's link stresses too (the scene with the output stress)
        status(bar, f"{rpm_text(rpm)} rpm, Exudyn")
        outputs = (*spec.outputs, STRESS) if material is not None else spec.outputs
        r = _run(replace(spec, solvers=(*spec.solvers, "dynamic"), outputs=outputs))
    row = check_row(r, rng, spec.tolerance, margins)
    if spec.extra_settings:
        how = (f"with {row.linear_harmonics} crank harmonics" if row.linear_harmonics > 0
               else "on the co-rotating reduced basis")
        row = replace(row, verdict=f"{row.verdict} [linear model solved {how}: the default at most 32 "
                                   "harmonics did not converge]")
    if material is None:
        return row
    from ked_check.stresscheck import measured_stress_keys, stress_verdict

    keys = {**_stress(spec, r, material), **measured_stress_keys(r)}
    return replace(row, stress=keys, stress_verdict=stress_verdict(keys, spec.tolerance),
                   fatigue_criterion=material.criterion)


def row_task(*args: Any) -> Any:
    """One speed of a check on a worker (:func:`check_spec`), a refusal kept as data."""
    from ked_check.checkwork import kept

    return kept(lambda: check_spec(*args))


def _stress(spec: SceneSpec, r: SceneResult, material: Any) -> dict[str, float]:
    """The stress keys of one computed scene (:mod:`ked_check.stresscheck`); the linear tier where it answered."""
    from compare.execute import settings_of
    from ked_check.stresscheck import stress_keys

    lin = r.solutions.get("linear")
    settings = settings_of(get_solver("linear"), spec) if lin is not None else None
    return stress_keys(spec.scene(r.rpm), settings, lin is not None and lin.ok, material)


def _run(spec: SceneSpec) -> SceneResult:
    r = run_scene(spec, [get_solver(n) for n in spec.solvers])
    if r.stage in ("setup", "metrics"):
        raise ValueError(f"{r.stage}: {r.message}")
    return r


def _unresolved(r: SceneResult) -> bool:
    """True when the linear solve is stable, small-deflection, but not converged below its harmonics cap
    (with large deflections more harmonics would not change the tier)."""
    lin = r.solutions.get("linear")
    return (lin is not None and lin.ok and lin.flags == ("unresolved",)
            and int(lin.stats.get("harmonics", MAX_HARMONICS)) < MAX_HARMONICS)


def with_more_harmonics(spec: SceneSpec) -> SceneSpec:
    """The scene with the linear solve allowed :data:`MAX_HARMONICS` crank harmonics."""
    return replace(spec, extra_settings=(("linear", (("max_harmonics", MAX_HARMONICS),)),))
