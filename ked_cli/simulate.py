"""``ked simulate``: Exudyn flexible-multibody steady state of one scene (same scene options as
``ked quasi``)."""

from __future__ import annotations

import dataclasses
import json
from typing import Any

import click

from ked_cli.options import (
    SceneOptions,
    build_scene,
    build_slider,
    explicit,
    file_spec,
    is_file,
    resolve,
    scene_options,
    wrap,
)

ELEMENT_TYPES = ("ancf", "gebeam")


def dynamic_options(f: Any) -> Any:
    """The Exudyn settings options (defaults: ``exudyn_models.DynamicSettings``)."""
    opts = [
        click.option("--element", type=click.Choice(ELEMENT_TYPES), default="ancf", show_default=True,
                     help="Beam element: ANCF cable or geometrically exact beam."),
        click.option("--elements-per-link", type=click.IntRange(1, 64), default=None,
                     help="Finite elements per link, 1..64 [default: 4]."),
        click.option("--steps-per-cycle", type=click.IntRange(8, 1_000_000), default=None,
                     help="Fixed time steps per crank revolution, 8..1e6 [default: 720]."),
        click.option("--spectral-radius", type=click.FloatRange(0.0, 1.0), default=None,
                     help="Generalized-alpha spectral radius, 0..1 [default: 0.9]."),
        click.option("--damping-ratio", type=click.FloatRange(0.0, 0.99), default=None,
                     help="Modal damping ratio at the reference frequency, 0..0.99 [default: 0.02]."),
        click.option("--damping-reference-hz", type=click.FloatRange(0.0, 1e6, min_open=True), default=None,
                     help="Reference frequency [Hz] of the damping ratio [default: mean f1 of the frozen linkage]."),
        click.option("--ramp-cycles", type=click.FloatRange(0.0, 1000.0, min_open=True), default=None,
                     help="Start-up ramp duration [crank revolutions] [default: 0.5]."),
        click.option("--steady-tol", type=click.FloatRange(0.0, 1.0, min_open=True), default=None,
                     help="Steady state: change between successive cycles < tol * peak [default: 2e-3]."),
        click.option("--max-cycles", type=click.IntRange(1, 10_000), default=None,
                     help="Give up after this many constant-speed cycles, 1..1e4 [default: 80]."),
        click.option("--extrapolate/--no-extrapolate", default=None,
                     help="Accept the steady cycle extrapolated from the last 4 cycles once a cycle simulated "
                          "from it reproduces it [default: on]."),
        click.option("--sparse/--dense", default=None, help="Exudyn linear solver [default: sparse]."),
        click.option("--start", type=click.Choice(("ramp", "quasi_static", "linear")), default=None,
                     help="Start of the constant-speed phase: from rest through the ramp, at full speed from the "
                          "quasi-static deflected state, or on the linear model's periodic orbit (from the ramp "
                          "where the linear answer is outside its range) [default: the file's, else ramp; the "
                          "default campaign's: linear]."),
        click.option("--periodic", type=click.Choice(("off", "anderson")), default=None,
                     help="off: march cycle after cycle; anderson: solve the periodic orbit directly "
                          "(Anderson-accelerated fixed point of one cycle) [default: off]."),
        click.option("--refine/--no-refine", default=None,
                     help="On a Newton failure retry along the refinement ladder (more Newton iterations, "
                          "2x/4x/8x steps, 2x elements) [default: on]; --no-refine fails at once."),
        click.option("--refine-budget-s", type=click.FloatRange(0.0, 1e6, min_open=True), default=None,
                     help="Wall-time budget [s] of all attempts of the ladder together [default: 120]."),
    ]
    for o in reversed(opts):
        f = o(f)
    return f


def dynamic_settings(kw: dict[str, Any], base: dict[str, Any] | None = None) -> Any:
    """``DynamicSettings`` from the options given over ``base`` (a file's ``[dynamic]`` settings; unset ones keep
    their defaults)."""
    from exudyn_models.settings import DynamicSettings

    names = ("element", "elements_per_link", "steps_per_cycle", "spectral_radius", "damping_ratio",
             "damping_reference_hz", "ramp_cycles", "steady_tol", "max_cycles", "extrapolate", "sparse",
             "start", "periodic", "refine", "refine_budget_s")
    given = {n: kw.pop(n) for n in names if n in kw}
    given = {**(base or {}), **{n: v for n, v in given.items() if v is not None}}
    if "max_cycles" in given and "min_cycles" not in given:
        given["min_cycles"] = min(DynamicSettings().min_cycles, given["max_cycles"])
    try:
        return DynamicSettings(**given)
    except ValueError as exc:
        raise click.UsageError(str(exc)) from None


@click.command("simulate")
@scene_options
@dynamic_options
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object with the arrays and run statistics.")
def simulate(as_json: bool, **kw: Any) -> None:
    """Flexible-multibody (Exudyn) run of one scene to periodic steady state.

    JSON keys: crank_angle_deg, dx_m, dy_m, rotation_rad (elastic deflection of P over one steady
    cycle, global frame, same meaning as `ked quasi`), wall_s, cycles, converged, steps,
    newton_iterations, damping_reference_hz, message, failure_class ("" or numerical / physical / undecided),
    evidence, solved_settings (the settings that produced the history: the requested ones unless the
    refinement ladder was needed) and attempts (every run: rung, outcome, wall_s, cycles,
    elements_per_link, steps_per_cycle, message), flags (validity flags, e.g. large_deflection: the
    history is beyond the small-deflection range, as in `ked quasi`) and valid.  Exit status 1 when no
    steady state was reached (the JSON still says converged=false and holds the last cycle).

    A slider-crank (--linkage simeon, or a TOML [linkage] table with kind = "slider-crank") runs its own
    model (rigid or beam crank, beam coupler, slider held on its line; start from the ramp, marching);
    its mass model defaults to distributed, and the JSON adds midspan_m: the coupler's midspan deflection
    normal to its chord (same meaning as in `ked quasi`).
    """
    from ked_cli.quasi import slider_source

    opts = resolve(SceneOptions.pop(kw))  # a user file's scene filled in
    base = {}
    if is_file(opts.linkage):  # the file's [dynamic] table and damping ratio, the options given overriding them
        ctx = click.get_current_context()
        base = dict(file_spec(opts, kw["damping_ratio"] if explicit(ctx, "damping_ratio") else None).dynamic)
    settings = dynamic_settings(kw, base)
    slider = slider_source(opts.linkage)
    scene = build_slider(opts, slider) if slider is not None else build_scene(opts)
    from exudyn_models.simulate import SimulationError, simulate_steady_state

    try:
        res = simulate_steady_state(scene, settings)
    except ValueError as exc:  # input the model does not take (e.g. a slider-crank with a rigid coupler)
        raise click.UsageError(str(exc)) from None
    except SimulationError as exc:
        raise click.ClickException(f"simulation failed ({exc.failure_class}): {exc}") from None
    d = res.deflection
    out = {
        "crank_angle_deg": scene.crank_angles_deg.tolist(),
        "dx_m": d[:, 0].tolist(), "dy_m": d[:, 1].tolist(), "rotation_rad": d[:, 2].tolist(),
        "wall_s": res.wall_s, "cycles": res.cycles, "converged": res.converged, "steps": res.steps,
        "newton_iterations": res.newton_iterations, "damping_reference_hz": res.damping_reference_hz,
        "message": res.message, "failure_class": res.failure_class, "evidence": res.evidence,
        "solved_settings": dataclasses.asdict(res.solved_settings or res.settings),
        "attempts": [attempt_dict(a) for a in res.attempts],
        "flags": list(res.flags), "valid": bool(res.converged and not res.flags),
    }
    if res.midspan is not None:
        out["midspan_m"] = res.midspan.tolist()
    if res.flags and res.converged:
        click.echo(wrap(f"warning: {res.validity}"), err=True)
    if as_json:
        click.echo(json.dumps(out))
    else:
        _table(dataclasses.replace(opts, mass_model=scene.mass_model.name), res, out)
    if not res.converged:
        raise click.ClickException(f"no periodic steady state ({res.failure_class or 'numerical'}): {res.message}"
                                   f"{'; ' + res.evidence if res.evidence else ''} (the last cycle is not an answer)")


def attempt_dict(a: Any) -> dict[str, Any]:
    """One attempt of the refinement ladder as JSON."""
    return {"rung": a.rung, "outcome": a.outcome, "wall_s": a.wall_s, "cycles": a.cycles,
            "elements_per_link": a.settings.elements_per_link, "steps_per_cycle": a.settings.steps_per_cycle,
            "newton_max_iterations": a.settings.newton_max_iterations, "message": a.message}


def _table(opts: SceneOptions, res: Any, out: dict[str, Any]) -> None:
    click.echo(wrap(f"Dynamic (Exudyn) steady-state deflection of P: {opts.describe()}"))
    click.echo(wrap(f"{res.message}; {res.steps} steps, {res.newton_iterations} Newton iterations, "
                    f"{res.wall_s:.2f} s wall; damping reference {res.damping_reference_hz:.3g} Hz"))
    if len(res.attempts) > 1:
        click.echo(wrap("refinement ladder: " + "; ".join(a.text() for a in res.attempts)))
    if not res.converged:
        return
    if res.flags:
        click.echo(wrap("NOT VALID: " + ", ".join(res.flags) + " (see the warning above)"))
    mid = out.get("midspan_m")
    click.echo(f"{'theta deg':>9} {'dx mm':>10} {'dy mm':>10} {'rot mrad':>10}" + (f" {'mid mm':>10}" if mid else ""))
    for i, theta in enumerate(out["crank_angle_deg"]):
        click.echo(f"{theta:9.1f} {1e3 * out['dx_m'][i]:10.4g} {1e3 * out['dy_m'][i]:10.4g} "
                   f"{1e3 * out['rotation_rad'][i]:10.4g}" + (f" {1e3 * mid[i]:10.4g}" if mid else ""))
