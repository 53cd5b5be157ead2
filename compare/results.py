"""In-memory data model of one scene's outcome (independent of any file format).

:mod:`compare.store` maps it to and from HDF5; :mod:`compare.execute` produces it.  Arrays are over
the scene's crank-angle grid (n samples, one cycle).  Units: crank angle rad, deflections dx, dy m,
rotation rad, natural frequencies Hz, coupler point m, wall times s.
"""

from __future__ import annotations

import datetime as _dt
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from compare.metrics import PairMetrics, pair_name, reference_of
from compare.scenes import SceneSpec
from compare.solvers import STATUS_FAILED, STATUS_OK, Solution
from ked_quasi import units

STATUSES = (STATUS_OK, STATUS_FAILED)
__all__ = ["STATUSES", "STATUS_FAILED", "STATUS_OK", "RunStats", "SceneResult"]


@dataclass(frozen=True)
class RunStats:
    """Scene-level cost (each solver's own statistics are on its :class:`~compare.solvers.Solution`).
    Wall times [s]; ``worker`` = "host:pid" that computed the scene, ``finished_utc`` ISO-8601 time."""

    frequencies_wall_s: float = 0.0
    total_wall_s: float = 0.0
    worker: str = ""
    finished_utc: str = ""


@dataclass(frozen=True, eq=False)
class SceneResult:
    """Outcome of one scene: ``"ok"`` when every requested solver succeeded, else ``"failed"`` with the
    first failing ``stage`` (setup, frequencies, a solver's name, metrics, worker), the exception's type
    name and message; a failed scene keeps whatever was computed.

    - ``rpm`` [rev/min] resolved crank speed (nan if it could not be resolved)
    - ``omega1_min`` [rad/s] lowest first natural circular frequency over the cycle (nan if unknown)
    - ``crank_angle`` (n,) [rad]; ``coupler_point`` (n, 2) rigid P [m]
    - ``natural_frequencies`` (n, n_modes) [Hz] of the frozen structure
    - ``solutions``: solver name -> :class:`~compare.solvers.Solution`
    - ``metrics``: pair name (``<solver>_vs_<reference>``) -> :class:`~compare.metrics.PairMetrics`
    - ``warnings``: solver warnings (e.g. near-toggle crank angles), "; "-joined
    - ``failure_class``: why a failed scene failed (see :data:`compare.solvers.FAILURE_CLASSES`)
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
    solutions: dict[str, Solution] = field(default_factory=dict)
    metrics: dict[str, PairMetrics] = field(default_factory=dict)
    warnings: str = ""
    failure_class: str = ""
    stats: RunStats = field(default_factory=RunStats)

    @property
    def key(self) -> str:
        return self.spec.key

    @property
    def ok(self) -> bool:
        return self.status == STATUS_OK

    @property
    def speed_ratio(self) -> float:
        """r = Omega / omega1_min [1] of the resolved crank speed (NaN if either is unknown)."""
        return units.speed_ratio(units.rpm_to_rad_s(self.rpm), self.omega1_min)

    # -- views -------------------------------------------------------------------------------
    def history(self, solver: str) -> dict[str, np.ndarray]:
        """Component -> history of one solver ({} if it did not produce one)."""
        s = self.solutions.get(solver)
        return s.deflection if s is not None else {}

    @property
    def quasi_static(self) -> dict[str, np.ndarray]:
        return self.history("quasi_static")

    @property
    def dynamic(self) -> dict[str, np.ndarray]:
        return self.history("dynamic")

    def settings(self, solver: str) -> dict[str, Any]:
        """Resolved settings of one solver ({} if it did not run)."""
        s = self.solutions.get(solver)
        return s.settings if s is not None else {}

    @property
    def dynamic_settings(self) -> dict[str, Any]:
        return self.settings("dynamic")

    def stat(self, solver: str, name: str, default: Any = None) -> Any:
        """One run statistic of one solver (``default`` if absent)."""
        s = self.solutions.get(solver)
        return s.stats.get(name, default) if s is not None else default

    @property
    def reference(self) -> str | None:
        """The scene's reference solver: the highest-fidelity one that succeeded."""
        return reference_of({n: s.fidelity for n, s in self.solutions.items() if s.ok})

    @property
    def verdict(self) -> PairMetrics | None:
        """Quasi-static against the reference: the metrics the scene's verdict uses (None if either is
        missing)."""
        ref = self.reference
        return self.metrics.get(pair_name("quasi_static", ref)) if ref else None


def utc_now() -> str:
    """Current UTC time, ISO 8601 with seconds (the stamps of :class:`RunStats` and the stores)."""
    return _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")
