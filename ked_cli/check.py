"""``ked check``: for any four-bar, how fast is too fast for the quasi-static analysis, how wrong it is
at a given speed, and which model is needed (:mod:`ked_check.check`)."""

from __future__ import annotations

import math
import textwrap
from dataclasses import asdict

import click

from ked_cli.options import (
    RuleType,
    cap_workers,
    file_scene_specs,
    is_file,
    json_text,
    linkage_option,
    load_source,
    refuse_fast,
    refuse_fast_slider,
    refuse_oversized,
)
from ked_quasi import rules
from ked_quasi.fatigue import CRITERIA
from ked_quasi.linkage import DIRECTIONS
from ked_quasi.massmodel import MASS_MODELS

WIDTH = 100
"""Columns of the printed verdict lines."""


def _rpm_range(text: str | None) -> list[float]:
    if not text:
        return []
    try:
        start, stop, n = text.split(":")
        a, b, k = float(start), float(stop), int(n)
    except ValueError:
        raise click.BadParameter(f"{text!r}: expected START:STOP:N, e.g. 50:300:6", param_hint="--rpm-range") from None
    if not 1 <= k <= 200:
        raise click.BadParameter("N must be 1..200", param_hint="--rpm-range")
    if k > 1 and a == b:
        raise click.BadParameter(f"{text!r}: START = STOP gives {k} equal speeds; use N = 1", param_hint="--rpm-range")
    values = [a + (b - a) * i / max(k - 1, 1) for i in range(k)]
    for v in values:
        try:
            rules.RPM.check(v)
        except ValueError as exc:
            raise click.BadParameter(str(exc).removeprefix("rpm: "), param_hint="--rpm-range") from None
    return values


@click.command("check")
@linkage_option()
@click.option("--mechanism", type=click.Choice(["source", "cognate"]), default="source", show_default=True,
              help="The source four-bar or its crank-driven Roberts cognate.")
@click.option("--mass-model", type=click.Choice(MASS_MODELS), default="tip", show_default=True,
              help="tip (Case I), joints (Case II), extender (Case III), distributed.")
@click.option("--rpm", "rpms", multiple=True, type=RuleType(rules.RPM),
              help=f"Crank speed(s): {rules.RPM.allowed()}; repeatable [default: 300].")
@click.option("--rpm-range", default=None, metavar="START:STOP:N", help="N crank speeds from START to STOP rpm.")
@click.option("--lumps", type=RuleType(rules.LUMPS), default=rules.DEFAULT_LUMPS, show_default=True,
              help=f"Lumps per distributed link (extender, distributed models): {rules.LUMPS.allowed()}.")
@click.option("--payload-kg", type=RuleType(rules.PAYLOAD_KG), default=None,
              help="Point mass at P [kg] [default: 2 lb for tip, else 0].")
@click.option("--stiffness-scale", type=RuleType(rules.STIFFNESS_SCALE), default=1.0, show_default=True,
              help=f"Multiply every Young's modulus: {rules.STIFFNESS_SCALE.allowed()}.")
@click.option("--direction", type=click.Choice(DIRECTIONS), default="ccw", show_default=True,
              help="Crank direction (the linear and Exudyn answers depend on it).")
@click.option("--damping-ratio", type=RuleType(rules.DAMPING_RATIO), default=rules.DEFAULT_DAMPING_RATIO,
              show_default=True,
              help=f"Modal damping ratio of the linear and Exudyn models: {rules.DAMPING_RATIO.allowed()} "
                   "(the atlas limits were measured at 0.02).")
@click.option("--tolerance", type=RuleType(rules.TOLERANCE), default=rules.DEFAULT_TOLERANCE, show_default=True,
              help="Relative history error accepted.")
@click.option("--confirm", is_flag=True, help="Also run the Exudyn model and report the three errors it measures.")
@click.option("--ultimate-strength", type=float, default=None, metavar="PA",
              help="Ultimate tensile strength S_u of the links' material [Pa], for the fatigue safety factor (with "
                   "--endurance-limit; both override a linkage file's [fatigue] table).")
@click.option("--endurance-limit", type=float, default=None, metavar="PA",
              help="Corrected endurance limit S_e of the links' material [Pa] (at most S_u), for the fatigue "
                   "safety factor (Goodman: 1/n = sigma_a/S_e + sigma_m/S_u at the link's worst fibre).")
@click.option("--fatigue-criterion", type=click.Choice(CRITERIA), default=None,
              help="Mean-stress criterion of the fatigue safety factor [default: the linkage file's [fatigue] "
                   "criterion, else goodman]; asme-elliptic needs the yield strength (the file's yield_strength).")
@click.option("--json", "as_json", is_flag=True, help="Print a JSON list, one object per speed.")
@click.option("--workers", type=click.IntRange(min=1), callback=cap_workers, default=None,
              help="Local worker processes for the speeds and the critical-speed sweep, used where the time "
                   "they save (estimated from the first two speeds, or sweep evaluations, timed here) exceeds "
                   "their start-up (1: all in this process) [default: available CPUs].")
def check(linkage: str, mechanism: str, mass_model: str, rpms: tuple[float, ...], rpm_range: str | None,
          lumps: int, payload_kg: float | None, stiffness_scale: float, direction: str, damping_ratio: float,
          tolerance: float, confirm: bool, ultimate_strength: float | None, endurance_limit: float | None,
          fatigue_criterion: str | None, as_json: bool, workers: int | None) -> None:
    """Design check: per speed, r = Omega/omega1_min, the quasi-static and linear peaks, how far the
    quasi-static answer is from the linear model, Floquet max |mu|, the one-mode estimate of the
    quasi-static error, the tier needed (quasi-static / borderline / linear / nonlinear) and a verdict.

    Every error is the history error of the deflection vector d = (dx, dy) of P, max|d - d_ref| /
    max|d_ref|: the measure of the campaign verdict of `ked run`.  A tier is granted only where the
    model it is judged against is inside its own range: quasi-static needs r below the linear model's
    limit (the atlas's lower band) and a predicted error below holds_below x tolerance; between that
    and fails_above x tolerance the tier is borderline (run --confirm).  With --confirm the errors
    measured against Exudyn decide the tier.

    A slider-crank (--linkage simeon or a TOML [linkage] table with kind = "slider-crank"; mass model
    distributed unless given) is judged by the slider atlas's limits and its own strata's margins; a
    stratum without calibration grants no quasi-static tier from a prediction (run --confirm).

    \b
    JSON keys per speed: speed_ratio, quasi_static_peak_m, linear_peak_m,
    linear_vs_quasi_static, quasi_static_error_estimate, floquet_max_abs, tier
    ("quasi-static", "borderline", "linear" or "nonlinear"), verdict, rpm, flags,
    confirmed (quasi_static_vs_dynamic, linear_vs_dynamic: measured errors), key,
    linear_harmonics (crank harmonics the linear solve used; 0: the co-rotating reduced basis),
    linear_limit_speed_ratio (the linear model's limit used: atlas lower band),
    holds_below_error, fails_above_error (predicted-error bounds of the borderline
    band), margins_source (where those margins come from), decided_by
    ("measured" or "predicted"), predicted_tier (the tier without the measurement),
    critical_speeds_rpm and amplification_peaks_rpm (the same in every object: with
    three speeds or more, the local maxima over the speeds checked of max |Floquet
    multiplier|, refined by the Floquet part alone, and of the amplification linear /
    quasi-static peak; else empty), floquet_steps (propagator steps per cycle behind
    floquet_max_abs), floquet_reduced (true when the reduced system's Floquet analysis
    gave it), stress (given --ultimate-strength and --endurance-limit, or a linkage file's [fatigue]
    table with ultimate_strength, endurance_limit and optionally yield_strength [Pa]; per link:
    quasi_static_peak_pa_<link> and linear_peak_pa_<link>, the peak |normal stress| [Pa]
    over the link and the cycle; stress_error_<link>, the quasi-static stress history's
    error against the linear one, peak-normalised; goodman_quasi_static, goodman_linear, the
    smallest Goodman safety factor over the links, and goodman_overstatement =
    goodman_quasi_static / goodman_linear - 1; safety_factor_quasi_static,
    safety_factor_linear, safety_factor_overstatement: the same by the criterion named in
    fatigue_criterion (--fatigue-criterion or the file's criterion); with the file's sn_curve:
    life_cycles_quasi_static, life_cycles_linear (shortest life over the links; null beyond the
    curve, where life_unbounded_<tier> is 1), life_overstatement (their ratio) and
    life_above_curve (1: a stress above the curve's first point); a slider-crank: crank and
    coupler), and
    stress_verdict (text: whether the quasi-static stress of every link is within the tolerance of
    the linear one; it grants no tier, the stress prediction being uncalibrated against Exudyn; with
    --confirm, measured against Exudyn's stresses: keys exudyn_peak_pa_<link>,
    stress_error_exudyn_<link>, linear_stress_error_exudyn_<link>).
    """
    from compare.inspect import rpm_text
    from ked_check.checkwork import CheckWorkerError
    from ked_check.report import run as run_check
    from ked_check.stresscheck import fatigue_line
    from ked_cli.quasi import slider_source
    from ked_quasi.massmodel import MassModel, default_payload
    from ked_quasi.scene import variant

    speeds = list(rpms) + _rpm_range(rpm_range) or [300.0]
    slider = slider_source(linkage)
    specs = None
    if is_file(linkage):  # the file's scene (grid, campaign, solver tables), the options given overriding it
        specs = file_scene_specs(linkage, mechanism=mechanism, mass_model=mass_model, lumps=lumps,
                                 payload_kg=payload_kg, stiffness_scale=stiffness_scale, direction=direction,
                                 rpms=list(rpms) + _rpm_range(rpm_range), damping_ratio=damping_ratio, single=False,
                                 tolerance=tolerance)
        s0 = specs[0]
        speeds = [s.speed.value for s in specs]
        mechanism, mass_model, stiffness_scale, direction = s0.mechanism, s0.mass_model.name, s0.stiffness_scale, \
            s0.direction
        damping_ratio, tolerance, lumps, payload_kg = s0.damping_ratio, s0.tolerance, s0.mass_model.lumps, \
            s0.mass_model.payload
    elif slider is not None:
        mass_model = _slider_mass_model(mechanism, mass_model)
    try:
        material = _material(ultimate_strength, endurance_limit)
        if material is None and is_file(linkage):  # the file's [fatigue] table, unless the options give one
            from ked_cli.options import scene_file

            material = scene_file(linkage).fatigue
        material = _with_criterion(material, fatigue_criterion)
        mm = MassModel(mass_model, lumps=lumps, payload=default_payload(mass_model) if payload_kg is None
                       else payload_kg) if specs is None else specs[0].mass_model
        from ked_check.check import spec_for

        if slider is None:
            source = load_source(linkage)
            refuse_fast(variant(source, mechanism, stiffness_scale, direction), mm, speeds,
                        specs[0].step_deg if specs else 10.0, "--rpm")
        else:
            source = slider
            first = specs[0] if specs else spec_for(slider, mechanism, mm, speeds[0], stiffness_scale=stiffness_scale,
                                                    direction=direction)
            refuse_fast_slider(first.scene(speeds[0]), speeds, "--rpm")
        first = specs[0] if specs else spec_for(source, mechanism, mm, speeds[0], stiffness_scale=stiffness_scale,
                                                direction=direction)
        refuse_oversized(first.scene(speeds[0]))
        report = run_check(source, mechanism, mm, speeds, stiffness_scale=stiffness_scale,
                           damping_ratio=damping_ratio, direction=direction, tolerance=tolerance, confirm=confirm,
                           workers=workers, specs=specs, material=material)
    except ValueError as exc:
        raise click.UsageError(str(exc)) from None
    except CheckWorkerError as exc:
        raise click.ClickException(str(exc)) from None
    rows, crit, amp = report.rows, report.critical_speeds, report.amplification_peaks_rpm
    if as_json:
        extra = {"critical_speeds_rpm": [c.rpm for c in crit], "amplification_peaks_rpm": list(amp)}
        click.echo(json_text([{**asdict(r), **extra} for r in rows]))
        return
    click.echo(textwrap.fill(f"Design check: {linkage} linkage, {mechanism}, mass model {mass_model}, damping "
                             f"{damping_ratio:g}, tolerance {tolerance:.0%}", width=WIDTH, subsequent_indent="  ",
                             break_on_hyphens=False, break_long_words=False))
    head = f"{'rpm':>7} {'r':>6} {'qs peak':>8} {'lin peak':>9} {'qs vs':>7} {'1-mode':>7} {'|mu|':>6}  {'tier':<12}"
    units = f"{'':>7} {'':>6} {'mm':>8} {'mm':>9} {'lin':>7} {'est.':>7} {'':>6}  {'':<12}"
    if confirm:
        head += f" {'Exudyn:':>8} {'Exudyn:':>8}"
        units += f" {'qs err':>8} {'lin err':>8}"
    click.echo(head.rstrip())
    click.echo(units.rstrip())
    for r in rows:
        line = (f"{r.rpm:7.1f} {r.speed_ratio:6.3f} {1e3 * r.quasi_static_peak_m:8.4g} {1e3 * r.linear_peak_m:9.4g} "
                f"{_pct(r.linear_vs_quasi_static):>7} {_pct(r.quasi_static_error_estimate):>7} "
                f"{r.floquet_max_abs:6.3f}  {r.tier:<12}")
        if confirm:
            c = r.confirmed
            line += (f" {'failed':>8} {'-':>8}" if "dynamic_failed" in c else
                     f" {_pct(c.get('quasi_static_vs_dynamic')):>8} {_pct(c.get('linear_vs_dynamic')):>8}")
        click.echo(line.rstrip())
        click.echo(textwrap.fill(r.verdict, width=WIDTH, initial_indent=" " * 9, subsequent_indent=" " * 11,
                                 break_on_hyphens=False))
        for text in ((r.stress_verdict, fatigue_line(r.stress, r.fatigue_criterion)) if r.stress else ()):
            click.echo(textwrap.fill(text, width=WIDTH, initial_indent=" " * 9, subsequent_indent=" " * 11,
                                     break_on_hyphens=False))
    if len(rows) >= 3:
        for text in ("Critical speeds, i.e. of weakest damping (parametric resonance: local maxima of max |Floquet "
                     "multiplier|; transients die out slowest): "
                     + (", ".join(f"{rpm_text(c.rpm)} rpm (|mu| {c.max_abs:.3g})" for c in crit)
                        or "none in this range"),
                     "Amplification peaks (forced resonance: local maxima of the linear / quasi-static peak; keep "
                     "the operating speed away from these): "
                     + (", ".join(f"{rpm_text(a)} rpm" for a in amp) or "none in this range")):
            click.echo(textwrap.fill(text, width=WIDTH, subsequent_indent="  ", break_on_hyphens=False))
    click.echo(textwrap.fill(
        "r = Omega/omega1_min; qs vs lin: the quasi-static answer's history error against the linear KED answer; "
        "1-mode est.: its one-mode harmonic estimate; |mu|: Floquet max |multiplier| of the linear model"
        + ("; Exudyn: the errors measured against Exudyn" if confirm else ""),
        width=WIDTH, subsequent_indent="  ", break_on_hyphens=False))


def _material(ultimate_strength: float | None, endurance_limit: float | None) -> object:
    """The fatigue material of --ultimate-strength and --endurance-limit (both or neither)."""
    from ked_quasi.fatigue import Material

    if ultimate_strength is None and endurance_limit is None:
        return None
    if ultimate_strength is None or endurance_limit is None:
        missing = "--ultimate-strength" if ultimate_strength is None else "--endurance-limit"
        raise ValueError(f"{missing}: the fatigue safety factor needs both --ultimate-strength and "
                         "--endurance-limit (Pa)")
    try:
        return Material(ultimate_strength=ultimate_strength, endurance_limit=endurance_limit)
    except ValueError as exc:
        text = str(exc).replace("Material.ultimate_strength", "--ultimate-strength")
        raise ValueError(text.replace("Material.endurance_limit", "--endurance-limit")) from None


def _with_criterion(material: object, criterion: str | None) -> object:
    """``material`` judged by ``criterion`` (None: its own); refused without a material to judge."""
    if criterion is None:
        return material
    if material is None:
        raise ValueError("--fatigue-criterion: needs a material (--ultimate-strength and --endurance-limit, or a "
                         "linkage file's [fatigue] table)")
    from dataclasses import replace

    try:
        return replace(material, criterion=criterion, endurance_limit=None if material.design_cycles else
                       material.endurance_limit)
    except ValueError as exc:
        raise ValueError(str(exc).replace("Material.yield_strength", "--fatigue-criterion")) from None


def _slider_mass_model(mechanism: str, mass_model: str) -> str:
    """The mass model of a slider-crank check: distributed unless --mass-model was given; the source
    mechanism only."""
    if mechanism != "source":
        raise click.BadParameter("a slider-crank has no Roberts cognate; use --mechanism source",
                                 param_hint="--mechanism")
    ctx = click.get_current_context()
    given = ctx.get_parameter_source("mass_model") not in (click.core.ParameterSource.DEFAULT, None)
    return mass_model if given else "distributed"


def _pct(x: float | None) -> str:
    return "-" if x is None or not math.isfinite(x) else f"{100 * x:.1f}%"
