"""A scene: one four-bar, one mass model, one constant crank speed, one crank-angle grid."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .linkage import FourBar
from .massmodel import MassModel


@dataclass(frozen=True)
class Scene:
    """What both solvers are asked to analyse.

    fourbar: the mechanism (already the source or the cognate); mass_model: where its mass is;
    rpm: crank speed magnitude [rev/min] (direction from ``fourbar.direction``); step_deg: crank-angle
    grid step [deg], dividing 360.
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
        rpm = float(self.rpm)
        if not math.isfinite(rpm) or rpm <= 0:
            raise ValueError(f"Scene.rpm must be a positive finite crank speed in rev/min, got {self.rpm!r}")
        step = float(self.step_deg)
        if not math.isfinite(step) or step <= 0 or step > 360:
            raise ValueError(f"Scene.step_deg must be in (0, 360] deg, got {self.step_deg!r}")
        n = 360.0 / step
        if abs(n - round(n)) > 1e-9 * n:
            raise ValueError(f"Scene.step_deg must divide 360 deg exactly, got {self.step_deg!r}")
        object.__setattr__(self, "rpm", rpm)
        object.__setattr__(self, "step_deg", step)

    @property
    def crank_angles(self) -> np.ndarray:
        """Uniform grid over one turn, 0 <= theta < 2 pi [rad]."""
        n = round(360.0 / self.step_deg)
        return np.arange(n) * (2.0 * np.pi / n)

    @property
    def omega(self) -> float:
        """Crank speed magnitude [rad/s]."""
        return self.rpm * 2.0 * np.pi / 60.0
