"""``ked benchmark``: published benchmarks reproduced by independent reference implementations."""

from __future__ import annotations

import click

from ked_cli.options import json_text


@click.group("benchmark")
def benchmark() -> None:
    """Published benchmarks of flexible mechanisms, reproduced by independent implementations."""


MIN_OMEGA = 5.0
"""Slowest crank speed of the benchmark [rad/s]."""
MIN_OMEGA_REASON = ("the reference is marched to its damped steady state, which takes longer the slower the crank: "
                    "21 s at 5 rad/s and 75 s at 1 rad/s on this project's 2-core machine, without bound below; at "
                    "5 rad/s, r = 0.004, the dynamic part is already about 5e-5 of the peak")


def _speeds(text: str, option: str = "--steady-state") -> list[float]:
    try:
        values = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise click.BadParameter(f"{text!r}: give crank speeds in rad/s separated by commas, e.g. 50,150",
                                 param_hint=option) from None
    if not values or any(not (MIN_OMEGA <= abs(v) <= 1000.0) for v in values):
        raise click.BadParameter(f"{text!r}: each crank speed must be {MIN_OMEGA:g} to 1000 rad/s in size "
                                 f"({MIN_OMEGA_REASON})", param_hint=option)
    return values


@benchmark.command("simeon")
@click.option("--no-project", is_flag=True,
              help="Start from the 9-digit initial values as printed (their velocity-constraint residual is "
                   "~1e-8) instead of projecting the velocities onto the constraint first.")
@click.option("--steady-state", "steady", default=None, metavar="RAD_S[,RAD_S...]",
              help="Also march the damped reference model (published damping matrix) from a rigid start to "
                   "its periodic steady state at these crank speeds [rad/s] and print the rod's peak "
                   "midspan deflection.")
@click.option("--speeds", "speeds", default="25:300:25", show_default=True, metavar="RAD_S[,RAD_S...]|FROM:TO:STEP",
              help="Crank speeds [rad/s] of the tier comparison (reference model marched to its damped steady "
                   "state, with and without geometric stiffness, ~1 min per speed, against the quasi-static, "
                   "linear and Exudyn tiers), as a list or a range; "
                   "'none' skips it.")
@click.option("--no-dynamic", is_flag=True,
              help="Skip the Exudyn tier in the tier comparison (dynamic_error and dynamic_error_geometric null).")
@click.option("--no-geometric", is_flag=True,
              help="Skip the reference with geometric stiffness in the tier comparison (the *_geometric keys "
                   "null; halves the reference's cost).")
@click.option("--figure", "figure", default=None, type=click.Path(dir_okay=False, writable=True),
              help="Also draw the tiers' errors against the speed ratio (PNG) from this run's numbers; refuses "
                   "to overwrite an existing file.")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
def simeon(no_project: bool, steady: str | None, speeds: str, no_dynamic: bool, no_geometric: bool,
           figure: str | None, as_json: bool) -> None:
    """Simeon's flexible slider-crank (Test Set for IVP solvers, problem "crank"): the published state at
    t = 0.1 s (linear stiffness, no damping) against this harness's independent implementation of the
    published equations (ked_bench.simeon: index-1 form, scipy DOP853).

    JSON keys: published, reproduced (component name -> value, SI), relative_error (per component),
    max_relative_error (components 1-7, the positions, as the test set scores them), projected,
    initial_velocity_residual; with --steady-state also steady_states (a list of {omega_rad_s,
    speed_ratio, midspan_peak_m, cycles}); speeds (a list of {omega_rad_s, speed_ratio (Omega over the
    rod's first bending frequency), quasi_static_error, linear_error, dynamic_error,
    linear_prestressed_error, reference_peak_m, linear_status, notes}): the history error, max |a - ref| /
    max |ref| over the cycle, of each tier's rod midspan deflection (normal to its chord) against the
    reference model's damped periodic steady state (published damping matrix, rigid start); the linear
    tier with the reference's first-mode damping ratio (2.59 %) at the rod's first bending frequency and,
    like the reference, without geometric stiffness (linear_prestressed_error: with it, the harness's
    default); dynamic_error: the Exudyn tier (6 ANCF elements, 1080 steps per cycle, the same damping);
    null where a tier gives no answer, the reason in notes.  The reference's default (linear stiffness)
    lacks the rod's geometric stiffening by its axial force, which Exudyn's beams and the prestressed
    linear tier contain: reference_geometric_peak_m, dynamic_error_geometric,
    linear_prestressed_error_geometric compare them with the reference with geometric stiffness (the
    like-for-like comparison of those tiers).
    """
    from ked_bench.simeon import COMPONENTS, SimeonParameters, reproduce, steady_state

    omegas = _speeds(steady) if steady is not None else []
    sweep = _sweep(speeds)
    if figure is not None:
        from pathlib import Path

        if Path(figure).exists():
            raise click.BadParameter(f"{figure!r}: exists; give a new file name (stored results are never "
                                     "overwritten)", param_hint="--figure")
        if not sweep:
            raise click.BadParameter("needs the tier comparison (--speeds other than 'none')",
                                     param_hint="--figure")
    rep = reproduce(project=not no_project)
    out = {"published": rep.published, "reproduced": rep.reproduced, "relative_error": rep.relative_error,
           "max_relative_error": rep.max_relative_error, "projected": rep.projected,
           "initial_velocity_residual": rep.velocity_residual}
    rows = []
    for omega in omegas:
        try:
            s = steady_state(omega)
        except RuntimeError as exc:  # no steady state, or the integration failed: an answer, not a crash
            from ked_cli.errors import UserError

            raise UserError(f"--steady-state: {exc}; try another crank speed") from None
        rows.append({"omega_rad_s": omega, "speed_ratio": abs(omega) / SimeonParameters().first_bending_rad_s,
                     "midspan_peak_m": s.peak, "cycles": s.cycles})
    if omegas:
        out["steady_states"] = rows
    if sweep:
        out["speeds"] = _compare(sweep, dynamic=not no_dynamic, geometric=not no_geometric)
    if figure is not None:
        from ked_bench.figure import write_validity_figure
        from ked_cli.errors import UserError

        try:
            write_validity_figure(out["speeds"], figure)
        except OSError as exc:
            raise UserError(f"--figure: cannot write {figure!r}: {exc.strerror or exc}") from None
    if as_json:
        click.echo(json_text(out))
        return
    click.echo("Simeon's flexible slider-crank at t = 0.1 s (linear stiffness, no damping)")
    click.echo(f"{'component':<10} {'published':>24} {'reproduced':>24} {'rel. error':>10}")
    for name in COMPONENTS:
        click.echo(f"{name:<10} {rep.published[name]:>24.15e} {rep.reproduced[name]:>24.15e} "
                   f"{rep.relative_error[name]:>10.1e}")
    how = "projected onto the velocity constraint" if rep.projected else "as printed"
    click.echo(f"max relative error, components 1-7: {rep.max_relative_error:.1e}")
    click.echo(f"(initial velocities {how}; their residual {rep.velocity_residual:.1e})")
    if rows:
        click.echo("\nDamped reference model, periodic steady state (rigid start):")
        click.echo(f"{'omega [rad/s]':>13} {'r':>7} {'peak midspan q1 [mm]':>21} {'cycles':>7}")
        for row in rows:
            click.echo(f"{row['omega_rad_s']:>13g} {row['speed_ratio']:>7.4f} {1e3 * row['midspan_peak_m']:>21.5f} "
                       f"{row['cycles']:>7d}")
    if sweep:
        _speeds_table(out["speeds"])


def _sweep(text: str) -> list[float]:
    """--speeds: 'none', a list 'a,b,c' or a range 'from:to:step' [rad/s] (inclusive)."""
    if text.strip().lower() == "none":
        return []
    if ":" not in text:
        values = _speeds(text, "--speeds")
        if any(v < 0.0 for v in values):
            raise click.BadParameter(f"{text!r}: the benchmark's crank turns CCW; give positive speeds",
                                     param_hint="--speeds")
        return values
    try:
        lo, hi, step = (float(v) for v in text.split(":"))
    except ValueError:
        raise click.BadParameter(f"{text!r}: give FROM:TO:STEP in rad/s, e.g. 25:300:25", param_hint="--speeds") \
            from None
    if not (MIN_OMEGA <= lo <= hi <= 1000.0 and step > 0.0) or (hi - lo) / step > 100:
        raise click.BadParameter(f"{text!r}: need {MIN_OMEGA:g} <= FROM <= TO <= 1000 rad/s and STEP > 0, at most "
                                 f"100 steps ({MIN_OMEGA_REASON})", param_hint="--speeds")
    return [lo + k * step for k in range(int((hi - lo) / step + 1e-9) + 1)]


def _compare(omegas: list[float], dynamic: bool = True, geometric: bool = True) -> list[dict]:
    from ked_bench.simeon import steady_state
    from ked_bench.tiers import compare_speed
    from ked_cli.errors import UserError

    rows = []
    for omega in omegas:
        try:
            ref = steady_state(omega)
            geo = steady_state(omega, stiffness="geometric") if geometric else None
        except RuntimeError as exc:
            raise UserError(f"--speeds: {exc}; try another crank speed") from None
        rows.append(compare_speed(omega, ref, dynamic=dynamic, geometric=geo).to_dict())
    return rows


def _pct(x: float | None) -> str:
    return "-" if x is None else f"{100.0 * x:.2f} %"


def _speeds_table(rows: list[dict]) -> None:
    click.echo("\nTiers against the reference, rod midspan deflection, damped periodic steady state")
    click.echo("(history error max|a - ref| / max|ref|; linear: reference damping 2.59 % at the rod's f1, no")
    click.echo("geometric stiffness like the reference; prestressed: the harness's default linear tier;")
    click.echo("'geo': against the reference with geometric stiffness, like for like for prestressed and Exudyn)")
    click.echo(f"{'omega rad/s':>11} {'r':>7} {'peak mm':>9} {'quasi-static':>12} {'linear':>9} "
               f"{'prestressed':>11} {'dynamic':>9} {'prestr. geo':>11} {'dyn. geo':>9}")
    for row in rows:
        click.echo(f"{row['omega_rad_s']:>11g} {row['speed_ratio']:>7.4f} {1e3 * row['reference_peak_m']:>9.4f} "
                   f"{_pct(row['quasi_static_error']):>12} {_pct(row['linear_error']):>9} "
                   f"{_pct(row['linear_prestressed_error']):>11} {_pct(row['dynamic_error']):>9} "
                   f"{_pct(row.get('linear_prestressed_error_geometric')):>11} "
                   f"{_pct(row.get('dynamic_error_geometric')):>9}")
    notes = sorted({n for row in rows for n in row["notes"]})
    for n in notes:
        click.echo(f"note: {n}")
