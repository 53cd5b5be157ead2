"""Named linkages, and scenes built from a linkage's name (:func:`ked_quasi.scene.build_scene`)."""

from __future__ import annotations

from .linkage import FourBar, thesis_fourbar
from .scene import Scene, build_scene
from .slidercrank import SliderCrank, simeon_slider_crank

LINKAGES = {"thesis": thesis_fourbar}

SLIDER_LINKAGES = {"simeon": simeon_slider_crank}
"""Named slider-crank linkages (``--linkage simeon``: the flexible slider-crank of Simeon's benchmark)."""


def slider_linkage(name: str) -> SliderCrank | None:
    """A named slider-crank preset (SI), or None when ``name`` names none."""
    return SLIDER_LINKAGES[name]() if name in SLIDER_LINKAGES else None


def linkage(name: str) -> FourBar:
    """A named linkage preset (SI)."""
    if name not in LINKAGES:
        raise ValueError(f"linkage must be one of {', '.join(LINKAGES)}; got {name!r}")
    return LINKAGES[name]()


def make_scene(linkage_name: str = "thesis", mechanism_name: str = "source", mass_model: str = "tip",
               rpm: float = 300.0, step_deg: float = 10.0, lumps: int = 5, payload: float | None = None,
               stiffness_scale: float = 1.0, direction: str | None = None) -> Scene:
    """:func:`~ked_quasi.scene.build_scene` of a named linkage."""
    return build_scene(linkage(linkage_name), mechanism_name, mass_model, rpm, step_deg, lumps, payload,
                       stiffness_scale, direction)
