"""``ked benchmark``: published benchmarks reproduced by independent reference implementations."""

from __future__ import annotations

import click

from ked_cli.options import json_text


@click.group("benchmark")
def benchmark() -> None:
    """Published benchmarks of flexible mechanisms, reproduced by independent implementations."""


def _speeds(text: str) -> list[float]:
    try:
        values = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise click.BadParameter(f"{text!r}: give crank speeds in rad/s separated by commas, e.g. 50,150",
                                 param_hint="--steady-state") from None
    if not values or any(not (0.0 < abs(v) <= 1000.0) for v in values):
        raise click.BadParameter(f"{text!r}: each crank speed must be nonzero and at most 1000 rad/s in size",
                                 param_hint="--steady-state")
    return values


@benchmark.command("simeon")
@click.option("--no-project", is_flag=True,
              help="Start from the 9-digit initial values as printed (their velocity-constraint residual is "
                   "~1e-8) instead of projecting the velocities onto the constraint first.")
@click.option("--steady-state", "steady", default=None, metavar="RAD_S[,RAD_S...]",
              help="Also march the damped reference model (published damping matrix) from a rigid start to "
                   "its periodic steady state at these crank speeds [rad/s] and print the rod's peak "
                   "midspan deflection.")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
def simeon(no_project: bool, steady: str | None, as_json: bool) -> None:
    """Simeon's flexible slider-crank (Test Set for IVP solvers, problem "crank"): the published state at
    t = 0.1 s (linear stiffness, no damping) against this harness's independent implementation of the
    published equations (ked_bench.simeon: index-1 form, scipy DOP853).

    JSON keys: published, reproduced (component name -> value, SI), relative_error (per component),
    max_relative_error (components 1-7, the positions, as the test set scores them), projected,
    initial_velocity_residual; with --steady-state also steady_states (a list of {omega_rad_s,
    speed_ratio, midspan_peak_m, cycles}).  The comparison of the harness's own tiers with this
    reference needs the slider-crank in every tier, which the harness does not model yet.
    """
    from ked_bench.simeon import COMPONENTS, SimeonParameters, reproduce, steady_state

    omegas = _speeds(steady) if steady is not None else []
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
    if as_json:
        click.echo(json_text(out))
        return
    click.echo("Simeon's flexible slider-crank at t = 0.1 s (linear stiffness, no damping)")
    click.echo(f"{'component':<10} {'published':>24} {'reproduced':>24} {'rel. error':>10}")
    for name in COMPONENTS:
        click.echo(f"{name:<10} {rep.published[name]:>24.15e} {rep.reproduced[name]:>24.15e} "
                   f"{rep.relative_error[name]:>10.1e}")
    how = "projected onto the velocity constraint" if rep.projected else "as printed"
    click.echo(f"max relative error, components 1-7: {rep.max_relative_error:.1e} (initial velocities {how}; "
               f"their residual {rep.velocity_residual:.1e})")
    if rows:
        click.echo("\nDamped reference model, periodic steady state (rigid start):")
        click.echo(f"{'omega [rad/s]':>13} {'r':>7} {'peak midspan q1 [mm]':>21} {'cycles':>7}")
        for row in rows:
            click.echo(f"{row['omega_rad_s']:>13g} {row['speed_ratio']:>7.4f} {1e3 * row['midspan_peak_m']:>21.5f} "
                       f"{row['cycles']:>7d}")
