"""In-memory data model of one scene's outcome (independent of any file format).

:mod:`compare.store` maps it to and from HDF5; :mod:`compare.execute` produces it.  Arrays are over
the scene's crank-angle grid (n samples, one cycle).  Units: crank angle rad, deflections dx, dy m,
rotation rad, natural frequencies Hz, coupler point m, wall times s.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from compare.metrics import SceneMetrics
from compare.scenes import SceneSpec

STATUS_OK = "ok"
STATUS_FAILED = "failed"
STATUSES = (STATUS_OK, STATUS_FAILED)
# Stage at which a failed scene stopped.
STAGES = ("setup", "frequencies", "quasi_static", "dynamic", "metrics")


@dataclass(frozen=True)
class RunStats:
    """Cost of one scene.  Wall times [s]; ``steps`` time steps, ``newton_iterations`` total Newton
    iterations and ``cycles`` crank cycles simulated by the dynamic solver (-1 if it did not run);
    ``worker`` = "host:pid" that computed the scene, ``finished_utc`` ISO-8601 time."""

    frequencies_wall_s: float = 0.0
    quasi_static_wall_s: float = 0.0
    dynamic_wall_s: float = 0.0
    total_wall_s: float = 0.0
    steps: int = -1
    newton_iterations: int = -1
    cycles: int = -1
    converged: bool = False
    dynamic_message: str = ""
    worker: str = ""
    finished_utc: str = ""


@dataclass(frozen=True, eq=False)
class SceneResult:
    """Outcome of one scene (status ``"ok"`` or ``"failed"``; a failed scene keeps whatever was
    computed before the failing ``stage`` and the exception's type name and message).

    - ``rpm`` [rev/min] resolved crank speed (nan if it could not be resolved)
    - ``omega1_min`` [rad/s] lowest first natural circular frequency over the cycle (nan if unknown)
    - ``crank_angle`` (n,) [rad]; ``coupler_point`` (n, 2) rigid P [m]
    - ``natural_frequencies`` (n, n_modes) [Hz] of the frozen structure
    - ``quasi_static`` / ``dynamic``: component name -> (n,) history (only requested outputs)
    - ``dynamic_settings``: fully resolved ``exudyn_models.DynamicSettings`` fields
    - ``warnings``: solver warnings (e.g. near-toggle crank angles), "; "-joined
    """

    spec: SceneSpec
    status: str
    stage: str = ""
    error_type: str = ""
    message: str = ""
    rpm: float = float("nan")
    omega1_min: float = float("nan")
    crank_angle: np.ndarray | None = None
    coupler_point: np.ndarray | None = None
    natural_frequencies: np.ndarray | None = None
    quasi_static: dict[str, np.ndarray] = field(default_factory=dict)
    dynamic: dict[str, np.ndarray] = field(default_factory=dict)
    dynamic_settings: dict[str, Any] = field(default_factory=dict)
    metrics: SceneMetrics | None = None
    warnings: str = ""
    stats: RunStats = field(default_factory=RunStats)

    @property
    def key(self) -> str:
        return self.spec.key

    @property
    def ok(self) -> bool:
        return self.status == STATUS_OK
