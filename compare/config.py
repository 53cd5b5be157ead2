"""Campaign configuration: TOML text -> validated, frozen :class:`CampaignConfig`.

The whole document is checked before anything runs; every problem found (unknown key, wrong type,
out-of-range value, bad combination) is collected with its TOML path and reported in a single
:class:`ConfigError`.  Reference of all keys, types, units and defaults: ``docs/hdf5_schema.md``
(section "Campaign configuration") and the embedded default ``compare/default_campaign.toml``.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

try:  # Python >= 3.11
    import tomllib
except ModuleNotFoundError:  # pragma: no cover - Python 3.10
    import tomli as tomllib  # type: ignore[no-redef]

from compare.scenes import (
    BRANCHES,
    COMPONENTS,
    DIRECTIONS,
    LINKS,
    MASS_MODEL_NAMES,
    MECHANISMS,
    LinkageSpec,
    MassModelSpec,
    SceneSpec,
    SectionSpec,
    SpeedSpec,
    expand_grid,
)

DEFAULT_TOLERANCE = 0.10
SECTION_KEYS = ("youngs_modulus", "area", "second_moment", "density")

# Range rules for known exudyn_models.DynamicSettings fields: (kind, low, high, low_open).
# kind: "int", "float", "str:<a>|<b>", "bool".  Unknown-but-existing fields are type-checked
# against their default value only.
_DYNAMIC_RULES: dict[str, tuple[str, float | None, float | None, bool]] = {
    "element": ("str:ancf|gebeam", None, None, False),
    "elements_per_link": ("int", 1, 64, False),
    "steps_per_cycle": ("int", 8, 1_000_000, False),
    "spectral_radius": ("float", 0.0, 1.0, False),
    "damping_reference_hz": ("float", 0.0, 1e6, True),
    "steady_tol": ("float", 0.0, 1.0, True),
    "max_cycles": ("int", 1, 10_000, False),
    "min_cycles": ("int", 1, 10_000, False),
    "ramp_cycles": ("float", 0.0, 1000.0, True),
    "newton_abs_tol": ("float", 0.0, 1e6, True),
    "newton_rel_tol": ("float", 0.0, 1.0, True),
    "newton_max_iterations": ("int", 1, 1000, False),
    "sparse": ("bool", None, None, False),
}
# Fields assumed when exudyn_models is not importable (from the API contract).
_CONTRACT_DYNAMIC_FIELDS = (
    "element",
    "elements_per_link",
    "steps_per_cycle",
    "spectral_radius",
    "damping_ratio",
    "damping_reference_hz",
    "steady_tol",
    "max_cycles",
)


class ConfigError(ValueError):
    """Invalid campaign configuration; ``problems`` lists ``"toml.path: message"`` strings."""

    def __init__(self, problems: list[str], source: str = "campaign config"):
        self.problems = list(problems)
        lines = [f"{source}: {len(self.problems)} problem(s):"] + [f"  - {p}" for p in self.problems]
        super().__init__("\n".join(lines))


@dataclass(frozen=True)
class CampaignConfig:
    """A validated campaign.  ``text`` is the TOML source (stored in the results file)."""

    name: str
    tolerance: float
    outputs: tuple[str, ...]
    step_deg: float
    n_modes: int
    linkage: LinkageSpec
    mechanisms: tuple[str, ...]
    mass_models: tuple[MassModelSpec, ...]
    speeds: tuple[SpeedSpec, ...]
    stiffness_scales: tuple[float, ...]
    damping_ratios: tuple[float, ...]
    directions: tuple[str, ...]
    dynamic: tuple[tuple[str, Any], ...]
    text: str = ""
    dynamic_variants: tuple[tuple[tuple[str, Any], ...], ...] = ((),)

    def scenes(self) -> tuple[SceneSpec, ...]:
        """All scenes of the campaign grid (see :func:`compare.scenes.expand_grid`)."""
        return expand_grid(
            linkage=self.linkage,
            mechanisms=self.mechanisms,
            mass_models=self.mass_models,
            speeds=self.speeds,
            stiffness_scales=self.stiffness_scales,
            damping_ratios=self.damping_ratios,
            directions=self.directions,
            step_deg=self.step_deg,
            n_modes=self.n_modes,
            outputs=self.outputs,
            tolerance=self.tolerance,
            dynamic=self.dynamic,
            dynamic_variants=self.dynamic_variants,
        )


# --------------------------------------------------------------------------------------------------
# public entry points


def default_config_text() -> str:
    """TOML text of the embedded default campaign (``compare/default_campaign.toml``)."""
    return resources.files("compare").joinpath("default_campaign.toml").read_text(encoding="utf-8")


def load_config(path: str | Path | None = None) -> CampaignConfig:
    """Read and validate a campaign file; ``None`` gives the embedded default campaign."""
    if path is None:
        return parse_config(default_config_text(), source="<default campaign>")
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as exc:
        raise ConfigError([f"cannot read file: {exc}"], source=str(p)) from exc
    return parse_config(text, source=str(p))


def parse_config(text: str, source: str = "campaign config") -> CampaignConfig:
    """Parse and validate TOML ``text``; raise :class:`ConfigError` listing every problem."""
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError([f"TOML syntax error: {exc}"], source=source) from exc
    return validate(doc, text=text, source=source)


def validate(doc: dict[str, Any], text: str = "", source: str = "campaign config") -> CampaignConfig:
    """Validate a parsed TOML document (pure apart from importing the thesis preset)."""
    c = _Checker()
    c.keys(doc, "", ("campaign", "linkage", "grid", "dynamic"))

    camp = c.table(doc, "campaign")
    name = c.string(camp, "campaign.name", default="campaign")
    tolerance = c.number(camp, "campaign.tolerance", default=DEFAULT_TOLERANCE, lo=0.0, hi=10.0, lo_open=True)
    outputs = c.choices(camp, "campaign.outputs", COMPONENTS, default=COMPONENTS)
    outputs = tuple(x for x in COMPONENTS if x in outputs)  # canonical order: same scenes, same keys
    step_deg = c.number(camp, "campaign.step_deg", default=10.0, lo=0.0, hi=45.0, lo_open=True)
    if step_deg is not None and step_deg > 0:
        n = 360.0 / step_deg
        if abs(n - round(n)) > 1e-9:
            c.err("campaign.step_deg", f"must divide 360 degrees into whole steps (got {step_deg!r})")
    n_modes = c.integer(camp, "campaign.n_modes", default=3, lo=1, hi=20)
    c.keys(camp, "campaign", ("name", "tolerance", "outputs", "step_deg", "n_modes"))

    linkage = _linkage(c, c.table(doc, "linkage"))

    grid = c.table(doc, "grid")
    c.keys(
        grid,
        "grid",
        ("mechanisms", "mass_models", "rpm", "speed_ratios", "stiffness_scales", "damping_ratios",
         "directions", "dynamic_variants"),
    )
    mechanisms = c.choices(grid, "grid.mechanisms", MECHANISMS, default=("source",))
    mass_models = _mass_models(c, grid)
    rpms = c.numbers(grid, "grid.rpm", default=(), lo=0.0, hi=1e5, lo_open=True)
    ratios = c.numbers(grid, "grid.speed_ratios", default=(), lo=0.0, hi=10.0, lo_open=True)
    if "rpm" not in grid and "speed_ratios" not in grid:
        rpms = (_thesis_rpm(c),)
    elif not rpms and not ratios and not any(b.startswith(("grid.rpm", "grid.speed_ratios")) for b in c.bad):
        c.err("grid", "at least one crank speed is required in grid.rpm or grid.speed_ratios")
    speeds = tuple(SpeedSpec("rpm", v) for v in rpms) + tuple(SpeedSpec("ratio", v) for v in ratios)
    stiffness = c.numbers(grid, "grid.stiffness_scales", default=(1.0,), lo=0.0, hi=1e6, lo_open=True)
    damping = c.numbers(grid, "grid.damping_ratios", default=(0.02,), lo=0.0, hi=0.99)
    directions = c.choices(grid, "grid.directions", DIRECTIONS, default=("ccw",))

    dynamic_raw = c.table(doc, "dynamic")
    dynamic = _dynamic(c, dynamic_raw)
    variants = _dynamic_variants(c, grid, dynamic_raw)

    if c.problems:
        raise ConfigError(c.problems, source=source)
    assert linkage is not None
    return CampaignConfig(
        name=name,
        tolerance=tolerance,
        outputs=outputs,
        step_deg=step_deg,
        n_modes=n_modes,
        linkage=linkage,
        mechanisms=mechanisms,
        mass_models=mass_models,
        speeds=speeds,
        stiffness_scales=stiffness,
        damping_ratios=damping,
        directions=directions,
        dynamic=dynamic,
        text=text,
        dynamic_variants=variants,
    )


# --------------------------------------------------------------------------------------------------
# sections of the document


_LINKAGE_NUMBERS = ("crank", "coupler", "follower", "extender")


def _linkage(c: _Checker, tab: dict[str, Any]) -> LinkageSpec | None:
    allowed = ("preset", *_LINKAGE_NUMBERS, "coupler_angle_deg", "ground", "branch", "section", "sections")
    c.keys(tab, "linkage", allowed)
    geometric = (*_LINKAGE_NUMBERS, "coupler_angle_deg", "ground")
    base: dict[str, Any] = {}
    explicit = False
    if "preset" in tab:
        preset_name = c.string(tab, "linkage.preset", choices=("thesis",))
        if preset_name is None:
            return None
        base = _thesis_linkage(c)
    elif any(k in tab for k in geometric):
        explicit = True
    else:
        base = _thesis_linkage(c)  # no [linkage] dimensions -> thesis linkage
    vals: dict[str, Any] = {}
    for k in _LINKAGE_NUMBERS:
        vals[k] = c.number(tab, f"linkage.{k}", default=base.get(k), lo=0.0, hi=1e3, lo_open=True,
                           required=explicit)
    if "coupler_angle_deg" in tab:
        ang = c.number(tab, "linkage.coupler_angle_deg", lo=-360.0, hi=360.0)
        vals["coupler_angle"] = None if ang is None else math.radians(ang)
    elif explicit:
        c.err("linkage.coupler_angle_deg", "required when no preset is given")
        vals["coupler_angle"] = None
    else:
        vals["coupler_angle"] = base.get("coupler_angle")
    if "ground" in tab:
        ground = c.number(tab, "linkage.ground", lo=0.0, hi=1e3, lo_open=True)
        vals["crank_pivot"] = (0.0, 0.0)
        vals["follower_pivot"] = (ground, 0.0) if ground is not None else None
    elif explicit:
        c.err("linkage.ground", "required when no preset is given")
        vals["crank_pivot"] = vals["follower_pivot"] = None
    else:
        vals["crank_pivot"] = base.get("crank_pivot")
        vals["follower_pivot"] = base.get("follower_pivot")
    vals["branch"] = c.string(tab, "linkage.branch", default=base.get("branch", "open"), choices=BRANCHES)

    # sections: [linkage.section] applies to all links, [linkage.sections.<link>] overrides
    common = c.table(tab, "section", path="linkage.section")
    c.keys(common, "linkage.section", SECTION_KEYS)
    per = c.table(tab, "sections", path="linkage.sections")
    c.keys(per, "linkage.sections", LINKS)
    sections = []
    base_sections = base.get("sections")
    for i, link in enumerate(LINKS):
        own = c.table(per, link, path=f"linkage.sections.{link}")
        c.keys(own, f"linkage.sections.{link}", SECTION_KEYS)
        props = {}
        for key in SECTION_KEYS:
            default = base_sections[i][key] if base_sections else None
            if key in own:
                props[key] = c.number(own, f"linkage.sections.{link}.{key}", lo=0.0, hi=1e15, lo_open=True)
            elif key in common:
                props[key] = c.number(common, f"linkage.section.{key}", lo=0.0, hi=1e15, lo_open=True)
            elif default is not None:
                props[key] = default
            else:
                c.err(f"linkage.sections.{link}.{key}",
                      "missing (give it in [linkage.section] or [linkage.sections." + link + "])")
                props[key] = None
        sections.append(props)
    if any(v is None for v in vals.values()) or any(v is None for s in sections for v in s.values()):
        return None
    return LinkageSpec(
        crank=vals["crank"],
        coupler=vals["coupler"],
        follower=vals["follower"],
        extender=vals["extender"],
        coupler_angle=vals["coupler_angle"],
        crank_pivot=tuple(vals["crank_pivot"]),
        follower_pivot=tuple(vals["follower_pivot"]),
        branch=vals["branch"],
        sections=tuple(SectionSpec(**s) for s in sections),
    )


def _mass_models(c: _Checker, grid: dict[str, Any]) -> tuple[MassModelSpec, ...]:
    path = "grid.mass_models"
    raw = grid.get("mass_models", ["tip"])
    if not isinstance(raw, list) or not raw:
        c.err(path, f"must be a non-empty array of names or tables, got {_tname(raw)}")
        return ()
    out: list[MassModelSpec] = []
    for i, item in enumerate(raw):
        p = f"{path}[{i}]"
        if isinstance(item, str):
            item = {"name": item}
        if not isinstance(item, dict):
            c.err(p, f"must be a mass-model name or a table, got {_tname(item)}")
            continue
        c.keys(item, p, ("name", "lumps", "payload_kg", "joint_split", "placement"))
        name = c.string(item, f"{p}.name", required=True, choices=MASS_MODEL_NAMES)
        lumps = c.integer(item, f"{p}.lumps", default=5, lo=1, hi=100)
        default_payload = _thesis_tip_mass(c) if name == "tip" else 0.0
        payload = c.number(item, f"{p}.payload_kg", default=default_payload, lo=0.0, hi=1e4)
        if name == "tip" and payload is not None and payload <= 0.0:
            c.err(f"{p}.payload_kg", "the 'tip' mass model needs a payload > 0 kg")
        split = c.number(item, f"{p}.joint_split", default=0.5, lo=0.0, hi=1.0)
        placement = c.string(item, f"{p}.placement", default="midpoint", choices=("midpoint", "end"))
        if None not in (name, lumps, payload, split, placement):
            out.append(MassModelSpec(name, lumps, payload, split, placement))
    if len(set(out)) != len(out):
        c.err(path, "duplicate mass models")
    return tuple(out)


def _dynamic(c: _Checker, tab: dict[str, Any], prefix: str = "dynamic",
             check_settings: bool = True) -> tuple[tuple[str, Any], ...]:
    fields = _dynamic_fields()
    out: dict[str, Any] = {}
    for key in tab:
        p = f"{prefix}.{key}"
        if key == "damping_ratio":
            c.err(p, "set damping in grid.damping_ratios (a grid axis), not in [dynamic]")
            continue
        if key not in fields:
            c.err(p, f"unknown key (allowed: {', '.join(sorted(k for k in fields if k != 'damping_ratio'))})")
            continue
        rule = _DYNAMIC_RULES.get(key)
        if rule is not None:
            kind, lo, hi, lo_open = rule
            if kind == "int":
                v = c.integer(tab, p, lo=int(lo), hi=int(hi))
            elif kind == "float":
                v = c.number(tab, p, lo=lo, hi=hi, lo_open=lo_open)
            elif kind.startswith("str:"):
                v = c.string(tab, p, choices=tuple(kind[4:].split("|")))
            else:
                v = c.boolean(tab, p)
        else:
            v = c.like(tab, p, fields[key])
        if v is not None:
            out[key] = v
    if check_settings and not any(p.startswith(f"{prefix}.") for p in c.bad):
        try:
            from compare.execute import dynamic_api

            DynamicSettings, _ = dynamic_api()
        except ImportError:
            pass
        else:
            try:
                DynamicSettings(**out)
            except (TypeError, ValueError) as exc:
                c.err(prefix, str(exc))
    return tuple(sorted(out.items()))


def _dynamic_variants(c: _Checker, grid: dict[str, Any],
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
        c.err(path, f"must be a non-empty array of tables, got {_tname(raw)}")
        return ((),)
    out: list[tuple[tuple[str, Any], ...]] = []
    for i, item in enumerate(raw):
        p = f"{path}[{i}]"
        if not isinstance(item, dict) or not item:
            c.err(p, f"must be a non-empty table of [dynamic] settings, got {_tname(item)}")
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


# --------------------------------------------------------------------------------------------------
# foundation look-ups (lazy so that importing this module stays cheap)


def _thesis_linkage(c: _Checker) -> dict[str, Any]:
    try:
        from ked_quasi.linkage import LINKS as QL
        from ked_quasi.linkage import thesis_fourbar
    except ImportError as exc:  # pragma: no cover - foundation missing
        c.err("linkage.preset", f"thesis preset unavailable: {exc}")
        return {}
    fb = thesis_fourbar()
    secs = {name: fb.section(name) for name in QL}
    return {
        "crank": float(fb.crank),
        "coupler": float(fb.coupler),
        "follower": float(fb.follower),
        "extender": float(fb.extender),
        "coupler_angle": float(fb.coupler_angle),
        "crank_pivot": (float(fb.crank_pivot[0]), float(fb.crank_pivot[1])),
        "follower_pivot": (float(fb.follower_pivot[0]), float(fb.follower_pivot[1])),
        "branch": str(fb.branch),
        "sections": [
            {k: float(getattr(secs[link], k)) for k in SECTION_KEYS} for link in LINKS
        ],
    }


def _thesis_rpm(c: _Checker) -> float:
    try:
        from ked_quasi.linkage import THESIS_RPM
    except ImportError:  # pragma: no cover
        return 300.0
    return float(THESIS_RPM)


def _thesis_tip_mass(c: _Checker) -> float:
    try:
        from ked_quasi.linkage import THESIS_TIP_MASS_KG
    except ImportError:  # pragma: no cover
        return 0.90718474
    return float(THESIS_TIP_MASS_KG)


def _dynamic_fields() -> dict[str, Any]:
    """Field name -> default value of ``exudyn_models.DynamicSettings`` (contract names if absent)."""
    try:
        from compare.execute import dynamic_api

        DynamicSettings, _ = dynamic_api()
    except ImportError:
        return {name: None for name in _CONTRACT_DYNAMIC_FIELDS}
    out: dict[str, Any] = {}
    for f in dataclasses.fields(DynamicSettings):
        if f.default is not dataclasses.MISSING:
            out[f.name] = f.default
        elif f.default_factory is not dataclasses.MISSING:  # type: ignore[misc]
            out[f.name] = f.default_factory()  # type: ignore[misc]
        else:
            out[f.name] = None
    return out


# --------------------------------------------------------------------------------------------------
# checker


def _tname(v: Any) -> str:
    return {bool: "boolean", int: "integer", float: "float", str: "string", list: "array",
            dict: "table"}.get(type(v), type(v).__name__)


class _Checker:
    """Collects problems; every accessor returns ``None`` (or a default) on error."""

    def __init__(self) -> None:
        self.problems: list[str] = []
        self.bad: set[str] = set()

    def err(self, path: str, msg: str) -> None:
        self.problems.append(f"{path}: {msg}")
        self.bad.add(path)

    def keys(self, tab: dict[str, Any], path: str, allowed: tuple[str, ...]) -> None:
        for k in tab:
            if k not in allowed:
                p = f"{path}.{k}" if path else k
                self.err(p, f"unknown key (allowed: {', '.join(allowed)})")

    def table(self, tab: dict[str, Any], key: str, path: str | None = None) -> dict[str, Any]:
        v = tab.get(key, {})
        if not isinstance(v, dict):
            self.err(path or key, f"must be a table, got {_tname(v)}")
            return {}
        return v

    def _get(self, tab: dict[str, Any], path: str, required: bool) -> tuple[bool, Any]:
        key = path.rsplit(".", 1)[-1]
        if key not in tab:
            if required:
                self.err(path, "required")
            return False, None
        return True, tab[key]

    def number(self, tab, path, *, default=None, lo=None, hi=None, lo_open=False, required=False):
        present, v = self._get(tab, path, required)
        if not present:
            return default
        return self._check_number(v, path, lo, hi, lo_open)

    def _check_number(self, v, path, lo, hi, lo_open):
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            self.err(path, f"must be a number, got {_tname(v)} {v!r}")
            return None
        v = float(v)
        if not math.isfinite(v):
            self.err(path, f"must be finite, got {v!r}")
            return None
        if lo is not None and (v < lo or (lo_open and v == lo)):
            self.err(path, f"must be {'>' if lo_open else '>='} {lo:g}, got {v:g}")
            return None
        if hi is not None and v > hi:
            self.err(path, f"must be <= {hi:g}, got {v:g}")
            return None
        return v

    def integer(self, tab, path, *, default=None, lo=None, hi=None, required=False):
        present, v = self._get(tab, path, required)
        if not present:
            return default
        if isinstance(v, bool) or not isinstance(v, int):
            self.err(path, f"must be an integer, got {_tname(v)} {v!r}")
            return None
        if (lo is not None and v < lo) or (hi is not None and v > hi):
            self.err(path, f"must be in [{lo}, {hi}], got {v}")
            return None
        return v

    def boolean(self, tab, path, *, default=None):
        present, v = self._get(tab, path, False)
        if not present:
            return default
        if not isinstance(v, bool):
            self.err(path, f"must be a boolean, got {_tname(v)} {v!r}")
            return None
        return v

    def string(self, tab, path, *, default=None, choices=None, required=False):
        present, v = self._get(tab, path, required)
        if not present:
            return default
        if not isinstance(v, str):
            self.err(path, f"must be a string, got {_tname(v)} {v!r}")
            return None
        if choices is not None and v not in choices:
            self.err(path, f"must be one of {', '.join(repr(x) for x in choices)}, got {v!r}")
            return None
        return v

    def like(self, tab, path, default):
        """Type-check against the type of a default value (unknown-range settings)."""
        if isinstance(default, bool):
            return self.boolean(tab, path)
        if isinstance(default, int):
            return self.integer(tab, path)
        if isinstance(default, float):
            return self.number(tab, path)
        if isinstance(default, str):
            return self.string(tab, path)
        present, v = self._get(tab, path, False)
        if isinstance(v, (dict, list)):
            self.err(path, f"must be a scalar, got {_tname(v)}")
            return None
        return v

    def _array(self, tab, path, default):
        present, v = self._get(tab, path, False)
        if not present:
            return None, default
        if not isinstance(v, list):
            self.err(path, f"must be an array, got {_tname(v)} {v!r}")
            return None, ()
        if not v:
            self.err(path, "must not be empty")
            return None, ()
        return v, None

    def numbers(self, tab, path, *, default=(), lo=None, hi=None, lo_open=False):
        v, dflt = self._array(tab, path, default)
        if v is None:
            return tuple(dflt)
        out = []
        for i, x in enumerate(v):
            y = self._check_number(x, f"{path}[{i}]", lo, hi, lo_open)
            if y is not None:
                out.append(y)
        if len(set(out)) != len(out):
            self.err(path, f"duplicate values in {v!r}")
        return tuple(out)

    def choices(self, tab, path, allowed, *, default=()):
        v, dflt = self._array(tab, path, default)
        if v is None:
            return tuple(dflt)
        out = []
        for i, x in enumerate(v):
            if not isinstance(x, str) or x not in allowed:
                self.err(f"{path}[{i}]", f"must be one of {', '.join(repr(a) for a in allowed)}, got {x!r}")
            else:
                out.append(x)
        if len(set(out)) != len(out):
            self.err(path, f"duplicate values in {v!r}")
        return tuple(out)
