"""`ked quasi`: the quasi-static solve of one scene, or a summary over mechanisms and mass models."""

from __future__ import annotations

import json
import warnings

import click
import numpy as np

from .massmodel import MASS_MODELS
from .presets import LINKAGES, make_scene
from .solver import natural_frequencies, solve_quasi_static


def scene_options(f):
    """The scene options shared by `ked quasi` and `ked simulate`."""
    opts = [
        click.option("--linkage", type=click.Choice(sorted(LINKAGES)), default="thesis", show_default=True,
                     help="Linkage preset."),
        click.option("--mechanism", type=click.Choice(["source", "cognate"]), default="source",
                     show_default=True, help="The source four-bar or its crank-driven Roberts cognate."),
        click.option("--mass-model", type=click.Choice(MASS_MODELS), default="tip", show_default=True,
                     help="tip (Case I), joints (Case II), extender (Case III), distributed."),
        click.option("--rpm", type=click.FloatRange(min=0, min_open=True), default=300.0, show_default=True,
                     help="Crank speed [rev/min]."),
        click.option("--step-deg", type=click.FloatRange(min=0, max=360, min_open=True), default=10.0,
                     show_default=True, help="Crank-angle grid step [deg]; must divide 360."),
        click.option("--lumps", type=click.IntRange(min=1), default=5, show_default=True,
                     help="Lumps per distributed link (extender, distributed models)."),
        click.option("--payload-kg", type=click.FloatRange(min=0), default=None,
                     help="Point mass at P [kg] (default: 2 lb for thesis/tip, else 0)."),
        click.option("--stiffness-scale", type=click.FloatRange(min=0, min_open=True), default=1.0,
                     show_default=True, help="Multiply every Young's modulus."),
        click.option("--direction", type=click.Choice(["ccw", "cw"]), default=None,
                     help="Crank direction (default: the linkage's)."),
    ]
    for o in reversed(opts):
        f = o(f)
    return f


def scene_from_options(kw: dict):
    try:
        return make_scene(kw["linkage"], kw["mechanism"], kw["mass_model"], kw["rpm"], kw["step_deg"],
                          kw["lumps"], kw["payload_kg"], kw["stiffness_scale"], kw["direction"])
    except ValueError as exc:
        raise click.BadParameter(str(exc)) from exc


@click.command("quasi")
@scene_options
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object with the arrays.")
@click.option("--summary", is_flag=True,
              help="Ignore --mechanism/--mass-model: solve source and cognate in every mass model, print a table.")
def quasi(as_json: bool, summary: bool, **kw) -> None:
    """Quasi-static KED solve (instantaneous-structure flexibility method) of one scene.

    JSON keys: crank_angle_deg, dx_m, dy_m, rotation_rad (elastic deflection of P, global frame),
    f1_hz (first natural frequency of the frozen structure), transmission_angle_deg, flagged.
    """
    if summary:
        _summary(kw, as_json)
        return
    scene = scene_from_options(kw)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = solve_quasi_static(scene)
        f1 = natural_frequencies(scene, n_modes=1)[:, 0]
    for w in caught:
        click.echo(f"warning: {w.message}", err=True)
    out = {
        "crank_angle_deg": np.degrees(res.crank_angle).tolist(),
        "dx_m": res.deflection[:, 0].tolist(), "dy_m": res.deflection[:, 1].tolist(),
        "rotation_rad": res.deflection[:, 2].tolist(), "f1_hz": f1.tolist(),
        "transmission_angle_deg": np.degrees(res.transmission_angle).tolist(),
        "flagged": res.flagged.tolist(),
    }
    if as_json:
        click.echo(json.dumps(out))
        return
    click.echo(f"{'theta deg':>9} {'dx mm':>9} {'dy mm':>9} {'rot mrad':>9} {'f1 Hz':>7} {'mu deg':>7}")
    for i in range(res.crank_angle.size):
        click.echo(f"{out['crank_angle_deg'][i]:9.1f} {1e3 * out['dx_m'][i]:9.3f} {1e3 * out['dy_m'][i]:9.3f} "
                   f"{1e3 * out['rotation_rad'][i]:9.3f} {f1[i]:7.2f} {out['transmission_angle_deg'][i]:7.1f}"
                   + ("  FLAGGED" if res.flagged[i] else ""))


def _summary(kw: dict, as_json: bool) -> None:
    rows = []
    for mech in ("source", "cognate"):
        for mm in MASS_MODELS:
            scene = scene_from_options({**kw, "mechanism": mech, "mass_model": mm})
            res = solve_quasi_static(scene)
            f1 = natural_frequencies(scene, n_modes=1)[:, 0]
            mag = np.hypot(res.deflection[:, 0], res.deflection[:, 1])
            rows.append({"mechanism": mech, "mass_model": mm, "mass_kg": scene.mass_model.payload,
                         "peak_deflection_m": float(mag.max()),
                         "peak_at_deg": float(np.degrees(res.crank_angle[mag.argmax()])),
                         "peak_rotation_rad": float(np.abs(res.deflection[:, 2]).max()),
                         "f1_min_hz": float(f1.min()), "f1_max_hz": float(f1.max()),
                         "speed_ratio": float(scene.omega / (2 * np.pi * f1.min()))})
    if as_json:
        click.echo(json.dumps(rows))
        return
    click.echo(f"Quasi-static KED summary: linkage={kw['linkage']}, {kw['rpm']:g} rpm, step {kw['step_deg']:g} deg")
    click.echo(f"{'mechanism':<9} {'mass model':<11} {'peak |d| mm':>11} {'at deg':>7} {'peak rot mrad':>13} "
               f"{'f1 min..max Hz':>15} {'Omega/w1min':>11}")
    for r in rows:
        click.echo(f"{r['mechanism']:<9} {r['mass_model']:<11} {1e3 * r['peak_deflection_m']:11.3f} "
                   f"{r['peak_at_deg']:7.1f} {1e3 * r['peak_rotation_rad']:13.3f} "
                   f"{r['f1_min_hz']:7.2f}..{r['f1_max_hz']:<7.2f} {r['speed_ratio']:11.3f}")
