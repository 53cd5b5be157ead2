"""The linkage kinds an atlas can hold: the one seam where the atlas's machinery (families, threshold,
confirmation, calibration) learns which generator drew its linkages.

An atlas file holds one kind; its stored generator ranges name it (``ranges["kind"]``; a file without it
is a four-bar atlas, as every atlas before the slider-crank's).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ked_quasi.cognates import MECHANISMS
from ked_quasi.massmodel import MASS_MODELS
from ked_quasi.slidercrank import KIND as SLIDER_KIND
from ked_quasi.slidercrank import SLIDER_MASS_MODELS
from ked_research.atlas import generate as four_bar_generate
from ked_research.atlas import slider_generate


@dataclass(frozen=True)
class AtlasKind:
    """A linkage kind of the atlas: its name (the stratum's first part), its seeded generator
    (``generate(n, seed)``, ``candidate(seed, index)``), its ranges as stored, and the mass models and
    mechanisms of its families, in the atlas's order."""

    name: str
    generate: Callable[[int, int], four_bar_generate.Sample]
    candidate: Callable[[int, int], Any]
    ranges: Callable[[], dict[str, Any]]
    mass_models: tuple[str, ...]
    mechanisms: tuple[str, ...]


FOUR_BAR = AtlasKind("four-bar", four_bar_generate.generate, four_bar_generate.candidate,
                     four_bar_generate.ranges_dict, MASS_MODELS, MECHANISMS)
SLIDER = AtlasKind(SLIDER_KIND, slider_generate.generate, slider_generate.candidate, slider_generate.ranges_dict,
                   SLIDER_MASS_MODELS, slider_generate.MECHANISMS)
KINDS = {k.name: k for k in (FOUR_BAR, SLIDER)}


def kind_named(name: str) -> AtlasKind:
    """The kind called ``name`` (ValueError naming the choices otherwise)."""
    if name not in KINDS:
        raise ValueError(f"linkage kind: one of {', '.join(KINDS)}; got {name!r}")
    return KINDS[name]


def kind_of(path: Path) -> AtlasKind:
    """The kind of the atlas file at ``path`` (four-bar for a missing file or ranges without a kind)."""
    from ked_research.atlas import store

    if not Path(path).exists():
        return FOUR_BAR
    ranges = store.attrs(Path(path)).get("ranges")
    return kind_named(ranges.get("kind", FOUR_BAR.name)) if isinstance(ranges, dict) else FOUR_BAR
