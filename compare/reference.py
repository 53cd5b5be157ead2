"""Regression reference: expected metrics of a small campaign and the check against a rerun.

The committed reference lives in ``results/reference/``: ``reference.toml`` (the campaign),
``reference.h5`` (its results) and ``expected_metrics.json`` (written by :func:`expected_metrics`).
Regenerate after an intended change of the solvers with::

    python -m compare.reference results/reference

Tolerances (:data:`TOLERANCES`): every metric must stay within ``rel`` of the stored value or within the
absolute floor ``abs`` (whichever is larger), and every verdict must be unchanged.
"""

from __future__ import annotations

import json
import math
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from compare.results import SceneResult

# metric -> (relative tolerance [1], absolute floor [unit of the metric])
TOLERANCES: dict[str, tuple[float, float]] = {
    "max_abs_error": (0.02, 1e-7),  # m or rad
    "rms_error": (0.02, 1e-7),  # m or rad
    "relative_error": (0.02, 2e-3),  # 1
    "amplification": (0.02, 2e-3),  # 1
    "phase_shift": (0.0, math.radians(1.0)),  # rad
    "speed_ratio": (1e-6, 0.0),  # 1
}


def expected_metrics(results: Sequence[SceneResult]) -> dict[str, Any]:
    """Reference record: key -> label, status, verdict and per-component metrics."""
    out: dict[str, Any] = {"tolerances": {k: {"rel": r, "abs": a} for k, (r, a) in TOLERANCES.items()},
                           "scenes": {}}
    for r in sorted(results, key=lambda r: r.key):
        rec: dict[str, Any] = {"label": r.spec.label, "status": r.status}
        v = r.verdict
        if v is not None:
            rec["holds"] = v.holds
            rec["speed_ratio"] = v.speed_ratio
            rec["verdict_error"] = v.verdict_error  # the vector's relative_error; recorded for readers
            rec["components"] = {c.component: {"holds": c.holds, **_values(c)} for c in v.components}
        out["scenes"][r.key] = rec
    return out


def _values(c: Any) -> dict[str, float]:
    """The recorded metrics of a component (``relative_error`` is the history error)."""
    return {m: getattr(c, "history_error" if m == "relative_error" else m) for m in TOLERANCES if m != "speed_ratio"}


def _close(name: str, new: float, old: float) -> bool:
    rel, floor = TOLERANCES[name]
    if name == "phase_shift":
        d = abs((new - old + math.pi) % (2 * math.pi) - math.pi)
    else:
        d = abs(new - old)
    return d <= max(rel * abs(old), floor)


def compare_to_reference(results: Sequence[SceneResult], expected: dict[str, Any]) -> list[str]:
    """Differences of ``results`` from an :func:`expected_metrics` record (empty list = regression passes)."""
    problems: list[str] = []
    got = {r.key: r for r in results}
    for key, rec in expected["scenes"].items():
        label = rec["label"]
        r = got.get(key)
        if r is None:
            problems.append(f"{label} [{key}]: missing from the rerun")
            continue
        if r.status != rec["status"]:
            problems.append(f"{label}: status {r.status!r} != reference {rec['status']!r} ({r.message})")
            continue
        v = r.verdict
        if v is None:
            continue
        if v.holds != rec["holds"]:
            problems.append(f"{label}: verdict changed (holds {v.holds}, reference {rec['holds']})")
        if not _close("speed_ratio", v.speed_ratio, rec["speed_ratio"]):
            problems.append(f"{label}: speed_ratio {v.speed_ratio:.6g} != {rec['speed_ratio']:.6g}")
        for comp, ref in rec["components"].items():
            c = v.component(comp)
            if c.holds != ref["holds"]:
                problems.append(f"{label} {comp}: verdict changed (holds {c.holds}, reference {ref['holds']})")
            for m, value in _values(c).items():
                if not _close(m, value, ref[m]):
                    problems.append(f"{label} {comp}: {m} {value:.6g} vs reference {ref[m]:.6g} "
                                    f"(tolerance rel {TOLERANCES[m][0]:g}, abs {TOLERANCES[m][1]:g})")
    return problems


def regenerate(directory: str | Path, workers: int | None = None) -> Path:
    """Rerun ``<directory>/reference.toml`` into a fresh ``reference.h5`` and write
    ``expected_metrics.json``; returns the JSON path."""
    from compare import store
    from compare.config import load_config
    from compare.runner import run_campaign

    d = Path(directory)
    cfg = load_config(d / "reference.toml")
    h5 = d / "reference.h5"
    if h5.exists():
        h5.unlink()
    run_campaign(cfg, h5, workers=workers, progress=False)
    path = d / "expected_metrics.json"
    path.write_text(json.dumps(expected_metrics(store.read_scenes(h5)), indent=2, sort_keys=True) + "\n")
    return path


if __name__ == "__main__":  # pragma: no cover
    print(regenerate(sys.argv[1] if len(sys.argv) > 1 else "results/reference"))
