"""What ``ked check`` needs from the atlas, published as package data: the tier limits of each mass model
and the calibrated margins of the quasi-static call, in ``compare/atlas_limits.json``.

``ked study atlas`` writes it from the atlas file (:func:`write`); ``ked check`` reads it through
:mod:`importlib.resources` (:func:`read`), so an installed wheel carries the same limits as the checkout
and the check needs neither the results directory nor HDF5.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict
from importlib import resources
from pathlib import Path
from typing import Any

from ked_quasi.massmodel import MASS_MODELS

RESOURCE = "atlas_limits.json"
"""The file's name inside the ``compare`` package."""


def build(atlas: str | Path) -> dict[str, Any]:
    """The published record of an atlas file: {"source", "damping_ratio", "limits": {mass model: TierLimits
    fields}, "margins": {"10": {stratum: VerdictMargins fields}}} (non-finite numbers as null): only the strata
    whose margins grant the quasi-static tier (bound met); the check grants none from a prediction elsewhere."""
    # here, not at the top: ked check reads the published file only and must not import scipy.stats, h5py
    from compare.atlas.analysis import limits
    from compare.atlas.calibration import verdict_margins
    from compare.atlas.compute import DAMPING

    rec: dict[str, Any] = {"source": f"atlas {Path(atlas).name}", "damping_ratio": DAMPING, "limits": {},
                           "margins": {}}
    for mm in MASS_MODELS:
        try:
            rec["limits"][mm] = _finite(asdict(limits(mm, atlas)))
        except ValueError:
            continue
    rec["margins"]["10"] = {k: _finite(asdict(m)) for k in strata(atlas)
                            if math.isfinite((m := verdict_margins(0.10, atlas, k)).holds_below) and m.holds_below > 0}
    return rec


def strata(atlas: str | Path) -> list[str]:
    """The strata calibrated in the atlas file at 10 % (whether their bound is met or not)."""
    from compare.atlas import store
    from compare.atlas.calibration import ATTR

    rec = store.attrs(Path(atlas)).get(ATTR, {})
    rec = rec.get("10", {}) if isinstance(rec, dict) else {}
    return sorted(rec.get("strata", {})) if isinstance(rec, dict) else []


def write(atlas: str | Path, out: str | Path | None = None) -> Path:
    """Write the published record of ``atlas`` (default: beside this package's modules, the file
    :func:`read` finds); returns its path."""
    path = Path(out) if out is not None else Path(__file__).resolve().parent.parent / RESOURCE
    path.write_text(json.dumps(build(atlas), indent=1, sort_keys=True, allow_nan=False) + "\n")
    return path


def read() -> dict[str, Any]:
    """The published record ({} when the package carries none or it cannot be read)."""
    try:
        text = resources.files("compare").joinpath(RESOURCE).read_text(encoding="utf-8")
        rec = json.loads(text)
    except (OSError, ValueError):
        return {}
    return rec if isinstance(rec, dict) else {}


def _finite(d: dict[str, Any]) -> dict[str, Any]:
    return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in d.items()}
