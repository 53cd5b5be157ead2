"""The check's published limits, package data of this package (``ked_check/atlas_limits.json``): the tier limits
of each mass model and the calibrated margins of the quasi-static call.

``ked study atlas`` writes the file from the atlas (:mod:`ked_research.atlas.publish`); ``ked check`` reads it
through :mod:`importlib.resources` (:func:`read`), so an installed wheel carries the same limits as the checkout
and the check needs neither the results directory nor HDF5.
"""

from __future__ import annotations

import json
from importlib import resources
from pathlib import Path
from typing import Any

RESOURCE = "atlas_limits.json"
"""The file's name inside the ``ked_check`` package."""
PATH = Path(__file__).resolve().parent / RESOURCE
"""Where the checkout's copy lies (the file :func:`read` finds in an editable install)."""
FOUR_BAR = "four-bar"
KIND_LIMITS = "kind_limits"
"""Key of the tier limits of the other linkage kinds: {kind: {mass model: TierLimits fields}} (a four-bar's
stay under "limits", as before the slider-crank's atlas)."""


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
        text = resources.files("ked_check").joinpath(RESOURCE).read_text(encoding="utf-8")
        rec = json.loads(text)
    except (OSError, ValueError):
        return {}
    return rec if isinstance(rec, dict) else {}
