"""The ``[linkage]`` table of a campaign or linkage file -> the source linkage (a four-bar or a slider-crank), one
reader for every command; problems named by their TOML path (``linkage.<key>``, ``linkage[i].<key>``).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from compare.scenes import FOUR_BAR, SLIDER_KIND
from compare.tomlcheck import Checker, ConfigError, type_name
from ked_quasi import rules
from ked_quasi.linkage import BRANCHES, LINKS, SECTION_RULES, FourBar, thesis_fourbar
from ked_quasi.slidercrank import PRESET_KINDS, SliderCrank, kind_conflict, simeon_slider_crank, slider_from_table

SECTION_KEYS = tuple(SECTION_RULES)
LINKAGE_NUMBERS = ("crank", "coupler", "follower", "extender")


def linkage_path(i: int, n: int) -> str:
    """How messages name a campaign's i-th linkage: ``linkage`` (a single table) or ``linkage[i]``."""
    return "linkage" if n == 1 else f"linkage[{i}]"


def source_linkages(c: Checker, raw: Any) -> tuple[FourBar | SliderCrank, ...]:
    """The campaign's source linkages: one ``[linkage]`` table, or an array of them (``[[linkage]]`` tables,
    or ``linkage = ["thesis", "simeon", {...}]`` where a string is a preset name), each read by
    :func:`linkage_from_table`; problems are named ``linkage[i].<key>``.  Two equal linkages are refused."""
    if isinstance(raw, dict):
        lk = linkage_from_table(c, raw)
        return () if lk is None else (lk,)
    if not isinstance(raw, list) or not raw:
        c.err("linkage", f"must be a table ([linkage]) or a non-empty array of tables ([[linkage]]) or preset "
                         f"names, got {type_name(raw)}")
        return ()
    out: list[FourBar | SliderCrank] = []
    for i, item in enumerate(raw):
        path = linkage_path(i, len(raw))
        if isinstance(item, str):
            item = {"preset": item}
        if not isinstance(item, dict):
            c.err(path, f"must be a linkage table or a preset name ('thesis', 'simeon'), got {type_name(item)}")
            continue
        sub = Checker()
        lk = linkage_from_table(sub, item)
        if sub.problems or lk is None:  # the same messages, named by the array element
            c.problems += [path + p[len("linkage"):] if p.startswith("linkage") else f"{path}: {p}"
                           for p in sub.problems or ["cannot be read"]]
            c.bad.add(path)
            continue
        if lk in out:
            c.err(path, f"the same linkage as {linkage_path(out.index(lk), len(raw))} (each linkage once)")
            continue
        out.append(lk)
    return tuple(out)


def linkage_from_table(c: Checker, tab: dict[str, Any]) -> FourBar | SliderCrank | None:
    """A ``[linkage]`` table (campaign schema) -> the source :class:`FourBar` (None after a problem); with
    ``kind = "slider-crank"`` (or ``preset = "simeon"``) the :class:`~ked_quasi.slidercrank.SliderCrank`
    (keys: :func:`ked_quasi.slidercrank.slider_from_table`)."""
    kind = c.string(tab, "linkage.kind", default=FOUR_BAR, choices=tuple(_READERS))
    if kind is None:
        return None
    if kind_conflict(tab):
        c.err("linkage", kind_conflict(tab).removeprefix("linkage."))
        return None
    preset = tab.get("preset")
    kind = PRESET_KINDS.get(preset, kind) if isinstance(preset, str) else kind  # a preset names its kind
    return _READERS[kind](c, tab)


def _slider_from_table(c: Checker, tab: dict[str, Any]) -> SliderCrank | None:
    """A slider-crank's ``[linkage]`` table (or ``preset = "simeon"``)."""
    if tab.get("preset") == "simeon":
        c.keys(tab, "linkage", ("preset", "kind"))
        return None if c.problems else simeon_slider_crank()
    try:
        return slider_from_table(tab)
    except ValueError as exc:
        msg = str(exc)
        c.problems.append(msg if msg.startswith("linkage") else f"linkage: {msg}")
        c.bad.add("linkage")
        return None


def _four_bar_from_table(c: Checker, tab: dict[str, Any]) -> FourBar | None:
    """A four-bar's ``[linkage]`` table (or ``preset = "thesis"``)."""
    tab = {k: v for k, v in tab.items() if k != "kind"}
    c.keys(tab, "linkage", ("preset", *LINKAGE_NUMBERS, "coupler_angle_deg", "ground", "branch", "section",
                            "sections", "kind"))
    explicit = "preset" not in tab and any(k in tab for k in (*LINKAGE_NUMBERS, "coupler_angle_deg", "ground"))
    if "preset" in tab and c.string(tab, "linkage.preset", choices=("thesis", "simeon")) is None:
        return None
    base = None if explicit else thesis_fourbar().to_dict()
    vals: dict[str, Any] = {}
    for k in LINKAGE_NUMBERS:
        vals[k] = c.rule(tab, f"linkage.{k}", rules.LENGTH, default=base and base[k], required=explicit)
    ang = c.rule(tab, "linkage.coupler_angle_deg", rules.COUPLER_ANGLE_DEG, required=explicit)
    vals["coupler_angle"] = math.radians(ang) if ang is not None else base and base["coupler_angle"]
    ground = c.rule(tab, "linkage.ground", rules.LENGTH, required=explicit)
    vals["crank_pivot"] = [0.0, 0.0] if ground is not None else base and base["crank_pivot"]
    vals["follower_pivot"] = [ground, 0.0] if ground is not None else base and base["follower_pivot"]
    vals["branch"] = c.string(tab, "linkage.branch", default=base["branch"] if base else "open", choices=BRANCHES)
    vals["sections"] = _sections(c, tab, base["sections"] if base else None)
    if c.problems or any(v is None for v in vals.values()):
        return None
    try:
        return FourBar.from_dict(vals)
    except ValueError as exc:
        c.err("linkage", str(exc))
        return None


_READERS = {FOUR_BAR: _four_bar_from_table, SLIDER_KIND: _slider_from_table}
"""Linkage kind -> the reader of its ``[linkage]`` table (a new kind adds its entry)."""


def _sections(c: Checker, tab: dict[str, Any], base: list[dict[str, float]] | None) -> list[dict[str, float]] | None:
    """``[linkage.section]`` applies to all links, ``[linkage.sections.<link>]`` overrides."""
    common = c.table(tab, "section", path="linkage.section")
    c.keys(common, "linkage.section", SECTION_KEYS)
    per = c.table(tab, "sections", path="linkage.sections")
    c.keys(per, "linkage.sections", LINKS)
    out = []
    for i, link in enumerate(LINKS):
        own = c.table(per, link, path=f"linkage.sections.{link}")
        c.keys(own, f"linkage.sections.{link}", SECTION_KEYS)
        props = {}
        for key, rule in rules.USER_SECTION_RULES.items():  # the plausibility bounds of a user's material
            if key in own:
                props[key] = c.rule(own, f"linkage.sections.{link}.{key}", rule)
            elif key in common:
                props[key] = c.rule(common, f"linkage.section.{key}", rule)
            elif base is not None:
                props[key] = base[i][key]
            else:
                c.err(f"linkage.sections.{link}.{key}",
                      "missing (give it in [linkage.section] or [linkage.sections." + link + "])")
                props[key] = None
        out.append(props)
    return None if any(v is None for p in out for v in p.values()) else out


def single_linkage(doc: dict[str, Any], p: Path) -> None:
    """ConfigError unless ``doc`` holds exactly one ``[linkage]`` table (naming the tables found)."""
    if isinstance(doc.get("linkage"), list):
        raise ConfigError(["holds several linkages ([[linkage]] or an array); a linkage file holds one [linkage] "
                           "table (several linkages belong in a campaign config)"], source=str(p))
    if not isinstance(doc.get("linkage"), dict):
        tables = [f"[{k}]" for k, v in doc.items() if isinstance(v, dict)]
        loose = [k for k, v in doc.items() if not isinstance(v, dict)]
        found = (f"tables found: {', '.join(tables)}" if tables else "no tables found") + (
            f"; keys outside any table: {', '.join(loose)}" if loose else "")
        raise ConfigError([f"no [linkage] table ({found}); a linkage file needs a [linkage] table (lower case) with "
                           "crank, coupler, follower, extender, ground [m], coupler_angle_deg and [linkage.section], "
                           "or preset = \"thesis\""], source=str(p))
