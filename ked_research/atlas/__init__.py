"""The KED validity atlas: the quasi-static and linear models' speed-ratio limits over a seeded sample of
four-bars (``generate``), computed on the harness's executor (``run``: local workers or a Dask cluster),
confirmed on a stratified Exudyn sample (``confirm``), stored compactly (``store``: ``results/atlas/atlas.h5``)
and reported (``report``).

:func:`limits` gives the design check the atlas's tier limits of a mass model, :func:`verdict_margins` the margins of
its quasi-static call calibrated on the threshold sample (``threshold``, ``calibration``).
"""

import importlib

_EXPORTS = {"TierLimits": "analysis", "limits": "analysis", "VerdictMargins": "calibration",
            "verdict_margins": "calibration", "Linkage": "generate", "Reject": "generate", "Sample": "generate",
            "generate": "generate"}

__all__ = ["Linkage", "Reject", "Sample", "TierLimits", "VerdictMargins", "generate", "limits", "verdict_margins"]


def __getattr__(name: str):
    """The package's names, imported on first use: ``ked check`` reads only :mod:`ked_check.published`
    and must not pay for scipy.stats (calibration) at start-up."""
    if name in _EXPORTS:
        return getattr(importlib.import_module(f"ked_research.atlas.{_EXPORTS[name]}"), name)
    raise AttributeError(f"module 'ked_research.atlas' has no attribute {name!r}")
