"""``ked quasi``: the quasi-static solve of one scene, or a summary over mechanisms and mass models."""

from __future__ import annotations

import math
import warnings
from typing import Any

import click

from ked_cli.options import SceneOptions, build_scene, file_spec, is_file, json_text, resolve, scene_options, wrap


@click.command("quasi")
@scene_options
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object with the arrays.")
@click.option("--summary", is_flag=True,
              help="Ignore --mechanism/--mass-model: solve source and cognate in every mass model, print a table.")
def quasi(as_json: bool, summary: bool, **kw: Any) -> None:
    """Quasi-static KED solve (instantaneous-structure flexibility method) of one scene.

    JSON keys: crank_angle_deg, dx_m, dy_m, rotation_rad (elastic deflection of P, global frame),
    f1_hz (first natural frequency of the frozen structure), transmission_angle_deg, flagged
    (near-toggle angles), flags (validity flags of the whole answer, e.g. large_deflection), valid.

    A slider-crank (--linkage simeon, or a TOML [linkage] table with kind = "slider-crank") is solved
    with its own frozen structure (crank clamped, slider resisting motion normal to its line); its mass
    model defaults to distributed (the links' own mass), the slider's mass is always included, and the JSON
    adds midspan_m: the coupler's midspan deflection normal to its chord.
    """
    opts = SceneOptions.pop(kw)
    if not summary:  # a user file's scene filled in (the summary runs every mechanism and mass model)
        opts = resolve(opts)
    slider = slider_source(opts.linkage)
    if slider is not None:
        _slider(opts, slider, as_json, summary)
        return
    if summary:
        _summary(opts, as_json)
        return
    scene = build_scene(opts)
    out, caught = solve(scene)
    for w in caught:
        click.echo(wrap(f"warning: {w}"), err=True)
    if as_json:
        click.echo(json_text(out))
        return
    _table(opts, scene, out)


def solve(scene: Any) -> tuple[dict[str, Any], list[str]]:
    """The JSON record of one quasi-static solve and its warnings (validity flags included)."""
    from ked_quasi.solver import natural_frequencies, solve_quasi_static

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = solve_quasi_static(scene)
        f1 = natural_frequencies(scene, n_modes=1)[:, 0]
    out, flagged = _record(scene, res, f1, scene.fourbar)
    return out, [str(w.message) for w in caught] + flagged


def _record(scene: Any, res: Any, f1: Any, linkage: Any) -> tuple[dict[str, Any], list[str]]:
    """The JSON keys of a quasi-static solve that both linkages share, and its validity message (if
    flagged by ``ked_quasi.limits``)."""
    import numpy as np

    from ked_quasi import limits

    flags = limits.flags(res.deflection, linkage)
    out = {
        "crank_angle_deg": scene.crank_angles_deg.tolist(),
        "dx_m": res.deflection[:, 0].tolist(), "dy_m": res.deflection[:, 1].tolist(),
        "rotation_rad": res.deflection[:, 2].tolist(), "f1_hz": f1.tolist(),
        "transmission_angle_deg": np.degrees(res.transmission_angle).tolist(),
        "flagged": res.flagged.tolist(), "flags": list(flags), "valid": not flags,
    }
    return out, [limits.describe(flags, res.deflection, linkage)] if flags else []


def _decimals(step_deg: float) -> int:
    """Decimals that show every grid angle exactly (at least one)."""
    for d in range(1, 7):
        if abs(round(step_deg, d) - step_deg) < 1e-9:
            return d
    return 6


def _table(opts: SceneOptions, scene: Any, out: dict[str, Any]) -> None:
    mm = scene.mass_model
    click.echo(wrap(f"Quasi-static deflection of the coupler point P: {opts.describe()}"
                    + (f", payload {mm.payload:g} kg" if mm.payload else "")))
    click.echo(wrap("theta: crank angle CCW from the ground line M->Q; dx, dy: elastic displacement of P in the "
                    "global frame; rot: elastic rotation of the section at P (CCW +); f1: first natural frequency "
                    "of the frozen linkage; mu: transmission angle (FLAGGED within 1 deg of a toggle)"))
    if not out["valid"]:
        click.echo(wrap("NOT VALID: " + ", ".join(out["flags"]) + " (see the warning above)"))
    d = _decimals(scene.step_deg)
    w = max(9, d + 5)
    click.echo(f"{'theta deg':>{w}} {'dx mm':>10} {'dy mm':>10} {'rot mrad':>10} {'f1 Hz':>8} {'mu deg':>7}")
    for i, theta in enumerate(out["crank_angle_deg"]):
        click.echo(f"{theta:{w}.{d}f} {1e3 * out['dx_m'][i]:10.4g} {1e3 * out['dy_m'][i]:10.4g} "
                   f"{1e3 * out['rotation_rad'][i]:10.4g} {out['f1_hz'][i]:8.3f} "
                   f"{out['transmission_angle_deg'][i]:7.1f}" + ("  FLAGGED" if out["flagged"][i] else ""))


def _summary(opts: SceneOptions, as_json: bool) -> None:
    import numpy as np

    from ked_quasi import units
    from ked_quasi.massmodel import MASS_MODELS
    from ked_quasi.solver import natural_frequencies, solve_quasi_static

    rows = []
    for mech in ("source", "cognate"):
        for mm in MASS_MODELS:
            scene = build_scene(opts, mechanism=mech, mass_model=mm)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                res = solve_quasi_static(scene)
            f1 = natural_frequencies(scene, n_modes=1)[:, 0]
            mag = np.hypot(res.deflection[:, 0], res.deflection[:, 1])
            rows.append({"mechanism": mech, "mass_model": mm, "mass_kg": scene.mass_model.payload,
                         "peak_deflection_m": float(mag.max()),
                         "peak_at_deg": float(scene.crank_angles_deg[mag.argmax()]),
                         "peak_rotation_rad": float(np.abs(res.deflection[:, 2]).max()),
                         "f1_min_hz": float(f1.min()), "f1_max_hz": float(f1.max()),
                         "speed_ratio": units.speed_ratio(scene.omega, units.omega1_min(f1))})
    if as_json:
        click.echo(json_text(rows))
        return
    from compare.inspect import rpm_text

    click.echo(wrap(f"Quasi-static KED summary: {opts.linkage} linkage, {rpm_text(opts.rpm)} rpm, "
                    f"step {opts.step_deg:g} deg"))
    click.echo(f"{'mechanism':<9} {'mass model':<11} {'peak |d| mm':>11} {'at deg':>7} {'peak rot mrad':>13} "
               f"{'f1 min..max Hz':>15} {'Omega/w1min':>11}")
    for r in rows:
        click.echo(f"{r['mechanism']:<9} {r['mass_model']:<11} {1e3 * r['peak_deflection_m']:11.3f} "
                   f"{r['peak_at_deg']:7.1f} {1e3 * r['peak_rotation_rad']:13.3f} "
                   f"{r['f1_min_hz']:7.2f}..{r['f1_max_hz']:<7.2f} {r['speed_ratio']:11.3f}")


# -- slider-crank -----------------------------------------------------------------------------------
def slider_source(linkage: str) -> Any:
    """The slider-crank ``--linkage`` names (a preset or a TOML file with kind = "slider-crank"), else None."""
    from ked_cli.options import scene_file
    from ked_quasi.presets import slider_linkage
    from ked_quasi.slidercrank import SliderCrank

    preset = slider_linkage(linkage)
    if preset is not None or linkage == "thesis":
        return preset
    lk = scene_file(linkage).linkage  # the whole file checked, as ked run checks it
    return lk if isinstance(lk, SliderCrank) else None


def _slider(opts: SceneOptions, sc: Any, as_json: bool, summary: bool) -> None:
    from ked_quasi import rules, units
    from ked_quasi.slidercrank import build_slider_scene

    ctx = click.get_current_context()
    given = ctx.get_parameter_source("mass_model") not in (click.core.ParameterSource.DEFAULT, None)
    if summary:
        raise click.UsageError("--summary compares four-bar mechanisms and mass models; a slider-crank is solved "
                               "one scene at a time (drop --summary)")
    if opts.mechanism != "source":
        raise click.BadParameter("a slider-crank has no Roberts cognate; use --mechanism source",
                                 param_hint="--mechanism")
    mass_model = opts.mass_model if given else "distributed"
    try:
        if is_file(opts.linkage):  # the file's scene, the options given overriding it
            spec = file_spec(opts)
            scene = spec.scene(spec.speed.value)
        else:
            scene = build_slider_scene(sc, mass_model, opts.rpm, opts.step_deg, opts.lumps, opts.payload_kg,
                                       opts.stiffness_scale, opts.direction)
    except ValueError as exc:
        raise click.UsageError(str(exc)) from None
    out, msgs = solve_slider(scene)
    f1_min = min((f for f in out["f1_hz"] if f is not None), default=float("nan"))
    try:
        rules.check_speed_ratio(units.speed_ratio(scene.omega, 2.0 * math.pi * f1_min), scene.rpm, f1_min, "value")
    except ValueError as exc:
        raise click.BadParameter(str(exc).removeprefix("value = "), param_hint="--rpm") from None
    for m in msgs:
        click.echo(wrap(f"warning: {m}"), err=True)
    if as_json:
        click.echo(json_text(out))
        return
    _slider_table(opts, scene, out)


def solve_slider(scene: Any) -> tuple[dict[str, Any], list[str]]:
    """The JSON record of one slider-crank quasi-static solve (the four-bar's keys plus midspan_m) and its
    validity messages."""
    from ked_quasi.slider_static import slider_natural_frequencies, solve_slider_quasi_static

    res = solve_slider_quasi_static(scene)
    f1 = slider_natural_frequencies(scene, n_modes=1)[:, 0]
    out, msgs = _record(scene, res, f1, scene.linkage)
    return {**out, "midspan_m": res.midspan.tolist()}, msgs


def _slider_table(opts: SceneOptions, scene: Any, out: dict[str, Any]) -> None:
    from compare.inspect import rpm_text

    mm, sc = scene.mass_model, scene.linkage
    rigid = [lk for lk, r in zip(("crank", "coupler"), sc.rigid) if r]
    click.echo(wrap(f"Quasi-static deflection of a slider-crank: {opts.linkage} (crank {sc.crank:g} m, coupler "
               f"{sc.coupler:g} m, offset {sc.offset:g} m, coupler point at {sc.coupler_point:g} of the coupler, "
               f"slider "
               f"{sc.slider_mass:g} kg" + (f", rigid {' and '.join(rigid)}" if rigid else "") + f"), mass model "
               f"{mm.name}" + (f" ({mm.lumps} lumps per link)" if mm.name == "distributed" else "")
               + (f", payload {mm.payload:g} kg" if mm.payload else "")
               + f", {rpm_text(scene.rpm)} rpm ({scene.omega:.4g} rad/s), step {scene.step_deg:g} deg"))
    click.echo(wrap("theta: crank angle CCW from +x (0: slider at its far dead centre when the offset is 0); dx, dy: "
                     "elastic displacement of P in the global frame; rot: elastic rotation of the section at P "
                     "(CCW +); mid: coupler midspan deflection normal to its chord (CCW normal of A->B); f1: first "
                     "natural frequency of the frozen linkage; mu: transmission angle"))
    if not out["valid"]:
        click.echo("NOT VALID: " + ", ".join(out["flags"]) + " (see the warning above)")
    d = _decimals(scene.step_deg)
    w = max(9, d + 5)
    click.echo(f"{'theta deg':>{w}} {'dx mm':>10} {'dy mm':>10} {'rot mrad':>10} {'mid mm':>10} {'f1 Hz':>9} "
               f"{'mu deg':>7}")
    for i, theta in enumerate(out["crank_angle_deg"]):
        click.echo(f"{theta:{w}.{d}f} {1e3 * out['dx_m'][i]:10.4g} {1e3 * out['dy_m'][i]:10.4g} "
                   f"{1e3 * out['rotation_rad'][i]:10.4g} {1e3 * out['midspan_m'][i]:10.4g} {out['f1_hz'][i]:9.2f} "
                   f"{out['transmission_angle_deg'][i]:7.1f}")
