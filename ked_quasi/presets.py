"""Named linkages and the default scene construction used by the command line and campaigns."""

from __future__ import annotations

from .cognates import mechanism
from .linkage import THESIS_TIP_MASS_KG, FourBar, thesis_fourbar
from .massmodel import MassModel
from .scene import Scene

LINKAGES = {"thesis": thesis_fourbar}


def linkage(name: str) -> FourBar:
    """A named linkage preset (SI)."""
    if name not in LINKAGES:
        raise ValueError(f"linkage must be one of {', '.join(LINKAGES)}; got {name!r}")
    return LINKAGES[name]()


def default_payload(linkage_name: str, mass_model: str) -> float:
    """Payload at P [kg] a preset uses by default: the thesis's 2 lb in Case I (tip), none otherwise."""
    return THESIS_TIP_MASS_KG if (linkage_name == "thesis" and mass_model == "tip") else 0.0


def make_scene(
    linkage_name: str = "thesis",
    mechanism_name: str = "source",
    mass_model: str = "tip",
    rpm: float = 300.0,
    step_deg: float = 10.0,
    lumps: int = 5,
    payload: float | None = None,
    stiffness_scale: float = 1.0,
    direction: str | None = None,
) -> Scene:
    """Scene from plain parameters (what the CLI and campaign configs speak)."""
    fb = mechanism(linkage(linkage_name), mechanism_name)
    if stiffness_scale != 1.0:
        fb = fb.with_stiffness_scale(stiffness_scale)
    if direction is not None:
        fb = fb.with_direction(direction)
    pay = default_payload(linkage_name, mass_model) if payload is None else payload
    return Scene(fb, MassModel(mass_model, lumps=lumps, payload=pay), rpm, step_deg)
