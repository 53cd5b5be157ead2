"""Validity study, data edge: read campaign HDF5 files into flat :class:`Point` records.

Everything downstream (:mod:`compare.limits`, ``validity_figures``,
``validity_report``) is pure and works on these records.  Units: SI; deflections of the coupler
point P in m (dx, dy, global frame), crank angle in rad, speeds in rad/s or rev/min where named.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from compare import metrics, store
from compare.results import SceneResult
from compare.scenes import SceneSpec, canonical_json
from ked_quasi.solver import solve_quasi_static

RETRY_STEP_FACTOR = 4
"""Earlier versions of the study retried a Newton failure once as a scene with this many times the steps
per cycle (such *retry* scenes are in the stored files) ..."""
RETRY_MAX_RATIO = 0.8
"""... if its speed ratio was below this (Newton failures below it are now retried through the refinement
ladder, see :func:`ked_research.validity.study.ladder_retries`)."""


@dataclass(frozen=True, eq=False)
class Point:
    """One stored scene of the study, flattened.

    ``linkage``: label of the four-bar (campaign name without ``validity-``); ``r``: crank speed ratio
    Omega / omega1_min [1]; ``rpm`` [rev/min]; ``omega1_min`` [rad/s]; ``f1_range_hz`` (min, max) of
    the first frozen-structure frequency over the cycle [Hz]; ``theta`` (n,) [rad]; ``qs`` / ``dyn``
    (n, 2) dx, dy of P [m] (``dyn`` None when the dynamic solver failed); ``refined``: computed at the
    refined (doubled) dynamic discretization; ``wall_s`` [s] scene wall time; ``cycles`` crank cycles
    simulated (-1: did not finish); ``source`` name of the HDF5 file it was read from.
    """

    key: str
    label: str
    linkage: str
    mechanism: str
    mass_model: str
    damping: float
    direction: str
    speed_kind: str
    r: float
    rpm: float
    omega1_min: float
    f1_range_hz: tuple[float, float]
    status: str
    stage: str
    error_type: str
    message: str
    refined: bool
    elements_per_link: int
    steps_per_cycle: int
    theta: np.ndarray | None
    qs: np.ndarray | None
    dyn: np.ndarray | None
    wall_s: float
    cycles: int
    spec: SceneSpec
    source: str = ""
    finished_utc: str = ""
    failure_class: str = ""

    @property
    def ok(self) -> bool:
        return self.status == "ok" and self.dyn is not None and self.qs is not None

    @property
    def family(self) -> tuple[str, str, str, float, str]:
        """(linkage, mechanism, mass model, damping ratio, direction)."""
        return (self.linkage, self.mechanism, self.mass_model, self.damping, self.direction)


def linkage_label(campaign_name: str) -> str:
    """``validity-thesis`` -> ``thesis``."""
    for prefix in ("validity-", "validity_"):
        if campaign_name.startswith(prefix):
            campaign_name = campaign_name[len(prefix):]
    return campaign_name.removesuffix("-retry")


def _speed_ratio(r: SceneResult) -> float:
    if r.verdict is not None or r.spec.speed.kind != "ratio":
        return float(r.speed_ratio)
    return float(r.spec.speed.value)


def pair_outcome(r: SceneResult) -> tuple[str, str, str, str, str]:
    """(status, stage, error type, message, failure class) of the quasi-static-vs-dynamic comparison of a scene: "ok"
    when both solutions exist, else the first of the two that failed (another solver's failure, e.g.
    an unstable linear model, does not take the comparison away)."""
    if r.stage in ("setup", "metrics"):
        return r.status, r.stage, r.error_type, r.message, r.failure_class
    for name in ("quasi_static", "dynamic"):
        s = r.solutions.get(name)
        if s is None:
            return "failed", name, "NotRun", f"{name} did not run", ""
        if not s.ok:
            return s.status, name, s.error_type, s.message, s.failure_class
    return "ok", "", "", "", ""


def to_point(r: SceneResult, linkage: str, refined: bool, source: str = "") -> Point:
    """Flatten one :class:`SceneResult`."""
    status, stage, error_type, message, failure_class = pair_outcome(r)
    ds = r.dynamic_settings or {}
    f = r.natural_frequencies
    f1 = (float(np.nanmin(f[:, 0])), float(np.nanmax(f[:, 0]))) if f is not None and f.size else (math.nan,) * 2
    return Point(
        key=r.key, label=r.spec.label, linkage=linkage, mechanism=r.spec.mechanism,
        mass_model=r.spec.mass_model.name, damping=float(r.spec.damping_ratio), direction=r.spec.direction,
        speed_kind=r.spec.speed.kind, r=_speed_ratio(r), rpm=float(r.rpm), omega1_min=float(r.omega1_min),
        f1_range_hz=f1, status=status, stage=stage, error_type=error_type, message=message,
        refined=refined, elements_per_link=int(ds.get("elements_per_link", -1)),
        steps_per_cycle=int(ds.get("steps_per_cycle", -1)),
        theta=r.crank_angle, qs=metrics.vector(r.quasi_static),
        dyn=metrics.vector(r.dynamic) if status == "ok" else None,
        wall_s=float(r.stats.total_wall_s), cycles=int(r.stat("dynamic", "cycles", -1)), spec=r.spec, source=source,
        finished_utc=r.stats.finished_utc, failure_class=failure_class or "unclassified",
    )


def read_points(path: str | Path, linkage: str | None = None, refined: bool = False,
                labels: dict[str, str] | None = None) -> list[Point]:
    """All complete scenes of one campaign file as points.  ``linkage`` label: given, else looked up
    by the scene's linkage JSON in ``labels``, else from the file's ``campaign_name``."""
    info = store.file_info(path)
    default = linkage or linkage_label(str(info.get("campaign_name", Path(path).stem)))
    return [to_point(r, linkage or (labels or {}).get(linkage_json(r.spec), default), refined, Path(path).name)
            for r in store.read_scenes(path)]


def run_starts(path: str | Path) -> list[str]:
    """ISO-8601 start times of every ``ked run`` recorded in a campaign file (``/runs``)."""
    return [str(r["started_utc"]) for r in store.run_records(path)]


def linkage_json(spec: SceneSpec) -> str:
    """Canonical JSON of a scene's source linkage (identifies the four-bar across files)."""
    return canonical_json(spec.key_dict()["linkage"])


def quasi_static_loads(spec: SceneSpec) -> tuple[np.ndarray, np.ndarray]:
    """Recompute the scene's quasi-static solution at 1 rad/s-equivalent shape: returns
    (loads (n, N, 2) [N], deflection (n, 2) [m]) at the scene's grid and an arbitrary speed.  The shape
    of both is independent of the speed (they scale with Omega^2), which is all the harmonic rule needs."""
    scene = spec.scene(100.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        qs = solve_quasi_static(scene)
    return np.asarray(qs.loads, float), np.asarray(qs.deflection, float)[:, :2]
