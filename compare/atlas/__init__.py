"""The KED validity atlas: the quasi-static and linear models' speed-ratio limits over a seeded sample of
four-bars (``generate``), computed on the harness's executor (``run``: local workers or a Dask cluster),
confirmed on a stratified Exudyn sample (``confirm``), stored compactly (``store``: ``results/atlas/atlas.h5``)
and reported (``report``).

:func:`limits` gives the design check the atlas's tier limits of a mass model, :func:`verdict_margins` the margins of
its quasi-static call calibrated on the threshold sample (``threshold``, ``calibration``).
"""

from compare.atlas.analysis import TierLimits, limits
from compare.atlas.calibration import VerdictMargins, verdict_margins
from compare.atlas.generate import Linkage, Reject, Sample, generate

__all__ = ["Linkage", "Reject", "Sample", "TierLimits", "VerdictMargins", "generate", "limits", "verdict_margins"]
