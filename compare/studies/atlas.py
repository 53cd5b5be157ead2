"""``ked study atlas``: the validity atlas (``compare.atlas``): compute (resume) the linkages, the
Exudyn-confirmed sample and the threshold sample into ``<results>/atlas/atlas.h5``, choose the check's
margins from the threshold sample (stored in the file: :func:`compare.atlas.verdict_margins`), then its
figures and README section."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from compare.atlas import published
from compare.atlas.analysis import default_path
from compare.atlas.calibration import store_margins
from compare.atlas.confirm import run_confirm
from compare.atlas.reconfirm import reconfirm
from compare.atlas.report import write_report
from compare.atlas.repredict import repredict
from compare.atlas.run import run_atlas
from compare.atlas.threshold import DEFAULT_THRESHOLD, DEFAULT_TOP_UP, run_threshold
from compare.paths import StudyPaths, remove_outputs

DEFAULT_LINKAGES = 1000
DEFAULT_CONFIRM = 200


def atlas_file(paths: StudyPaths) -> Path:
    """Where the atlas of a results directory lives."""
    return paths.results / "atlas" / "atlas.h5"


def run(paths: StudyPaths, *, workers: int = 2, fresh: bool = False, report_only: bool = False,
        progress: bool = False, echo: Callable[[str], Any] = print, linkages: int = DEFAULT_LINKAGES,
        seed: int = 0, scheduler: str | None = None, confirm: int = DEFAULT_CONFIRM,
        threshold: int = DEFAULT_THRESHOLD, threshold_top_up: int = DEFAULT_TOP_UP) -> dict[str, Any]:
    """The study with the common signature (see :func:`compare.studies.run`)."""
    path = atlas_file(paths)
    if fresh:
        remove_outputs([path], echo)
    summary: dict[str, Any] = {"atlas": str(path)}
    if not report_only:
        summary["run"] = vars(run_atlas(path, linkages=linkages, seed=seed, workers=workers, scheduler=scheduler,
                                        progress=progress, echo=echo))
        # confirmed rows whose quasi-static answer an older lumping made: confirmed again, then rows whose
        # prediction columns an older linear model made: predicted again, before anything is added
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
    if not path.exists():
        raise FileNotFoundError(f"{path}: no atlas file to report on; run `ked study atlas` without --report-only")
    summary["margins"] = store_margins(path)  # derived from the stored tables (also with --report-only)
    if path.resolve() == default_path().resolve():  # the committed atlas: publish what ked check reads
        summary["published"] = str(published.write(path))
    summary["report"] = write_report(path, paths.figures, paths.readme)
    return summary
