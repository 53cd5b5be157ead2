"""The atlas's published record for ``ked check`` (:mod:`ked_check.published`, the check's package data): built
from an atlas file (:func:`build`) and merged into what the file holds of the other linkage kinds (:func:`write`).
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict
from pathlib import Path
from typing import Any

from ked_check.published import PATH, merge
from ked_research.atlas import store
from ked_research.atlas.analysis import limits
from ked_research.atlas.calibration import ATTR, verdict_margins
from ked_research.atlas.compute import DAMPING
from ked_research.atlas.kinds import kind_of


def build(atlas: str | Path) -> dict[str, Any]:
    """The published record of an atlas file: {"source", "damping_ratio", "limits": {mass model: TierLimits
    fields}, "margins": {"10": {stratum: VerdictMargins fields}}} (non-finite numbers as null): only the strata
    whose margins grant the quasi-static tier (bound met); the check grants none from a prediction elsewhere.
    The mass models are those of the atlas's linkage kind (:func:`ked_research.atlas.kinds.kind_of`)."""
    rec: dict[str, Any] = {"source": f"atlas {Path(atlas).name}", "damping_ratio": DAMPING, "limits": {},
                           "margins": {}, "kind": kind_of(Path(atlas)).name}
    for mm in kind_of(Path(atlas)).mass_models:
        try:
            rec["limits"][mm] = _finite(asdict(limits(mm, atlas)))
        except ValueError:
            continue
    rec["margins"]["10"] = {k: _finite(asdict(m)) for k in strata(atlas)
                            if (m := verdict_margins(0.10, atlas, k)).calibrated}
    return rec


def strata(atlas: str | Path) -> list[str]:
    """The strata calibrated in the atlas file at 10 % (whether their bound is met or not)."""
    rec = store.attrs(Path(atlas)).get(ATTR, {})
    rec = rec.get("10", {}) if isinstance(rec, dict) else {}
    return sorted(rec.get("strata", {})) if isinstance(rec, dict) else []


def write(atlas: str | Path, out: str | Path | None = None) -> Path:
    """Write the published record of ``atlas`` (default: the check's package data, the file
    :func:`ked_check.published.read` finds), merged into what the file holds of the other linkage kinds (:func:`merge`);
    returns its path."""
    path = Path(out) if out is not None else PATH
    try:
        old = json.loads(path.read_text(encoding="utf-8")) if path.exists() else {}
    except ValueError:
        old = {}
    rec = merge(old if isinstance(old, dict) else {}, build(atlas))
    path.write_text(json.dumps(rec, indent=1, sort_keys=True, allow_nan=False) + "\n")
    return path


def _finite(d: dict[str, Any]) -> dict[str, Any]:
    return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in d.items()}
