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

RESOURCE = "atlas_limits.json"
"""The file's name inside the ``compare`` package."""
FOUR_BAR = "four-bar"
KIND_LIMITS = "kind_limits"
"""Key of the tier limits of the other linkage kinds: {kind: {mass model: TierLimits fields}} (a four-bar's
stay under "limits", as before the slider-crank's atlas)."""


def build(atlas: str | Path) -> dict[str, Any]:
    """The published record of an atlas file: {"source", "damping_ratio", "limits": {mass model: TierLimits
    fields}, "margins": {"10": {stratum: VerdictMargins fields}}} (non-finite numbers as null): only the strata
    whose margins grant the quasi-static tier (bound met); the check grants none from a prediction elsewhere.
    The mass models are those of the atlas's linkage kind (:func:`compare.atlas.kinds.kind_of`)."""
    # here, not at the top: ked check reads the published file only and must not import scipy.stats, h5py
    from compare.atlas.analysis import limits
    from compare.atlas.calibration import verdict_margins
    from compare.atlas.compute import DAMPING
    from compare.atlas.kinds import kind_of

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
    from compare.atlas import store
    from compare.atlas.calibration import ATTR

    rec = store.attrs(Path(atlas)).get(ATTR, {})
    rec = rec.get("10", {}) if isinstance(rec, dict) else {}
    return sorted(rec.get("strata", {})) if isinstance(rec, dict) else []


def merge(old: dict[str, Any], new: dict[str, Any]) -> dict[str, Any]:
    """The published file ``old`` with the record ``new`` of one linkage kind (:func:`build`) in place of that
    kind's entries; the other kinds' limits and strata stay as they are.  A four-bar record is the file's
    top level (source, damping ratio, limits); another kind's limits go under :data:`KIND_LIMITS`."""
    kind = new.get("kind", FOUR_BAR)
    out = dict(old)
    if kind == FOUR_BAR:
        out.update({k: new[k] for k in ("source", "damping_ratio", "limits")})
    else:
        out.setdefault("damping_ratio", new["damping_ratio"])
        out[KIND_LIMITS] = {**old.get(KIND_LIMITS, {}), kind: {"source": new["source"], "limits": new["limits"]}}
    margins = {t: {s: m for s, m in strata.items() if not s.startswith(f"{kind}/")}
               for t, strata in old.get("margins", {}).items()}
    for t, strata in new["margins"].items():
        margins[t] = {**margins.get(t, {}), **strata}
    out["margins"] = margins
    return out


def write(atlas: str | Path, out: str | Path | None = None) -> Path:
    """Write the published record of ``atlas`` (default: beside this package's modules, the file
    :func:`read` finds), merged into what the file holds of the other linkage kinds (:func:`merge`);
    returns its path."""
    path = Path(out) if out is not None else Path(__file__).resolve().parent.parent / RESOURCE
    try:
        old = json.loads(path.read_text(encoding="utf-8")) if path.exists() else {}
    except ValueError:
        old = {}
    rec = merge(old if isinstance(old, dict) else {}, build(atlas))
    path.write_text(json.dumps(rec, indent=1, sort_keys=True, allow_nan=False) + "\n")
    return path


def kind_limits(rec: dict[str, Any], kind: str) -> dict[str, Any]:
    """The published tier limits of linkage ``kind`` ({mass model: TierLimits fields}; {} without any)."""
    if kind == FOUR_BAR:
        lims = rec.get("limits", {})
    else:
        lims = rec.get(KIND_LIMITS, {}).get(kind, {}).get("limits", {})
    return lims if isinstance(lims, dict) else {}


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
