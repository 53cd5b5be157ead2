"""``ked study atlas``: the validity atlas (``ked_research.atlas``): compute (resume) the linkages, the
Exudyn-confirmed sample and the threshold sample into ``<results>/atlas/atlas.h5``, and the same for
generated slider-cranks into ``<results>/atlas/slider_atlas.h5``, choose the check's margins per stratum
from each threshold sample (stored in each file: :func:`ked_research.atlas.verdict_margins`), publish them,
then the figures and README section."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from compare.paths import StudyPaths, remove_outputs
from ked_research.atlas import publish
from ked_research.atlas.analysis import default_path
from ked_research.atlas.calibration import store_margins
from ked_research.atlas.confirm import run_confirm
from ked_research.atlas.reconfirm import reconfirm
from ked_research.atlas.report import write_report
from ked_research.atlas.repredict import repredict
from ked_research.atlas.resweep import resweep
from ked_research.atlas.run import run_atlas
from ked_research.atlas.threshold import DEFAULT_THRESHOLD, DEFAULT_TOP_UP, run_threshold

DEFAULT_LINKAGES = 1000
DEFAULT_CONFIRM = 200
SLIDER_LINKAGES = 200
"""Generated slider-cranks of the slider atlas: 200 families per slider stratum, so that each threshold draw
(100 scenes per stratum) takes its scenes from 100 equal strata of r10 of two families each."""
SLIDER_CONFIRM = 150
"""Scenes of the slider atlas's confirmed sample (the linear model's limits per mass model)."""
SLIDER_THRESHOLD = 300
"""Scenes of each of the slider threshold sample's three draws (100 per slider stratum each: two of the
four-bar's design, one aimed at predicted errors 0.7-1.05 x the tolerance): with no unsafe call a stratum
needs 122 Exudyn answers for the 3 % bound."""


def atlas_file(paths: StudyPaths) -> Path:
    """Where the atlas of a results directory lives."""
    return paths.results / "atlas" / "atlas.h5"


def slider_atlas_file(paths: StudyPaths) -> Path:
    """Where the slider atlas of a results directory lives (its own file beside the four-bar atlas)."""
    return paths.results / "atlas" / "slider_atlas.h5"


def run_slider(path: Path, *, linkages: int = SLIDER_LINKAGES, seed: int = 0, workers: int = 2,
               scheduler: str | None = None, confirm: int = SLIDER_CONFIRM, threshold: int = SLIDER_THRESHOLD,
               progress: bool = False, echo: Callable[[str], Any] = print) -> dict[str, Any]:
    """Compute (resume) the slider atlas at ``path``: its generated slider-cranks' families, the confirmed
    sample and the three threshold draws of ``threshold`` scenes each (its margins: ``store_margins``)."""
    from ked_research.atlas.kinds import SLIDER

    out: dict[str, Any] = {"atlas": str(path)}
    if linkages > 0:
        out["run"] = vars(run_atlas(path, linkages=linkages, seed=seed, workers=workers, scheduler=scheduler,
                                    progress=progress, echo=echo, kind=SLIDER))
    if not path.exists():
        return out
    # as the four-bar atlas: what an older code made is computed again before anything is added
    out["reswept"] = resweep(path, seed=seed, workers=workers, scheduler=scheduler, progress=progress, echo=echo)
    out["reconfirmed"] = reconfirm(path, seed=seed, workers=workers, scheduler=scheduler, progress=progress,
                                   echo=echo)
    out["repredicted"] = repredict(path, seed=seed, workers=workers, scheduler=scheduler, progress=progress,
                                   echo=echo)
    if confirm > 0:
        out["confirm"] = run_confirm(path, n=confirm, seed=seed, workers=workers, scheduler=scheduler,
                                     progress=progress, echo=echo)
    if threshold > 0:
        out["threshold"] = run_threshold(path, n=threshold, top_up=threshold, targeted=threshold, seed=seed,
                                         workers=workers, scheduler=scheduler, progress=progress, echo=echo)
    return out


def run(paths: StudyPaths, *, workers: int = 2, fresh: bool = False, report_only: bool = False,
        progress: bool = False, echo: Callable[[str], Any] = print, linkages: int = DEFAULT_LINKAGES,
        seed: int = 0, scheduler: str | None = None, confirm: int = DEFAULT_CONFIRM,
        threshold: int = DEFAULT_THRESHOLD, threshold_top_up: int = DEFAULT_TOP_UP,
        slider_linkages: int = SLIDER_LINKAGES) -> dict[str, Any]:
    """The study with the common signature (see :func:`ked_research.run`); ``slider_linkages`` > 0 also
    computes (resumes) the slider atlas (:func:`run_slider`) with that many generated slider-cranks."""
    path, slider = atlas_file(paths), slider_atlas_file(paths)
    if fresh:
        remove_outputs([path, slider] if slider_linkages > 0 else [path], echo)
    summary: dict[str, Any] = {"atlas": str(path)}
    if not report_only:
        summary["run"] = vars(run_atlas(path, linkages=linkages, seed=seed, workers=workers, scheduler=scheduler,
                                        progress=progress, echo=echo))
        # family sweeps an older code made: swept again; confirmed rows whose quasi-static answer an older
        # lumping made: confirmed again, then rows whose prediction columns an older linear model made:
        # predicted again, before anything is added
        summary["reswept"] = resweep(path, seed=seed, workers=workers, scheduler=scheduler, progress=progress,
                                     echo=echo)
        summary["reconfirmed"] = reconfirm(path, seed=seed, workers=workers, scheduler=scheduler,
                                           progress=progress, echo=echo)
        summary["repredicted"] = repredict(path, seed=seed, workers=workers, scheduler=scheduler, progress=progress,
                                           echo=echo)
        if confirm > 0:
            summary["confirm"] = run_confirm(path, n=confirm, seed=seed, workers=workers, scheduler=scheduler,
                                             progress=progress, echo=echo)
        if threshold > 0:
            summary["threshold"] = run_threshold(path, n=threshold, top_up=threshold_top_up, seed=seed,
                                                 workers=workers, scheduler=scheduler, progress=progress, echo=echo)
        if slider_linkages > 0:
            summary["slider"] = run_slider(slider, linkages=slider_linkages, seed=seed, workers=workers,
                                           scheduler=scheduler, progress=progress, echo=echo)
    if slider.exists():
        summary.setdefault("slider", {})["margins"] = store_margins(slider)
    if not path.exists():
        raise FileNotFoundError(f"{path}: no atlas file to report on; run `ked study atlas` without --report-only")
    summary["margins"] = store_margins(path)  # derived from the stored tables (also with --report-only)
    if path.resolve() == default_path().resolve():  # the committed atlas: publish what ked check reads
        summary["published"] = str(publish.write(path))
        if slider.exists():  # merged beside the four-bar entries
            publish.write(slider)
    summary["report"] = write_report(path, paths.figures, paths.readme, slider if slider.exists() else None)
    return summary
