"""The design check: for one linkage at one or more crank speeds, how wrong is the quasi-static answer,
and which model is needed.

Every speed is one campaign scene computed by :func:`compare.execute.run_scene` (the same code path,
hence the same numbers a campaign stores) with the quasi-static and the linear solver, and Exudyn too
when asked to confirm.  The tier rule (:func:`tier`):

* **quasi-static** when the linear model is stable, inside its small-deflection range, and the
  quasi-static history differs from it by less than the tolerance (that difference is the dynamic
  part of the quasi-static error);
* **linear** when the linear model is needed (or the quasi-static answer is flagged) and the speed
  ratio is below the linear model's own limit from the atlas (its agreement with Exudyn), the
  atlas's uncertainty counting against it;
* **nonlinear** otherwise (no stable linear steady state, large deflections, or beyond the linear
  model's limit): the Exudyn model is the answer (``--confirm`` runs it).

The linear solve uses the default settings (at most 32 crank harmonics); when its periodic solve has not
converged there (a frozen higher mode sweeping over many harmonics in a cycle), the check solves the
scene again with up to :data:`MAX_HARMONICS` before judging, and says so in the verdict.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

from compare import metrics
from compare.execute import run_scene
from compare.inspect import speed_ratio
from compare.results import SceneResult
from compare.scenes import SceneSpec, SpeedSpec
from compare.solvers import get as get_solver
from ked_linear.settings import HARMONICS
from ked_quasi.harmonics import one_mode_dynamic_estimate
from ked_quasi.linkage import FourBar
from ked_quasi.massmodel import MassModel

TIERS = ("quasi-static", "linear", "nonlinear")
DEFAULT_DYNAMIC = (("element", "ancf"), ("elements_per_link", 4), ("spectral_radius", 0.9), ("steps_per_cycle", 720))
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

    def note(self, damping_ratio: float) -> str:
        """'' or a caution when the checked scene is damped otherwise than the atlas."""
        if not math.isfinite(self.damping_ratio) or math.isclose(damping_ratio, self.damping_ratio):
            return ""
        return (f"; the atlas limit was measured at {self.damping_ratio:g} damping, this check runs at "
                f"{damping_ratio:g}: a guide only, confirm with --confirm")


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


def spec_for(source: FourBar, mechanism: str, mass_model: MassModel, rpm: float, *, stiffness_scale: float = 1.0,
             damping_ratio: float = 0.02, direction: str = "ccw", step_deg: float = 10.0, tolerance: float = 0.10,
             confirm: bool = False) -> SceneSpec:
    """The campaign scene of one check (the default campaign's grid settings: 3 modes, all outputs)."""
    solvers = ("quasi_static", "linear", "dynamic") if confirm else ("quasi_static", "linear")
    dyn = tuple(sorted(dict(DEFAULT_DYNAMIC, damping_ratio=damping_ratio).items()))
    return SceneSpec(linkage=source, mechanism=mechanism, mass_model=mass_model, speed=SpeedSpec("rpm", float(rpm)),
                     stiffness_scale=stiffness_scale, damping_ratio=damping_ratio, direction=direction,
                     step_deg=step_deg, n_modes=3, outputs=("dx", "dy", "rotation"), tolerance=tolerance, dynamic=dyn,
                     solvers=solvers)


def tier(r: SceneResult, linear_range: LinearRange, tolerance: float) -> tuple[str, str]:
    """(tier, one-line verdict) of a checked scene (see the module docstring)."""
    qs, lin = r.solutions.get("quasi_static"), r.solutions.get("linear")
    ratio = speed_ratio(r)
    if qs is None or not qs.ok:
        return "nonlinear", f"no quasi-static answer ({qs.message if qs else 'not run'}): use the nonlinear model"
    if lin is None or not lin.ok:
        why = lin.message if lin is not None else "the linear model did not run"
        return "nonlinear", f"no stable linear steady state ({why}): use the nonlinear model (--confirm)"
    if "weakly_damped" in lin.flags:
        from ked_linear.solver import WEAKLY_DAMPED

        mu = lin.stats.get("floquet_max_abs", math.nan)
        return "nonlinear", (f"weakly damped: max |Floquet multiplier| {mu:.3g} >= {WEAKLY_DAMPED:g}, near a critical "
                             "speed (parametric resonance): the linear periodic answer is not valid and the nonlinear "
                             "model may never settle; avoid this speed or add damping")
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
    if err < tolerance and not qs.flags:
        return "quasi-static", f"quasi-static holds: it differs from the linear model by {err:.1%} < {tolerance:.0%}"
    limit = linear_range.r10 if tolerance >= 0.10 else linear_range.r5
    spread = linear_range.r10_spread if tolerance >= 0.10 else linear_range.r5_spread
    note = linear_range.note(r.spec.damping_ratio)
    if math.isfinite(limit) and ratio > limit - (spread if math.isfinite(spread) else 0.0):
        return "nonlinear", (f"quasi-static is {err:.0%} off, and r = {ratio:.3g} is not safely below the linear "
                             f"model's limit (r = {limit:.3g}, {spread:.2g} below it for 10 % of the "
                             f"{linear_range.source} linkages{note}): use the nonlinear model")
    bound = f"valid up to r = {limit:.3g} - {spread:.2g} ({linear_range.source}{note})" if math.isfinite(limit) \
        else "its own limit unknown without an atlas: confirm with --confirm"
    return "linear", f"quasi-static is {err:.0%} off: use the linear model ({bound})"


def check_row(r: SceneResult, linear_range: LinearRange, tolerance: float) -> CheckRow:
    """The check's numbers of one computed scene."""
    nan = math.nan
    qs, lin = r.solutions.get("quasi_static"), r.solutions.get("linear")
    ratio = speed_ratio(r)
    qs_xy = metrics.vector(qs.deflection) if qs is not None and qs.ok else None
    lin_xy = metrics.vector(lin.deflection) if lin is not None and lin.ok else None
    est = nan
    if qs_xy is not None and math.isfinite(ratio):
        est = metrics.history_error(qs_xy, one_mode_dynamic_estimate(qs_xy, ratio, r.spec.damping_ratio))
    name, verdict = tier(r, linear_range, tolerance)
    confirmed = {}
    if "dynamic" in r.solutions and r.solutions["dynamic"].ok:
        dyn = metrics.vector(r.solutions["dynamic"].deflection)
        confirmed = {"quasi_static_vs_dynamic": metrics.history_error(qs_xy, dyn) if qs_xy is not None else nan,
                     "linear_vs_dynamic": metrics.history_error(lin_xy, dyn) if lin_xy is not None else nan}
    elif "dynamic" in r.solutions:
        confirmed = {"dynamic_failed": 1.0}
    return CheckRow(
        rpm=r.rpm, speed_ratio=ratio, quasi_static_peak_m=metrics.peak(qs_xy) if qs_xy is not None else nan,
        linear_peak_m=metrics.peak(lin_xy) if lin_xy is not None else nan,
        linear_vs_quasi_static=metrics.history_error(qs_xy, lin_xy) if lin_xy is not None and qs_xy is not None
        else nan, quasi_static_error_estimate=est,
        floquet_max_abs=float(lin.stats.get("floquet_max_abs", nan)) if lin is not None else nan,
        tier=name, verdict=verdict, flags=tuple(sorted({*(qs.flags if qs else ()), *(lin.flags if lin else ())})),
        confirmed=confirmed, key=r.key, linear_harmonics=int(lin.stats.get("harmonics", 0)) if lin is not None else 0,
    )


def linear_range(mass_model: str) -> LinearRange:
    """The linear model's limits for a mass model, from the committed atlas (NaN when there is none)."""
    try:
        from compare.atlas import limits
        from compare.atlas.compute import DAMPING
    except ImportError:
        return LinearRange()
    try:
        t = limits(mass_model)
    except (OSError, ValueError, KeyError):
        return LinearRange()
    return LinearRange(r5=t.linear_r5, r5_spread=t.linear_r5_spread, r10=t.linear_r10, r10_spread=t.linear_r10_spread,
                       source="atlas", damping_ratio=DAMPING)


def check(source: FourBar, mechanism: str, mass_model: MassModel, rpms: Sequence[float], *,
          stiffness_scale: float = 1.0, damping_ratio: float = 0.02, direction: str = "ccw", step_deg: float = 10.0,
          tolerance: float = 0.10, confirm: bool = False) -> list[CheckRow]:
    """The design check of one linkage at each of ``rpms`` [rev/min] (see the module docstring)."""
    rng = linear_range(mass_model.name)
    rows = []
    for rpm in rpms:
        spec = spec_for(source, mechanism, mass_model, rpm, stiffness_scale=stiffness_scale,
                        damping_ratio=damping_ratio, direction=direction, step_deg=step_deg, tolerance=tolerance)
        r = _run(spec)
        if _unresolved(r):
            spec = with_more_harmonics(spec)
            r = _run(spec)
        if confirm:
            r = _run(replace(spec, solvers=(*spec.solvers, "dynamic")))
        row = check_row(r, rng, tolerance)
        if spec.extra_settings:
            row = replace(row, verdict=f"{row.verdict} [linear model solved with {row.linear_harmonics} crank "
                                       "harmonics: the default at most 32 did not converge]")
        rows.append(row)
    return rows


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
