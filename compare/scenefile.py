"""A user's linkage file read for a single-scene command (``ked quasi``, ``linear``, ``simulate``, ``check`` with
``--linkage FILE``): the whole file by the campaign's rules, and the scenes it describes.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

try:  # Python >= 3.11
    import tomllib
except ModuleNotFoundError:  # pragma: no cover - Python 3.10
    import tomli as tomllib  # type: ignore[no-redef]

from compare.config import CampaignConfig, validate
from compare.linkagefile import single_linkage
from compare.scenes import SLIDER_KIND, SceneSpec, SpeedSpec
from compare.tomlcheck import ConfigError, read_text
from ked_quasi.massmodel import MassModel


def load_scene_file(path: str | Path) -> CampaignConfig:
    """A user's linkage file read for a single-scene command (``ked quasi``, ``linear``, ``simulate``, ``check``
    with ``--linkage FILE``): the whole file by the campaign's rules, as ``ked run`` reads it (every table and
    key checked, its ``[grid]``, ``[campaign]``, ``[dynamic]`` and solver tables kept), except that the grid's
    crank speeds are not checked against the speed-ratio bound (the command checks the speed it runs).  A
    slider-crank file without ``grid.mass_models`` gets ``distributed``, the commands' default for it.
    :class:`ConfigError` naming the file and every problem otherwise."""
    p = Path(path)
    text = read_text(p)
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError([f"TOML syntax error: {exc}"], source=str(p)) from None
    single_linkage(doc, p)
    tab, grid = doc.get("linkage"), doc.get("grid", {})
    if (isinstance(tab, dict) and (tab.get("kind") == SLIDER_KIND or tab.get("preset") == "simeon")
            and isinstance(grid, dict) and "mass_models" not in grid):
        doc = {**doc, "grid": {**grid, "mass_models": ["distributed"]}}
    return validate(doc, text=text, source=str(p), check_speeds=False)


SCENE_AXES = {"mechanisms": "--mechanism", "mass_models": "--mass-model", "stiffness_scales": "--stiffness-scale",
              "damping_ratios": "--damping-ratio", "directions": "--direction", "dynamic_variants": ""}
"""The grid axes that describe one scene of a file, and the option choosing each on the command line."""


def file_scenes(config: CampaignConfig, given: dict[str, Any], rpms: Sequence[float] | None = None,
                **settings: Any) -> tuple[SceneSpec, ...]:
    """The scenes a single-scene command runs on a user's file: the file's grid, as ``ked run`` expands it,
    with each axis of :data:`SCENE_AXES` the command line gives (``given``: axis -> the one value) in place of
    the file's, at the crank speeds ``rpms`` [rev/min] (None: the file's ``grid.rpm``).  ``settings``: fields
    of the grid the command line gives explicitly (e.g. ``tolerance``, ``step_deg``).  An axis of several
    values that the command line does not choose: ValueError naming the axis, its values and the option."""
    g = config.grid
    fields: dict[str, Any] = {}
    for axis, option in SCENE_AXES.items():
        values = (given[axis],) if axis in given else getattr(g, axis)
        if len(values) > 1:
            shown = ", ".join(_axis_text(v) for v in values)
            how = f"choose one with {option}" if option else "a single-scene command runs one: keep one"
            raise ValueError(f"grid.{axis}: the file holds {len(values)} values ({shown}); {how}")
        fields[axis] = tuple(values)
    if rpms is None:
        if any(s.kind != "rpm" for s in g.speeds):
            raise ValueError("grid.speed_ratios: a single-scene command runs at a crank speed in rpm; give --rpm")
        speeds = g.speeds
    else:
        speeds = tuple(SpeedSpec("rpm", float(r)) for r in rpms)
    return replace(g, speeds=speeds, **fields, **settings).expand()


def _axis_text(v: Any) -> str:
    if isinstance(v, MassModel):
        return v.name
    if isinstance(v, tuple):
        return "{" + ", ".join(f"{k} = {x!r}" for k, x in v) + "}"
    return f"{v:g}" if isinstance(v, float) else str(v)
