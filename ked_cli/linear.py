"""``ked linear``: the linear time-periodic KED model of one scene (same scene options as ``ked quasi``)."""

from __future__ import annotations

from typing import Any

import click

from ked_cli.options import (
    RuleType,
    SceneOptions,
    build_scene,
    build_slider,
    explicit,
    file_spec,
    is_file,
    json_text,
    refuse_oversized,
    resolve,
    scene_options,
    wrap,
)
from ked_quasi import rules


@click.command("linear")
@scene_options
@click.option("--damping-ratio", type=RuleType(rules.DAMPING_RATIO), default=rules.DEFAULT_DAMPING_RATIO,
              show_default=True,
              help="Modal damping ratio at the reference frequency (stiffness-proportional, as ked simulate).")
@click.option("--damping-reference-hz", type=click.FloatRange(0.0, 1e9, min_open=True), default=None,
              help="Reference frequency [Hz] of the damping ratio [default: mean f1 of the frozen linkage].")
@click.option("--prestress/--no-prestress", default=True, show_default=True,
              help="Geometric stiffness of the links' axial forces under the quasi-static inertia loads.")
@click.option("--max-harmonics", type=click.IntRange(1, 64), default=32, show_default=True,
              help="Largest number of crank harmonics the periodic solve may use, 1..64 (the solve grows as "
                   "(harmonics x coordinates)^3).")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object with the arrays and statistics.")
def linear(damping_ratio: float, damping_reference_hz: float | None, prestress: bool, max_harmonics: int,
           as_json: bool,
           **kw: Any) -> None:
    """Linear time-periodic KED: the frozen linkage plus the inertia of its elastic motion, periodic
    steady state solved directly, Floquet stability (docs/linear_model.md).

    JSON keys: crank_angle_deg, dx_m, dy_m, rotation_rad (elastic deflection of P, as ked quasi; null
    without a stable steady state), floquet_max_abs, stable, wall_s, harmonics (crank harmonics of the
    collocation; 0 when the steady state on the co-rotating reduced basis answered), radau_steps (that
    basis's steps per cycle; 0 otherwise), error_estimate,
    speed_ratio, damping_reference_hz, flags, valid, message, status ("ok", "marginal": undamped, every
    multiplier on the unit circle, or "unstable"), floquet_error.  Flag "weakly_damped": max |Floquet
    multiplier| >= 0.9, the periodic answer is not valid there.  Exit status 1 when there is no
    asymptotically stable periodic steady state (max |Floquet multiplier| >= 1, or marginal).

    A slider-crank (--linkage simeon, or a TOML [linkage] table with kind = "slider-crank") is solved on its
    own frozen structure, as by ked quasi (mass model distributed unless given); the JSON adds midspan_m,
    the coupler's midspan deflection normal to its chord.
    """
    import numpy as np

    from ked_linear import LinearSettings, describe_flags, result_flags, solve_linear

    opts = resolve(SceneOptions.pop(kw))  # a user file's scene filled in
    scene = _slider_scene(opts)
    if scene is None:
        scene = build_scene(opts)
    else:
        from dataclasses import replace

        opts = replace(opts, mass_model=scene.mass_model.name)  # the mass model solved (distributed by default)
    refuse_oversized(scene)
    linkage = scene.linkage
    if is_file(opts.linkage):  # the file's damping and [linear] settings, where the options do not set them
        damping_ratio, damping_reference_hz, max_harmonics = _file_settings(
            opts, damping_ratio, damping_reference_hz, max_harmonics)
    try:
        settings = LinearSettings(damping_ratio=damping_ratio, damping_reference_hz=damping_reference_hz,
                                  prestress=prestress, max_harmonics=max_harmonics)
    except ValueError as exc:
        raise click.UsageError(str(exc)) from None
    try:
        res = solve_linear(scene, settings)
    except (np.linalg.LinAlgError, ArithmeticError) as exc:  # before ValueError: LinAlgError is one
        from compare.solvers.linear import NUMERICAL_FAILURE

        raise click.ClickException(f"{NUMERICAL_FAILURE}: {exc} (not a verdict on the linkage)") from None
    except ValueError as exc:
        raise click.UsageError(str(exc)) from None
    d = res.deflection
    flags = result_flags(res, linkage)
    out = {
        "crank_angle_deg": scene.crank_angles_deg.tolist(),
        "dx_m": d[:, 0].tolist() if res.stable else None, "dy_m": d[:, 1].tolist() if res.stable else None,
        "rotation_rad": d[:, 2].tolist() if res.stable else None,
        "floquet_max_abs": res.floquet_max_abs, "stable": res.stable, "wall_s": res.wall_s,
        "harmonics": res.harmonics, "radau_steps": res.radau_steps,
        "error_estimate": res.error_estimate, "speed_ratio": res.speed_ratio,
        "damping_reference_hz": res.damping_reference_hz, "flags": list(flags), "valid": res.stable and not flags,
        "message": res.message, "status": res.status, "floquet_error": res.floquet_error,
    }
    if getattr(res, "midspan", None) is not None:  # a slider-crank: the coupler's midspan deflection too
        out["midspan_m"] = res.midspan.tolist() if res.stable else None
    if flags:
        click.echo(wrap(f"warning: {describe_flags(flags, res, linkage)}"), err=True)
    if as_json:
        click.echo(json_text(out))
    else:
        _table(opts, scene, res, out)
    if not res.stable:
        raise click.ClickException(f"no stable periodic steady state: {res.message}")


def _table(opts: SceneOptions, scene: Any, res: Any, out: dict[str, Any]) -> None:
    click.echo(wrap(f"Linear KED steady-state deflection of P: {opts.describe()}"))
    click.echo(wrap(f"{res.message}; r = Omega/omega1_min = {res.speed_ratio:.3g}; {res.wall_s * 1e3:.1f} ms"))
    if not res.stable:
        return
    if not out["valid"]:
        click.echo(wrap("NOT VALID: " + ", ".join(out["flags"]) + " (see the warning above)"))
    step = rules.steps_per_turn(scene.step_deg)
    d = max(1, len(f"{360 / step:g}".split(".")[-1]) if "." in f"{360 / step:g}" else 1)
    mid = out.get("midspan_m")
    click.echo(f"{'theta deg':>9} {'dx mm':>10} {'dy mm':>10} {'rot mrad':>10}" + (f" {'mid mm':>10}" if mid else ""))
    for i, theta in enumerate(out["crank_angle_deg"]):
        click.echo(f"{theta:9.{d}f} {1e3 * out['dx_m'][i]:10.4g} {1e3 * out['dy_m'][i]:10.4g} "
                   f"{1e3 * out['rotation_rad'][i]:10.4g}" + (f" {1e3 * mid[i]:10.4g}" if mid else ""))


def _slider_scene(opts: SceneOptions) -> Any:
    """The slider-crank scene ``--linkage`` names (``ked_cli.options.build_slider``: the same speed-ratio
    bound r <= 10 as ``ked quasi`` and ``ked check``), or None for a four-bar."""
    from ked_cli.quasi import slider_source

    sc = slider_source(opts.linkage)
    return None if sc is None else build_slider(opts, sc)


def _file_settings(opts: SceneOptions, damping_ratio: float, reference_hz: float | None,
                   max_harmonics: int) -> tuple[float, float | None, int]:
    """The damping ratio, its reference frequency and the harmonics cap of the user file's scene (its grid's
    damping ratio, its ``[dynamic]`` damping reference, its ``[linear]`` table), each option given overriding."""
    ctx = click.get_current_context()
    spec = file_spec(opts, damping_ratio if explicit(ctx, "damping_ratio") else None)
    own = spec.settings_for("linear")
    if not explicit(ctx, "damping_ratio"):
        damping_ratio = spec.damping_ratio
    if reference_hz is None:
        reference_hz = spec.shared_settings().get("damping_reference_hz", own.get("damping_reference_hz"))
    if not explicit(ctx, "max_harmonics"):
        max_harmonics = int(own.get("max_harmonics", max_harmonics))
    return damping_ratio, reference_hz, max_harmonics
