"""A scene: one four-bar, one mass model, one constant crank speed, one crank-angle grid."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from . import rules, units
from .cognates import mechanism as cognate_mechanism
from .linkage import KIND as FOUR_BAR_KIND
from .linkage import FourBar
from .massmodel import MassModel, lumps


class CrankGrid:
    """The crank-angle grid and speed of a scene with ``step_deg`` [deg] and ``rpm`` [rev/min] fields
    (the four-bar's :class:`Scene` and the slider-crank's ``SliderScene``)."""

    step_deg: float
    rpm: float

    @property
    def n_angles(self) -> int:
        """Number of crank angles of the grid."""
        return rules.steps_per_turn(self.step_deg)

    @property
    def crank_angles(self) -> np.ndarray:
        """Uniform grid over one turn, 0 <= theta < 2 pi [rad]."""
        n = self.n_angles
        return np.arange(n) * (2.0 * np.pi / n)

    @property
    def crank_angles_deg(self) -> np.ndarray:
        """The grid in degrees, exact multiples of ``step_deg`` (0 <= theta < 360)."""
        return np.arange(self.n_angles) * (360.0 / self.n_angles)

    @property
    def omega(self) -> float:
        """Crank speed magnitude [rad/s]."""
        return units.rpm_to_rad_s(self.rpm)


KIND = FOUR_BAR_KIND
"""The linkage kind of a :class:`Scene` (the slider-crank's: :data:`ked_quasi.slidercrank.KIND`)."""


@dataclass(frozen=True)
class Scene(CrankGrid):
    """What every solver is asked to analyse.

    fourbar: the mechanism (already the source or the cognate); mass_model: where its mass is;
    rpm: crank speed magnitude [rev/min] (direction from ``fourbar.direction``); step_deg: crank-angle
    grid step [deg], dividing 360.  Ranges: :mod:`ked_quasi.rules`.
    """

    fourbar: FourBar
    mass_model: MassModel
    rpm: float
    step_deg: float = 10.0

    def __post_init__(self) -> None:
        if not isinstance(self.fourbar, FourBar):
            raise ValueError("Scene.fourbar must be a FourBar")
        if not self.fourbar.full_turn:
            raise ValueError("Scene.fourbar must be crank-drivable over a full turn (full_turn=True)")
        if not isinstance(self.mass_model, MassModel):
            raise ValueError("Scene.mass_model must be a MassModel")
        object.__setattr__(self, "rpm", rules.RPM.check(self.rpm, "Scene.rpm"))
        object.__setattr__(self, "step_deg", rules.check_step_deg(self.step_deg, "Scene.step_deg"))
        n_nodes = len(lumps(self.fourbar, self.mass_model).link) + 5  # lumps + joints M, A, B, Q, P
        rules.check_work(self.n_angles, 2 * n_nodes, "Scene.step_deg and MassModel.lumps")

    @property
    def kind(self) -> str:
        """The linkage kind, :data:`KIND` (every scene type has one)."""
        return KIND

    @property
    def linkage(self) -> FourBar:
        """The scene's linkage (every scene type has one): its four-bar."""
        return self.fourbar

    def to_dict(self) -> dict[str, Any]:
        """Plain dict (JSON, HDF5 attributes); :meth:`from_dict` inverts it."""
        return {"fourbar": self.fourbar.to_dict(), "mass_model": self.mass_model.to_dict(),
                "rpm": self.rpm, "step_deg": self.step_deg}

    @staticmethod
    def from_dict(d: dict[str, Any]) -> Scene:
        return Scene(FourBar.from_dict(d["fourbar"]), MassModel.from_dict(d["mass_model"]), d["rpm"], d["step_deg"])


def variant(source: FourBar, mechanism: str = "source", stiffness_scale: float = 1.0,
            direction: str | None = None) -> FourBar:
    """The four-bar a scene analyses: ``source`` or its crank-driven Roberts ``cognate``, every Young's
    modulus times ``stiffness_scale``, crank turning in ``direction`` (None: the source's)."""
    fb = cognate_mechanism(source, mechanism)
    if stiffness_scale != 1.0:
        fb = fb.with_stiffness_scale(stiffness_scale)
    return fb.with_direction(direction) if direction is not None else fb


def build_scene(source: FourBar, mechanism: str = "source", mass_model: str = "tip", rpm: float = 300.0,
                step_deg: float = 10.0, lumps: int = 5, payload: float | None = None, stiffness_scale: float = 1.0,
                direction: str | None = None) -> Scene:
    """A scene from plain parameters, the way campaigns and the command line build it: the
    :func:`variant` of ``source``, the named mass model (payload [kg] default:
    :func:`~ked_quasi.massmodel.default_payload`), ``rpm`` [rev/min], ``step_deg`` [deg]."""
    from .massmodel import default_payload

    mm = MassModel(mass_model, lumps=lumps, payload=default_payload(mass_model) if payload is None else payload)
    return Scene(variant(source, mechanism, stiffness_scale, direction), mm, rpm, step_deg)
