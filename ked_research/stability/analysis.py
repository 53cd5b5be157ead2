"""Stability study, pure analysis: what each solver reported on an extreme scene, and the check.

Units: deflection peaks [m], angles [deg] where named ``_deg``, wall time [s]. Inputs are plain
arrays and values so that everything here is testable without running a solver.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass

import numpy as np

from compare.metrics import translation_error

#: speed ratio below which the dynamic peak must be within AMPLIFICATION_BAND of the quasi-static one
SUBCRITICAL = 0.8
AMPLIFICATION_BAND = (0.5, 3.0)
#: settings variants must agree with the same scene at default settings within this (relative) [1]
DEVIATION_LIMIT = 0.05


@dataclass(frozen=True)
class QuasiReport:
    """Quasi-static solver on one scene: peak of |dx|, |dy| [m] (nan-aware) over all angles and over the
    angles not flagged, largest condition number 1/|sin mu| [1], flagged (near-toggle) crank angles [deg],
    smallest distance of the transmission angle mu from a toggle, min(mu, 180 - mu) [deg], and how many
    angles have a non-finite deflection."""

    peak_m: float
    peak_unflagged_m: float
    condition_max: float
    flagged_deg: tuple[float, ...]
    toggle_distance_deg: float
    nonfinite: int


def quasi_report(deflection: np.ndarray, condition: np.ndarray, flagged: np.ndarray,
                 transmission_angle: np.ndarray, crank_angle: np.ndarray) -> QuasiReport:
    """Summarize a QuasiStaticResult's arrays (deflection (n, 3), angles [rad])."""
    d = np.asarray(deflection, dtype=float)
    mu = np.degrees(np.asarray(transmission_angle, dtype=float))
    xy = np.abs(d[:, :2])
    keep = ~np.asarray(flagged, bool)
    return QuasiReport(
        peak_m=float(np.nanmax(xy)) if np.isfinite(xy).any() else math.nan,
        peak_unflagged_m=float(np.nanmax(xy[keep])) if np.isfinite(xy[keep]).any() else math.nan,
        condition_max=float(np.nanmax(np.where(np.isfinite(condition), condition, np.inf))),
        flagged_deg=tuple(float(x) for x in np.round(np.degrees(np.asarray(crank_angle)[np.asarray(flagged, bool)]),
                                                     3)),
        toggle_distance_deg=float(np.min(np.minimum(mu, 180.0 - mu))),
        nonfinite=int((~np.isfinite(d)).any(axis=1).sum()),
    )


def peak(deflection: np.ndarray) -> float:
    """Peak of |dx|, |dy| [m] of an (n, >=2) history (nan if none is finite)."""
    xy = np.abs(np.asarray(deflection, dtype=float)[:, :2])
    return float(np.nanmax(xy)) if np.isfinite(xy).any() else math.nan


deviation = translation_error
"""max |d - base| of (dx, dy) relative to the peak of base [1] (:func:`compare.metrics.translation_error`)."""


def check(ok: bool, finite: bool, converged: bool, speed_ratio: float, amplification: float,
          deviation_from_default: float | None, near_toggle: bool = False) -> str:
    """Verdict on a dynamic result: "pass" or "fail: <reason>" (a failed run is not checked: "-").

    amplification: dynamic peak / quasi-static peak over the angles not flagged as near-toggle. The band
    applies below SUBCRITICAL, but not on near-toggle scenes: there the frozen structure is nearly
    singular over a range of angles (and its speed ratio meaningless), so the quasi-static peak is no
    yardstick; those scenes are checked against a refined dynamic run (deviation_from_default)."""
    if not ok:
        return "-"
    if not finite:
        return "fail: non-finite deflection"
    if not converged:
        return "fail: not steady"
    lo, hi = AMPLIFICATION_BAND
    if speed_ratio < SUBCRITICAL and not near_toggle and not lo <= amplification <= hi:
        return f"fail: amplification {amplification:.3g} outside {AMPLIFICATION_BAND}"
    if deviation_from_default is not None and deviation_from_default > DEVIATION_LIMIT:
        return f"fail: {100 * deviation_from_default:.3g} % from the default-settings result"
    return "pass"


@dataclass(frozen=True)
class StabilityFindings:
    """What the stored ``/study/cases`` table says: scenes [count] in cases [count], how many converged and
    how many of those pass :func:`check`, how many failed with a recorded reason and how many were lost;
    campaign and whole-study wall times [s] on ``workers`` processes; the Exudyn default settings
    (``DynamicSettings`` as a dict); the per-scene rows as stored and the rows of the failed scenes."""

    created_utc: str
    scenes: int
    cases: int
    converged: int
    passed: int
    failed: int
    lost: int
    campaign_wall_s: float
    study_wall_s: float
    workers: int
    defaults: dict
    rows: tuple[dict, ...]
    failures: tuple[dict, ...]


def analyse(cases: list[dict], attrs: dict) -> StabilityFindings:
    """The findings of the stored rows ``cases`` (:func:`ked_research.study_io.rows`) and file attributes."""
    dd = json.loads(attrs["defaults"]) if isinstance(attrs["defaults"], str) else dict(attrs["defaults"])
    n_ok = sum(1 for r in cases if r["status"] == "ok")
    return StabilityFindings(
        created_utc=str(attrs["created_utc"]), scenes=len(cases), cases=len({r["case"] for r in cases}),
        converged=n_ok, passed=sum(1 for r in cases if r["check"] == "pass"), failed=len(cases) - n_ok,
        lost=int(attrs.get("lost", 0)), campaign_wall_s=float(attrs["campaign_wall_s"]),
        study_wall_s=float(attrs["study_wall_s"]), workers=int(attrs["workers"]), defaults=dd, rows=tuple(cases),
        failures=tuple(r for r in cases if r["status"] != "ok"))
