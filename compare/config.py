"""Campaign configuration: TOML text -> validated, frozen :class:`CampaignConfig`.

The whole document is checked before anything runs; every problem found (unknown key, wrong type,
out-of-range value, bad combination) is collected with its TOML path and reported in a single
:class:`ConfigError`.  Reference of all keys, types, units and defaults: ``docs/hdf5_schema.md``
(section "Campaign configuration") and the embedded default ``compare/default_campaign.toml``.
"""

from __future__ import annotations

import functools
import itertools
import json
import math
from dataclasses import dataclass, replace
from importlib import resources
from pathlib import Path
from typing import Any

try:  # Python >= 3.11
    import tomllib
except ModuleNotFoundError:  # pragma: no cover - Python 3.10
    import tomli as tomllib  # type: ignore[no-redef]

from compare import solvers as solver_registry
from compare.expect import Expectations, parse_expect
from compare.linkagefile import linkage_from_table, linkage_path, single_linkage, source_linkages
from compare.scenes import MECHANISMS, Grid, Items, SceneSpec, SpeedSpec
from compare.solvers import COMPONENTS, OUTPUTS
from compare.tolerances import Tolerances, parse_tolerances
from compare.tomlcheck import Checker, ConfigError, read_text, read_toml, type_name
from ked_quasi import kinds, rules, units
from ked_quasi.fatigue import CRITERIA, CYCLES, STRENGTH_RULES, Material, SNCurve
from ked_quasi.linkage import DIRECTIONS, THESIS_RPM, FourBar
from ked_quasi.massmodel import MASS_MODELS, PLACEMENTS, MassModel, default_payload
from ked_quasi.slidercrank import SliderCrank

DEFAULT_TOLERANCE = rules.DEFAULT_TOLERANCE
CONFIG_SOLVERS = ("quasi_static", "linear", "dynamic")
"""The solvers of a config without ``[campaign] solvers``: the three tiers (quasi-static, linear KED,
Exudyn), as the default campaign runs them."""

@dataclass(frozen=True)
class CampaignConfig:
    """A validated campaign.  ``text`` is the TOML source (stored in the results file)."""

    name: str
    grid: Grid
    text: str = ""
    tolerances: Tolerances | None = None
    """The ``[tolerances]`` table (None: absent; :mod:`compare.tolerances`); not part of any scene key."""
    expect: Expectations | None = None
    """The ``[expect]`` table (None: absent; :mod:`compare.expect`); not part of any scene key."""
    fatigue: Material | None = None
    """The ``[fatigue]`` table: the links' material strengths for the fatigue safety factors (None: absent);
    not part of any scene key (no deflection depends on it)."""

    def scenes(self) -> tuple[SceneSpec, ...]:
        """All scenes of the campaign grid (see :meth:`compare.scenes.Grid.expand`)."""
        return self.grid.expand()

    @property
    def linkage(self) -> FourBar | SliderCrank:
        """The first source linkage (the only one of a campaign with a single ``[linkage]`` table)."""
        return self.grid.linkage

    @property
    def linkages(self) -> tuple[FourBar | SliderCrank, ...]:
        """Every source linkage of the grid (several with a ``[[linkage]]`` array)."""
        return self.grid.linkages

    @property
    def solvers(self) -> tuple[str, ...]:
        return self.grid.solvers


# --------------------------------------------------------------------------------------------------
# public entry points


def default_config_text() -> str:
    """TOML text of the embedded default campaign (``compare/default_campaign.toml``)."""
    return resources.files("compare").joinpath("default_campaign.toml").read_text(encoding="utf-8")


def default_dynamic() -> tuple[tuple[str, Any], ...]:
    """The ``[dynamic]`` settings of the embedded default campaign, sorted (name, value) pairs as a
    campaign's scenes carry them."""
    return tuple(sorted(tomllib.loads(default_config_text())["dynamic"].items()))


def load_config(path: str | Path | None = None) -> CampaignConfig:
    """Read and validate a campaign file; ``None`` gives the embedded default campaign."""
    if path is None:
        return parse_config(default_config_text(), source="<default campaign>")
    p = Path(path)
    return parse_config(read_text(p), source=str(p))


def parse_config(text: str, source: str = "campaign config") -> CampaignConfig:
    """Parse and validate TOML ``text``; raise :class:`ConfigError` listing every problem."""
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError([f"TOML syntax error: {exc}"], source=source) from exc
    return validate(doc, text=text, source=source)


TOP_TABLES = ("campaign", "linkage", "grid", "dynamic", "tolerances", "expect", "fatigue")


def _extra_tables() -> tuple[str, ...]:
    """Every solver with settings has its table ([dynamic] is stored apart: its own grid axis and keys)."""
    return tuple(n for n in solver_registry.names() if n != "dynamic" and solver_registry.get(n).setting_fields())


def validate(doc: dict[str, Any], text: str = "", source: str = "campaign config",
             check_speeds: bool = True) -> CampaignConfig:
    """Validate a parsed TOML document; raise :class:`ConfigError` listing every problem.  ``check_speeds``
    False skips the speed-ratio bound of the grid's speeds (a single-scene command checks its own speed)."""
    c = Checker()
    extra_tables = _extra_tables()
    c.keys(doc, "", (*TOP_TABLES, *extra_tables))
    camp = c.table(doc, "campaign")
    c.keys(camp, "campaign", ("name", "tolerance", "outputs", "step_deg", "n_modes", "solvers"))
    name = c.string(camp, "campaign.name", default="campaign")
    if name is not None and (not name.strip() or any(ord(ch) < 32 or ord(ch) == 127 for ch in name)):
        c.err("campaign.name", f"must be non-blank text without control characters (NUL, tab, newline); got {name!r}")
    tolerance = c.rule(camp, "campaign.tolerance", rules.TOLERANCE, default=DEFAULT_TOLERANCE)
    outputs = c.choices(camp, "campaign.outputs", OUTPUTS, default=COMPONENTS)
    outputs = tuple(x for x in OUTPUTS if x in outputs)  # canonical order: same scenes, same keys
    if outputs and not any(x in COMPONENTS for x in outputs):
        c.err("campaign.outputs", f"must include a deflection component ({', '.join(COMPONENTS)}): every verdict "
                                  "measures the deflection; 'stress' adds the link stresses to it")
    step_deg = c.check(camp, "campaign.step_deg", rules.check_step_deg, default=10.0)
    n_modes = c.rule(camp, "campaign.n_modes", rules.N_MODES, default=3)
    solvers = c.choices(camp, "campaign.solvers", solver_registry.names(), default=CONFIG_SOLVERS)
    if solvers and "quasi_static" not in solvers:
        c.err("campaign.solvers", "must include 'quasi_static' (every verdict measures it)")
    linkages = source_linkages(c, doc.get("linkage", {}))
    grid = c.table(doc, "grid")
    c.keys(grid, "grid", ("mechanisms", "mass_models", "rpm", "speed_ratios", "stiffness_scales", "damping_ratios",
                          "directions", "dynamic_variants"))
    dynamic_raw = c.table(doc, "dynamic")
    fields = dict(
        linkages=linkages, mechanisms=c.choices(grid, "grid.mechanisms", MECHANISMS, default=("source",)),
        mass_models=_mass_models(c, grid), speeds=_speeds(c, grid),
        stiffness_scales=c.rules(grid, "grid.stiffness_scales", rules.STIFFNESS_SCALE, default=(1.0,)),
        damping_ratios=c.rules(grid, "grid.damping_ratios", rules.DAMPING_RATIO, default=(0.02,)),
        directions=c.choices(grid, "grid.directions", DIRECTIONS, default=("ccw",)),
        step_deg=step_deg, n_modes=n_modes, outputs=outputs, tolerance=tolerance,
        dynamic=_dynamic(c, dynamic_raw), dynamic_variants=_dynamic_variants(c, grid, dynamic_raw),
        extra_settings=_extra_settings(c, doc, extra_tables), solvers=tuple(x for x in solver_registry.names()
                                                                            if x in solvers))
    _distinct_labels(c, "grid.stiffness_scales", fields["stiffness_scales"])
    _distinct_labels(c, "grid.damping_ratios", fields["damping_ratios"])
    if not c.problems:
        for i, lk in enumerate(linkages):
            _check_kind_axes(c, lk, linkage_path(i, len(linkages)), fields["mechanisms"], fields["mass_models"])
    grid_obj = None if c.problems else Grid(**fields)
    if grid_obj is not None and grid_obj.size() > rules.MAX_SCENES:
        axes = " x ".join(f"{len(fields[k])} {k.replace('_', ' ')}" for k in (
            "linkages", "mechanisms", "mass_models", "speeds", "stiffness_scales", "damping_ratios", "directions",
            "dynamic_variants"))
        c.err("grid", f"{grid_obj.size()} scenes ({axes}) is more than one campaign may hold "
                      f"({rules.MAX_SCENES}); split the grid into several campaigns (join results with ked merge)")
    elif grid_obj is not None and _check_scene_size(c, grid_obj) and check_speeds:
        _check_speed_ratios(c, grid_obj)
        _check_linear_size(c, grid_obj)
    tolerances, expect = _regression_tables(c, doc)
    if expect and grid_obj is not None and not c.problems:
        _check_expect_scenes(c, expect, grid_obj)
    fatigue = _fatigue(c, doc)
    if c.problems:
        raise ConfigError(c.problems, source=source)
    assert grid_obj is not None
    return CampaignConfig(name=name, grid=grid_obj, text=text, tolerances=tolerances, expect=expect, fatigue=fatigue)


FATIGUE_KEYS = ("ultimate_strength", "endurance_limit", "yield_strength", "criterion", "sn_curve", "design_cycles")
_STRENGTHS = ("ultimate_strength", "endurance_limit", "yield_strength")


def _fatigue(c: Checker, doc: dict[str, Any]) -> Material | None:
    """The ``[fatigue]`` table (:class:`ked_quasi.fatigue.Material`): ultimate_strength [Pa] required;
    endurance_limit [Pa], or sn_curve ([[cycles, amplitude Pa], ...]) with design_cycles; optional
    yield_strength [Pa], criterion (goodman, gerber, asme-elliptic) and sn_curve (the life estimate); None when
    absent; every problem named by its key."""
    if "fatigue" not in doc:
        return None
    tab = c.table(doc, "fatigue")
    c.keys(tab, "fatigue", FATIGUE_KEYS)
    values = {k: c.check(tab, f"fatigue.{k}", STRENGTH_RULES[k].check, required=k == "ultimate_strength")
              for k in _STRENGTHS}
    values["criterion"] = c.string(tab, "fatigue.criterion", default="goodman", choices=CRITERIA)
    values["design_cycles"] = c.rule(tab, "fatigue.design_cycles", CYCLES)
    values["sn_curve"] = c.check(tab, "fatigue.sn_curve", _sn_curve)
    if any(f"fatigue.{k}" in c.bad for k in FATIGUE_KEYS) or set(tab) - set(FATIGUE_KEYS):
        return None
    try:
        return Material(**values)
    except ValueError as exc:  # the strengths' order, a missing S_e: the message names the key
        c.problems.append(str(exc).replace("Material.", "fatigue."))
        c.bad.add("fatigue")
        return None


def _sn_curve(v: Any, path: str) -> SNCurve:
    """An S-N curve from an array of [cycles, amplitude Pa] pairs."""
    if not isinstance(v, list) or not all(isinstance(p, list) and len(p) == 2 for p in v):
        raise ValueError(f"{path}: must be an array of [cycles, stress amplitude in Pa] pairs, e.g. "
                         f"[[1e3, 4.0e8], [5e8, 1.3e8]]; got {v!r}")
    try:
        return SNCurve(tuple((p[0], p[1]) for p in v))
    except ValueError as exc:
        raise ValueError(str(exc).replace("sn_curve", path, 1)) from None


def _check_expect_scenes(c: Checker, expect: Expectations, grid: Grid) -> None:
    """Every scene an ``[expect]`` table names must be a scene of the grid (label or key prefix)."""
    scenes = grid.expand()
    labels = {s.label for s in scenes}
    keys = [s.key for s in scenes]
    for name in ("holds", "fails"):
        for i, ident in enumerate(getattr(expect, name)):
            if ident not in labels and not any(k.startswith(ident) for k in keys):
                c.err(f"expect.{name}[{i}]", f"{ident!r} is not a scene of the grid (give a scene label, e.g. "
                                             f"{sorted(labels)[0]!r}, or a key prefix)")


def _regression_tables(c: Checker, doc: dict[str, Any]) -> tuple[Tolerances | None, Expectations | None]:
    """The ``[tolerances]`` and ``[expect]`` tables (None where absent), their problems added to ``c``."""
    tolerances = expect = None
    if "tolerances" in doc:
        tolerances, problems = parse_tolerances(doc["tolerances"])
        c.problems += problems
    if "expect" in doc:
        expect, problems = parse_expect(doc["expect"], MASS_MODELS)
        c.problems += problems
    return tolerances, expect


# --------------------------------------------------------------------------------------------------
# sections of the document


def _distinct_labels(c: Checker, path: str, values: tuple[float, ...]) -> None:
    """Values that print alike (scene labels use %g) would give two scenes one label: refused."""
    seen: dict[str, float] = {}
    for v in values:
        text = f"{v:g}"
        if text in seen:
            c.err(path, f"values {seen[text]!r} and {v!r} are both shown as {text} in scene labels and figure "
                        "names; use values that differ in their first 6 significant digits")
        seen[text] = v


def _speeds(c: Checker, grid: dict[str, Any]) -> tuple[SpeedSpec, ...]:
    rpms = c.rules(grid, "grid.rpm", rules.RPM, default=())
    ratios = c.rules(grid, "grid.speed_ratios", rules.SPEED_RATIO, default=())
    _distinct_labels(c, "grid.rpm", rpms)
    _distinct_labels(c, "grid.speed_ratios", ratios)
    if "rpm" not in grid and "speed_ratios" not in grid:
        rpms = (THESIS_RPM,)
    elif not rpms and not ratios and not any(b.startswith(("grid.rpm", "grid.speed_ratios")) for b in c.bad):
        c.err("grid", "at least one crank speed is required in grid.rpm or grid.speed_ratios")
    return tuple(SpeedSpec("rpm", v) for v in rpms) + tuple(SpeedSpec("ratio", v) for v in ratios)


def _check_kind_axes(c: Checker, source: FourBar | SliderCrank, path: str, mechanisms: tuple[str, ...],
                     mass_models: tuple[MassModel, ...]) -> None:
    """Every grid point must apply to every linkage of the grid: refused at load (one line naming the grid
    parameter and the linkage), never skipped nor stored as failed.  Each mechanism must be one of the linkage's
    kind (a four-bar's crank-drivable; a slider-crank has only its source) and each mass model one of its kind's
    (:mod:`ked_quasi.kinds`)."""
    kind = kinds.of_linkage(source)
    split = " (split the grid into one campaign per kind and join the files with ked merge)" \
        if path != "linkage" else ""
    if any(mech not in kind.mechanisms for mech in mechanisms):  # the mechanisms are a source and its cognate
        c.err("grid.mechanisms", f"{path} is a {kind.name}, which has no Roberts cognate: use "
                                 f"{json.dumps(list(kind.mechanisms))}{split}")
    bad = [mm.name for mm in mass_models if mm.name not in kind.mass_models]
    if bad:
        c.err("grid.mass_models", f"{', '.join(bad)}: not a mass model of a {kind.name} ({path}; allowed: "
                                  f"{', '.join(kind.mass_models)}){split}")
    for mech in (m for m in mechanisms if m in kind.mechanisms):
        try:
            kind.variant(source, mech)
        except ValueError as exc:
            c.err("grid.mechanisms", f"{mech!r}: {exc}" + (f" ({path})" if path != "linkage" else ""))


LINEAR_SOLVERS = ("linear", "linear_classic")
"""The solvers that run the linear KED model (its coordinate cap applies to their scenes)."""


def _check_scene_size(c: Checker, grid: Grid) -> bool:
    """Every linkage and mass model of the grid makes a scene of a size the solvers can hold at the campaign's
    step (:func:`ked_quasi.rules.check_work`): else refused at load, naming the two parameters; False then."""
    for i, linkage in enumerate(grid.linkages):
        where = "" if len(grid.linkages) == 1 else f" ({linkage_path(i, len(grid.linkages))})"
        for j, mm in enumerate(grid.mass_models):
            try:
                kinds.of_linkage(linkage).scene_type(linkage, mm, 1.0, grid.step_deg)
            except ValueError as exc:
                reason = str(exc).split(": ", 1)[-1]
                c.err("campaign.step_deg", f"with grid.mass_models[{j}].lumps = {mm.lumps}{where}: {reason}")
                return False
    return True


def _check_linear_size(c: Checker, grid: Grid) -> None:
    """A grid that runs the linear model is refused at load when a mass model's lumps exceed the model's
    coordinate cap for one of its linkages (:func:`ked_linear.size.check_size`, naming the allowed lumps)."""
    if not any(name in LINEAR_SOLVERS for name in grid.solvers):
        return
    from ked_linear.size import check_size

    for i, linkage in enumerate(grid.linkages):
        where = "" if len(grid.linkages) == 1 else f" ({linkage_path(i, len(grid.linkages))})"
        for j, mm in enumerate(grid.mass_models):
            scene = kinds.of_linkage(linkage).scene_type(linkage, mm, 1.0, grid.step_deg)
            try:
                check_size(scene, label=f"grid.mass_models[{j}].lumps{where}")
            except ValueError as exc:
                c.problems.append(str(exc))
                c.bad.add("grid.mass_models")
                return


def _check_speed_ratios(c: Checker, grid: Grid) -> None:
    """r = Omega/omega1_min above the bound (or below its floor) at a requested rpm is refused: checked once
    per distinct mechanism and mass model, at the fastest rpm and the smallest stiffness scale (every Young's
    modulus times k scales the frozen structure's stiffness by k, so omega1_min grows as sqrt(k): that pair has
    the largest r), and at the slowest rpm and the largest scale (the smallest r)."""
    rpms = [s.value for s in grid.speeds if s.kind == "rpm"]
    if not rpms:
        return
    # the fastest rpm at the softest scale has the largest r, the slowest at the stiffest the smallest
    for rpm, k in ((max(rpms), min(grid.stiffness_scales)), (min(rpms), max(grid.stiffness_scales))):
        for i, linkage in enumerate(grid.linkages):
            where = "" if len(grid.linkages) == 1 else f"{linkage_path(i, len(grid.linkages))}, "
            kind = kinds.of_linkage(linkage)
            for mech, mm in itertools.product(grid.mechanisms, grid.mass_models):
                named = f"{mech}, " if len(kind.mechanisms) > 1 else ""  # a kind of one mechanism: not named
                try:
                    check_speed(kind.variant(linkage, mech, k), mm, rpm, grid.step_deg,
                                label=f"grid.rpm ({where}{named}{mm.name}, stiffness x{k:g})")
                except ValueError as exc:
                    c.problems.append(str(exc))
                    c.bad.add("grid.rpm")
                    return
            if "grid.rpm" in c.bad:
                return


def check_speed(fourbar: FourBar | SliderCrank, mass_model: MassModel, rpm: float, step_deg: float,
                label: str = "rpm") -> None:
    """Refuse a crank speed ``rpm`` [rev/min] at which r = Omega/omega1_min exceeds the rule's bound
    (:func:`ked_quasi.rules.check_speed_ratio`, naming the likely unit mix-up) or lies below
    :data:`~ked_quasi.rules.MIN_SPEED_RATIO`.  A quick estimate (:data:`~ked_quasi.rules.SPEED_RATIO_LOAD_STEP_DEG`)
    screens; a suspicious speed is confirmed with the scene's own step and lumps, the omega1_min the run
    would compute."""
    from ked_quasi.units import rpm_to_rad_s

    bound = float(rules.SPEED_RATIO.hi)  # type: ignore[arg-type]
    quick = _omega1_min(fourbar, replace(mass_model, lumps=min(mass_model.lumps, rules.SPEED_RATIO_LOAD_LUMPS)),
                        rules.SPEED_RATIO_LOAD_STEP_DEG)
    r = units.speed_ratio(rpm_to_rad_s(rpm), quick)
    if not (r > rules.SPEED_RATIO_SCREEN * bound or r < rules.MIN_SPEED_RATIO / rules.SPEED_RATIO_SCREEN):
        return
    exact = _omega1_min(fourbar, mass_model, step_deg)
    rules.check_speed_ratio(units.speed_ratio(rpm_to_rad_s(rpm), exact), rpm, exact / (2.0 * math.pi), label)


@functools.lru_cache(maxsize=512)
def _omega1_min(fourbar: FourBar | SliderCrank, mass_model: MassModel, step_deg: float) -> float:
    """Lowest first natural circular frequency over the turn [rad/s] (nan if none is finite), as
    :func:`compare.execute.frame` computes it."""
    import warnings

    import numpy as np

    kind = kinds.of_linkage(fourbar)
    f1 = kind.natural_frequencies(kind.scene_type(fourbar, mass_model, 1.0, step_deg), n_modes=1)[:, 0]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return 2.0 * math.pi * float(np.nanmin(f1)) if np.isfinite(f1).any() else math.nan


def load_linkage(path: str | Path) -> FourBar:
    """The ``[linkage]`` table of a TOML file (campaign schema; every table name and key checked) as the source
    four-bar; :class:`ConfigError` naming the file and every problem otherwise."""
    p = Path(path)
    doc = read_toml(p)
    single_linkage(doc, p)
    c = Checker()
    c.keys(doc, "", (*TOP_TABLES, *_extra_tables()))  # a misspelt table is refused, never ignored
    fb = linkage_from_table(c, c.table(doc, "linkage"))
    if c.problems or fb is None:
        raise ConfigError(c.problems or ["linkage: missing"], source=str(p))
    return fb


def _mass_models(c: Checker, grid: dict[str, Any]) -> tuple[MassModel, ...]:
    path = "grid.mass_models"
    raw = grid.get("mass_models", ["tip"])
    if not isinstance(raw, list) or not raw:
        c.err(path, f"must be a non-empty array of names or tables, got {type_name(raw)}")
        return ()
    out: list[MassModel] = []
    for i, item in enumerate(raw):
        p = f"{path}[{i}]"
        item = {"name": item} if isinstance(item, str) else item
        if not isinstance(item, dict):
            c.err(p, f"must be a mass-model name or a table, got {type_name(item)}")
            continue
        c.keys(item, p, ("name", "lumps", "payload_kg", "joint_split", "placement"))
        name = c.string(item, f"{p}.name", required=True, choices=MASS_MODELS)
        vals = dict(name=name, lumps=c.rule(item, f"{p}.lumps", rules.LUMPS, default=rules.DEFAULT_LUMPS),
                    payload=c.rule(item, f"{p}.payload_kg", rules.PAYLOAD_KG, default=default_payload(name)),
                    joint_split=c.rule(item, f"{p}.joint_split", rules.JOINT_SPLIT, default=0.5),
                    placement=c.string(item, f"{p}.placement", default="midpoint", choices=PLACEMENTS))
        if None in vals.values():
            continue
        try:
            out.append(MassModel(**vals))
        except ValueError as exc:
            c.err(p, str(exc))
    if len(set(out)) != len(out):
        c.err(path, "duplicate mass models")
    return tuple(out)


def _extra_settings(c: Checker, doc: dict[str, Any], tables: tuple[str, ...]) -> tuple[tuple[str, Items], ...]:
    """Settings tables of solvers other than Exudyn (e.g. ``[linear]``), each checked like ``[dynamic]``."""
    return tuple((name, _settings_table(c, name, c.table(doc, name))) for name in tables if name in doc)


def _dynamic(c: Checker, tab: dict[str, Any], prefix: str = "dynamic",
             check_settings: bool = True) -> tuple[tuple[str, Any], ...]:
    return _settings_table(c, "dynamic", tab, prefix, check_settings)


def _settings_table(c: Checker, name: str, tab: dict[str, Any], prefix: str | None = None,
                    check_settings: bool = True) -> Items:
    """One solver's settings table (``[dynamic]``, ``[linear]``, ...), the same for every solver: each key a
    field of the solver's settings (the damping ratio is a grid axis), each value checked by the rule the
    solver declares for it (:attr:`compare.solvers.Solver.setting_rules`, the rules its settings class
    checks; a field without one: the type of its default), then the solver's settings built from them."""
    prefix = prefix or name
    solver = solver_registry.get(name)
    fields, rules_of = solver.setting_fields(), solver.setting_rules()
    out: dict[str, Any] = {}
    for key in tab:
        p = f"{prefix}.{key}"
        if key == "damping_ratio":
            c.err(p, f"set damping in grid.damping_ratios (a grid axis), not in [{name}]")
            continue
        if key not in fields:
            c.err(p, f"unknown key (allowed: {', '.join(sorted(k for k in fields if k != 'damping_ratio'))})")
            continue
        v = c.rule(tab, p, rules_of[key]) if key in rules_of else c.like(tab, p, fields[key])
        if v is not None:
            out[key] = v
    if check_settings and not any(b.startswith(f"{prefix}.") for b in c.bad):
        try:
            solver.make_settings(out, 0.02)
        except (TypeError, ValueError) as exc:
            c.err(prefix, str(exc))
    return tuple(sorted(out.items()))


def _dynamic_variants(c: Checker, grid: dict[str, Any],
                      base: dict[str, Any]) -> tuple[tuple[tuple[str, Any], ...], ...]:
    """``grid.dynamic_variants``: an array of tables of ``[dynamic]`` overrides (a grid axis).

    A value given as an array expands the variant into the Cartesian product of its values (the
    fields of DynamicSettings are scalars, so this is unambiguous).  Each expanded variant is
    validated like ``[dynamic]``, merged on top of it.  Absent key: one variant, no overrides.
    """
    path = "grid.dynamic_variants"
    if "dynamic_variants" not in grid:
        return ((),)
    raw = grid["dynamic_variants"]
    if not isinstance(raw, list) or not raw:
        c.err(path, f"must be a non-empty array of tables, got {type_name(raw)}")
        return ((),)
    out: list[tuple[tuple[str, Any], ...]] = []
    for i, item in enumerate(raw):
        p = f"{path}[{i}]"
        if not isinstance(item, dict) or not item:
            c.err(p, f"must be a non-empty table of [dynamic] settings, got {type_name(item)}")
            continue
        axes = []
        for key, v in item.items():
            if isinstance(v, list):
                if not v:
                    c.err(f"{p}.{key}", "must not be an empty array")
                axes.append([(key, x) for x in v])
            else:
                axes.append([(key, v)])
        for combo in itertools.product(*axes):
            n_bad = len(c.problems)
            own = _dynamic(c, dict(combo), prefix=p, check_settings=False)
            if len(c.problems) > n_bad:
                break  # one report per variant table
            if not any(b.startswith("dynamic") for b in c.bad):  # the merged settings must be valid too
                _dynamic(c, {**base, **dict(own)}, prefix=p)
            if len(c.problems) > n_bad:
                break
            out.append(own)
    if len(set(out)) != len(out):
        c.err(path, "duplicate variants")
    return tuple(out) or ((),)
