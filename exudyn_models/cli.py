"""`ked simulate`: Exudyn flexible-multibody steady-state run of one scene (same scene options as
`ked quasi`)."""

from __future__ import annotations

import json

import click
import numpy as np

from ked_quasi.cli import scene_from_options, scene_options

from .settings import ELEMENT_TYPES, DynamicSettings
from .simulate import SimulationError, simulate_steady_state

_DEFAULT = DynamicSettings()


@click.command("simulate")
@scene_options
@click.option("--element", type=click.Choice(ELEMENT_TYPES), default=_DEFAULT.element, show_default=True,
              help="Beam element: ANCF cable or geometrically exact beam.")
@click.option("--elements-per-link", type=int, default=_DEFAULT.elements_per_link, show_default=True,
              help="Finite elements per link.")
@click.option("--steps-per-cycle", type=int, default=_DEFAULT.steps_per_cycle, show_default=True,
              help="Fixed time steps per crank revolution.")
@click.option("--spectral-radius", type=float, default=_DEFAULT.spectral_radius, show_default=True,
              help="Generalized-alpha spectral radius (numerical damping of high modes).")
@click.option("--damping-ratio", type=float, default=_DEFAULT.damping_ratio, show_default=True,
              help="Modal damping ratio at the reference frequency (stiffness-proportional damping).")
@click.option("--damping-reference-hz", type=float, default=None,
              help="Reference frequency [Hz] of the damping ratio (default: mean f1 of the frozen structure).")
@click.option("--ramp-cycles", type=float, default=_DEFAULT.ramp_cycles, show_default=True,
              help="Start-up ramp duration [crank revolutions].")
@click.option("--steady-tol", type=float, default=_DEFAULT.steady_tol, show_default=True,
              help="Steady state: change between successive cycles < tol * peak.")
@click.option("--max-cycles", type=int, default=_DEFAULT.max_cycles, show_default=True,
              help="Give up (converged=false) after this many constant-speed cycles.")
@click.option("--extrapolate/--no-extrapolate", default=_DEFAULT.extrapolate, show_default=True,
              help="Accept the steady cycle extrapolated from the last 4 cycles once it has settled.")
@click.option("--sparse/--dense", default=_DEFAULT.sparse, show_default=True, help="Exudyn linear solver.")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object with the arrays and run statistics.")
def simulate(as_json: bool, element: str, elements_per_link: int, steps_per_cycle: int, spectral_radius: float,
             damping_ratio: float, damping_reference_hz: float | None, ramp_cycles: float, steady_tol: float,
             max_cycles: int, extrapolate: bool, sparse: bool, **kw) -> None:
    """Flexible-multibody (Exudyn) run of one scene to periodic steady state.

    JSON keys: crank_angle_deg, dx_m, dy_m, rotation_rad (elastic deflection of P over one steady
    cycle, global frame, same meaning as `ked quasi`), wall_s, cycles, converged, steps,
    newton_iterations, damping_reference_hz, message.
    """
    scene = scene_from_options(kw)
    try:
        settings = DynamicSettings(
            element=element, elements_per_link=elements_per_link, steps_per_cycle=steps_per_cycle,
            spectral_radius=spectral_radius, damping_ratio=damping_ratio,
            damping_reference_hz=damping_reference_hz, ramp_cycles=ramp_cycles, steady_tol=steady_tol,
            max_cycles=max_cycles, min_cycles=min(_DEFAULT.min_cycles, max_cycles), extrapolate=extrapolate,
            sparse=sparse)
    except ValueError as exc:
        raise click.BadParameter(str(exc)) from exc
    try:
        res = simulate_steady_state(scene, settings)
    except SimulationError as exc:
        raise click.ClickException(f"simulation failed: {exc}") from exc
    d = res.deflection
    out = {
        "crank_angle_deg": np.degrees(res.crank_angle).tolist(),
        "dx_m": d[:, 0].tolist(), "dy_m": d[:, 1].tolist(), "rotation_rad": d[:, 2].tolist(),
        "wall_s": res.wall_s, "cycles": res.cycles, "converged": res.converged, "steps": res.steps,
        "newton_iterations": res.newton_iterations, "damping_reference_hz": res.damping_reference_hz,
        "message": res.message,
    }
    if as_json:
        click.echo(json.dumps(out))
        return
    click.echo(f"{res.message}; {res.steps} steps, {res.newton_iterations} Newton iterations, "
               f"{res.wall_s:.2f} s wall; damping reference {res.damping_reference_hz:.3g} Hz")
    click.echo(f"{'theta deg':>9} {'dx mm':>9} {'dy mm':>9} {'rot mrad':>9}")
    for i in range(res.crank_angle.size):
        click.echo(f"{out['crank_angle_deg'][i]:9.1f} {1e3 * d[i, 0]:9.3f} {1e3 * d[i, 1]:9.3f} {1e3 * d[i, 2]:9.3f}")
