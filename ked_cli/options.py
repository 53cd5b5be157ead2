"""The options every single-scene command shares, checked by the same rules as campaigns.

``--linkage`` takes ``thesis`` or a TOML file holding a ``[linkage]`` table in exactly the campaign
schema, so every campaign config is also a linkage file.  Values are checked by
:mod:`ked_quasi.rules` (the same bounds and reasons as the campaign loader and the dataclasses).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import click

from ked_quasi import rules
from ked_quasi.cognates import MECHANISMS
from ked_quasi.linkage import DIRECTIONS
from ked_quasi.massmodel import MASS_MODELS


class RuleType(click.ParamType):
    """A number checked by a :class:`ked_quasi.rules.Rule` (or a check function)."""

    def __init__(self, rule: rules.Rule | None = None, check: Callable[[object, str], Any] | None = None) -> None:
        self.rule = rule
        self.check = check or (rule.check if rule else None)
        self.name = "integer" if rule is not None and rule.integer else "number"

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        if not isinstance(value, str):
            return value
        text = value.strip()
        try:
            number: Any = int(text) if self.name == "integer" else float(text)
        except ValueError:
            if self.name == "integer":
                try:
                    number = float(text)  # "5.0" reads, "5.5" is refused by the rule
                except ValueError:
                    self.fail(f"{value!r} is not a number", param, ctx)
                if not math.isfinite(number):  # nan, inf, 1e400
                    self.fail(f"must be {self.rule.allowed() if self.rule else 'finite'}; got {value!r}", param, ctx)
                number = int(number) if number == int(number) else number
            else:
                self.fail(f"{value!r} is not a number", param, ctx)
        try:
            return self.check(number, "value")
        except ValueError as exc:
            self.fail(str(exc).removeprefix("value: "), param, ctx)

    def get_metavar(self, param: click.Parameter, ctx: click.Context | None = None) -> str:
        return self.name.upper()


def linkage_option(default: str = "thesis") -> Callable:
    return click.option("--linkage", default=default, show_default=True, metavar="thesis|FILE.toml",
                        help="The four-bar: 'thesis' or a TOML file with a [linkage] table (campaign schema).")


def scene_options(f: Callable) -> Callable:
    """Decorate a command with the scene options (see :class:`SceneOptions`)."""
    opts = [
        linkage_option(),
        click.option("--mechanism", type=click.Choice(MECHANISMS), default="source", show_default=True,
                     help="The source four-bar or its crank-driven Roberts cognate."),
        click.option("--mass-model", type=click.Choice(MASS_MODELS), default="tip", show_default=True,
                     help="tip (Case I), joints (Case II), extender (Case III), distributed."),
        click.option("--rpm", type=RuleType(rules.RPM), default=300.0, show_default=True,
                     help=f"Crank speed: {rules.RPM.allowed()}."),
        click.option("--step-deg", type=RuleType(check=rules.check_step_deg), default=10.0, show_default=True,
                     help=f"Crank-angle grid step: {rules.STEP_DEG.allowed()}, dividing 360."),
        click.option("--lumps", type=RuleType(rules.LUMPS), default=rules.DEFAULT_LUMPS, show_default=True,
                     help=f"Lumps per distributed link (extender, distributed models): {rules.LUMPS.allowed()}."),
        click.option("--payload-kg", type=RuleType(rules.PAYLOAD_KG), default=None,
                     help=f"Point mass at P: {rules.PAYLOAD_KG.allowed()} [default: 2 lb for tip, else 0]."),
        click.option("--stiffness-scale", type=RuleType(rules.STIFFNESS_SCALE), default=1.0, show_default=True,
                     help=f"Multiply every Young's modulus: {rules.STIFFNESS_SCALE.allowed()}."),
        click.option("--direction", type=click.Choice(DIRECTIONS), default=None,
                     help="Crank direction [default: the linkage's, ccw for a TOML linkage]."),
    ]
    for o in reversed(opts):
        f = o(f)
    return f


@dataclass(frozen=True)
class SceneOptions:
    """The scene options as given (SI apart from rpm and deg)."""

    linkage: str
    mechanism: str
    mass_model: str
    rpm: float
    step_deg: float
    lumps: int
    payload_kg: float | None
    stiffness_scale: float
    direction: str | None

    @staticmethod
    def pop(kw: dict[str, Any]) -> SceneOptions:
        """Take the scene options out of a command's keyword arguments."""
        return SceneOptions(**{k: kw.pop(k) for k in SceneOptions.__dataclass_fields__})

    def describe(self) -> str:
        """One line naming the scene."""
        from compare.inspect import rpm_text

        return (f"{self.linkage} linkage, {self.mechanism}, mass model {self.mass_model}, {rpm_text(self.rpm)} rpm, "
                f"step {self.step_deg:g} deg, stiffness x{self.stiffness_scale:g}")


def load_source(linkage: str) -> Any:
    """The source four-bar of ``--linkage``; a UsageError naming the option and the file otherwise."""
    from ked_quasi.linkage import thesis_fourbar

    if linkage == "thesis":
        return thesis_fourbar()
    _refuse_slider_crank(linkage)
    return scene_file(linkage).linkage


def is_file(linkage: str) -> bool:
    """True when ``--linkage`` names a file (not a preset)."""
    from ked_quasi.presets import slider_linkage

    return linkage != "thesis" and slider_linkage(linkage) is None


_FILES: dict[str, Any] = {}


def scene_file(linkage: str) -> Any:
    """The user's file ``--linkage`` names, read once by the campaign's rules (``compare.scenefile.load_scene_file``:
    every table and key checked, as ``ked run`` reads it); every problem on its own line otherwise."""
    import os

    from compare.scenefile import ConfigError, load_scene_file
    from ked_cli.errors import ProblemsError

    try:
        st = os.stat(linkage)
        key: Any = (linkage, st.st_mtime_ns, st.st_size, st.st_ino)  # a rewritten file is read again
    except OSError:
        key = None
    if key is None or key not in _FILES:
        try:
            cfg = load_scene_file(linkage)
        except ConfigError as exc:
            raise ProblemsError(exc.source, exc.problems, "--linkage") from None
        if key is None:
            return cfg
        _FILES[key] = cfg
    return _FILES[key]


def explicit(ctx: click.Context | None, name: str) -> bool:
    """True when the option ``name`` was given on the command line (not its default)."""
    if ctx is None or name not in ctx.params:
        return False
    return ctx.get_parameter_source(name) not in (click.core.ParameterSource.DEFAULT, None)


def file_scene_specs(linkage: str, *, mechanism: str, mass_model: str, lumps: int, payload_kg: float | None,
                     stiffness_scale: float, direction: str | None, rpms: list[float],
                     damping_ratio: float | None = None, single: bool = True, forced: tuple[str, ...] = (),
                     **settings: Any) -> tuple[Any, ...]:
    """The campaign scenes of a single-scene command on the user's file ``linkage``
    (:func:`compare.scenefile.file_scenes`): the file's ``[grid]``, ``[campaign]``, ``[dynamic]`` and solver tables
    describe the scene, the options given on the command line override them (explicitly; an option left at
    its default does not).  ``rpms``: the speeds given (empty: the file's).  ``single``: one scene only.
    ``settings``: grid fields to set when their option was given (``tolerance``, ``step_deg``); ``forced``: options
    to take as given (a command looping over mechanisms or mass models)."""
    from dataclasses import replace

    from compare.scenefile import file_scenes
    from ked_quasi.massmodel import MassModel, default_payload

    cfg = scene_file(linkage)
    ctx = click.get_current_context(silent=True)

    def _explicit(ctx: click.Context | None, name: str) -> bool:
        return name in forced or explicit(ctx, name)

    given: dict[str, Any] = {}
    for axis, opt, value in (("mechanisms", "mechanism", mechanism),
                             ("stiffness_scales", "stiffness_scale", stiffness_scale),
                             ("damping_ratios", "damping_ratio", damping_ratio),
                             ("directions", "direction", direction)):
        if _explicit(ctx, opt) and value is not None:
            given[axis] = value
    mm_fields = {"lumps": lumps} if _explicit(ctx, "lumps") else {}
    if _explicit(ctx, "payload_kg") and payload_kg is not None:
        mm_fields["payload"] = payload_kg
    if _explicit(ctx, "mass_model"):
        same = [m for m in cfg.grid.mass_models if m.name == mass_model]
        base = same[0] if len(same) == 1 else MassModel(mass_model, payload=default_payload(mass_model))
        given["mass_models"] = replace(base, **mm_fields)
    elif mm_fields and len(cfg.grid.mass_models) == 1:
        given["mass_models"] = replace(cfg.grid.mass_models[0], **mm_fields)
    chosen = {k: v for k, v in settings.items() if _explicit(ctx, k)}
    try:
        specs = file_scenes(cfg, given, rpms or None, **chosen)
    except ValueError as exc:
        raise click.UsageError(f"{linkage}: {exc}") from None
    if single and len(specs) > 1:
        shown = ", ".join(f"{s.speed.value:g}" for s in specs)
        raise click.BadParameter(f"{linkage}: grid.rpm: the file holds {len(specs)} speeds ({shown} rpm); choose "
                                 "one", param_hint="--rpm")
    return specs


def file_spec(o: SceneOptions, damping_ratio: float | None = None, forced: tuple[str, ...] = ()) -> Any:
    """The one campaign scene the options describe on the user's file ``o.linkage`` (:func:`file_scene_specs`)."""
    ctx = click.get_current_context(silent=True)
    return file_scene_specs(o.linkage, mechanism=o.mechanism, mass_model=o.mass_model, lumps=o.lumps,
                            payload_kg=o.payload_kg, stiffness_scale=o.stiffness_scale, direction=o.direction,
                            rpms=[o.rpm] if explicit(ctx, "rpm") else [], damping_ratio=damping_ratio,
                            forced=forced, step_deg=o.step_deg)[0]


def _refuse_slider_crank(linkage: str) -> None:
    """BadParameter when ``--linkage`` names a slider-crank (for the commands that take only a four-bar)."""
    from ked_quasi.presets import slider_linkage
    from ked_quasi.slidercrank import SliderCrank

    if slider_linkage(linkage) is not None or isinstance(scene_file(linkage).linkage, SliderCrank):
        raise click.BadParameter(f"{linkage}: this command does not take a slider-crank yet ('ked quasi', 'linear', "
                                 "'simulate', 'check' and 'run' do); it takes a four-bar: thesis or a TOML file "
                                 "with a four-bar [linkage] table", param_hint="--linkage")


def resolve(o: SceneOptions) -> SceneOptions:
    """The options with a user file's scene filled in (what the command runs and prints); unchanged for a
    preset linkage."""
    from dataclasses import replace

    if not is_file(o.linkage):
        return o
    spec = file_spec(o)
    return replace(o, mechanism=spec.mechanism, mass_model=spec.mass_model.name, rpm=spec.speed.value,
                   step_deg=spec.step_deg, lumps=spec.mass_model.lumps, payload_kg=spec.mass_model.payload,
                   stiffness_scale=spec.stiffness_scale, direction=spec.direction)


def build_scene(o: SceneOptions, mechanism: str | None = None, mass_model: str | None = None) -> Any:
    """The ``ked_quasi.Scene`` the options describe (the campaign's construction: the same numbers)."""
    from dataclasses import replace

    from ked_quasi.scene import build_scene as build

    source = load_source(o.linkage)
    if is_file(o.linkage):  # the file's scene, the options given overriding it
        spec = file_spec(replace(o, mechanism=mechanism or o.mechanism, mass_model=mass_model or o.mass_model),
                         forced=(("mechanism",) if mechanism else ()) + (("mass_model",) if mass_model else ()))
        try:
            scene = spec.scene(spec.speed.value)
        except ValueError as exc:
            raise click.UsageError(str(exc)) from None
        refuse_fast(scene.fourbar, scene.mass_model, [scene.rpm], scene.step_deg, "--rpm")
        return scene
    try:
        scene = build(source, mechanism or o.mechanism, mass_model or o.mass_model, o.rpm, o.step_deg, o.lumps,
                      o.payload_kg, o.stiffness_scale, o.direction)
    except ValueError as exc:
        raise click.UsageError(str(exc)) from None
    refuse_fast(scene.fourbar, scene.mass_model, [o.rpm], o.step_deg, "--rpm")
    return scene


def build_slider(o: SceneOptions, sc: Any, refuse_fast: bool = True) -> Any:
    """The ``SliderScene`` the options describe for a slider-crank ``sc`` (as ``ked quasi`` builds it: mass
    model distributed unless --mass-model is given, the source mechanism only, the speed-ratio bound unless
    ``refuse_fast`` is False)."""
    from ked_quasi.slider_static import slider_natural_frequencies
    from ked_quasi.slidercrank import build_slider_scene

    ctx = click.get_current_context(silent=True)
    given = ctx is not None and ctx.get_parameter_source("mass_model") not in (click.core.ParameterSource.DEFAULT,
                                                                                 None)
    if o.mechanism != "source":
        raise click.BadParameter("a slider-crank has no Roberts cognate; use --mechanism source",
                                 param_hint="--mechanism")
    if is_file(o.linkage):  # the file's scene, the options given overriding it
        spec = file_spec(o)
        try:
            scene = spec.scene(spec.speed.value)
        except ValueError as exc:
            raise click.UsageError(str(exc)) from None
        if refuse_fast:
            refuse_fast_slider(scene, [scene.rpm], "--rpm", slider_natural_frequencies)
        return scene
    try:
        scene = build_slider_scene(sc, o.mass_model if given else "distributed", o.rpm, o.step_deg, o.lumps,
                                   o.payload_kg, o.stiffness_scale, o.direction)
    except ValueError as exc:
        raise click.UsageError(str(exc)) from None
    if refuse_fast:
        refuse_fast_slider(scene, [o.rpm], "--rpm", slider_natural_frequencies)
    return scene


def refuse_fast_slider(scene: Any, rpms: list[float], hint: str, frequencies: Any = None) -> None:
    """BadParameter for ``hint`` when a crank speed's r = Omega/omega1_min of a slider-crank scene is above the
    rules' bound."""
    from ked_quasi import units
    from ked_quasi.slider_static import slider_natural_frequencies
    from ked_quasi.units import rpm_to_rad_s

    f1 = (frequencies or slider_natural_frequencies)(scene, n_modes=1)[:, 0]
    f1_min = float(min((f for f in f1 if f == f), default=math.nan))
    for rpm in rpms:
        try:
            rules.check_speed_ratio(units.speed_ratio(rpm_to_rad_s(rpm), 2.0 * math.pi * f1_min), rpm, f1_min, "value")
        except ValueError as exc:
            raise click.BadParameter(str(exc).removeprefix("value = "), param_hint=hint) from None


def refuse_fast(fourbar: Any, mass_model: Any, rpms: list[float], step_deg: float, hint: str) -> None:
    """BadParameter for ``hint`` when a crank speed's r = Omega/omega1_min is above the rules' bound or
    below its floor (:data:`ked_quasi.rules.MIN_SPEED_RATIO`)."""
    from compare.config import check_speed

    for rpm in sorted({max(rpms), min(rpms)}) if rpms else ():  # the largest and the smallest r
        try:
            check_speed(fourbar, mass_model, rpm, step_deg, label="value")
        except ValueError as exc:
            raise click.BadParameter(str(exc).removeprefix("value = "), param_hint=hint) from None


def refuse_oversized(scene: Any) -> None:
    """BadParameter for --lumps when the linear KED model cannot take the scene (for the commands that
    need it: ``ked linear``, ``ked check``), at load, before anything is solved."""
    from ked_linear.size import check_size

    try:
        check_size(scene, label="value")
    except ValueError as exc:
        raise click.BadParameter(str(exc).removeprefix("value: "), param_hint="--lumps") from None


WIDTH = 100
"""Columns of every human-readable line a command prints."""


def wrap(text: str, indent: str = "  ") -> str:
    """``text`` in lines of at most :data:`WIDTH` columns, continuation lines indented (long words,
    e.g. paths, are never split)."""
    import textwrap

    return textwrap.fill(text, width=WIDTH, subsequent_indent=indent, break_on_hyphens=False,
                         break_long_words=False)


def json_text(value: Any, **dumps: Any) -> str:
    """Strict JSON (no NaN or inf: null instead; tuples as lists) of plain data (``dumps``: options of
    :func:`json.dumps`, e.g. ``indent``)."""
    import json
    import math

    def clean(v: Any) -> Any:
        if isinstance(v, dict):
            return {k: clean(x) for k, x in v.items()}
        if isinstance(v, (list, tuple)):
            return [clean(x) for x in v]
        if isinstance(v, float) and not math.isfinite(v):
            return None
        return v

    return json.dumps(clean(value), allow_nan=False, **dumps)


def cap_workers(ctx: click.Context, param: click.Parameter, value: int | None) -> int | None:
    """Click callback of every ``--workers``: more local worker processes than the CPUs available are never
    started (``compare.runner.default_workers``); say so once, on standard error."""
    given = ctx.get_parameter_source(param.name) == click.core.ParameterSource.COMMANDLINE
    if value is not None and given:
        from compare.executor import default_workers

        cpus = default_workers()
        if value > cpus:
            click.echo(f"ked: --workers {value}: at most {cpus} local worker processes start (the CPUs available "
                       "to this process)", err=True)
    return value
