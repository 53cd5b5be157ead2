"""``ked study stress``: compute (resume) the stress study's scenes into ``studies/stress.h5``
(:mod:`ked_research.stress.data`), then its figure and README section (:mod:`ked_research.stress.report`)."""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

from compare.paths import StudyPaths
from ked_research.stress.data import (  # noqa: F401 - the study's public names
    ATLAS_LINKAGES,
    DAMPING,
    ELEMENTS,
    FILE,
    MATERIALS,
    RATIOS,
    SECTION,
    TOLERANCE,
    Case,
    Row,
    cases,
    compute,
    stored,
)


def run(paths: StudyPaths, *, workers: int = 2, fresh: bool = False, report_only: bool = False,
        progress: bool = False, echo: Callable[[str], Any] = print,
        atlas_linkages: int = ATLAS_LINKAGES) -> dict[str, Any]:
    """The study with the common signature (see :func:`ked_research.run`)."""
    from compare.paths import remove_outputs
    from ked_research.stress.report import write_report

    path = paths.studies / FILE
    if fresh:
        remove_outputs([path], echo)
    summary: dict[str, Any] = {"file": str(path)}
    if not report_only:
        summary["computed"] = _compute(path, cases(atlas_linkages), workers=workers, progress=progress, echo=echo)
    if not path.exists():
        raise FileNotFoundError(f"{path}: no stress study to report on; run `ked study stress` without "
                                "--report-only")
    summary["report"] = write_report(stored(path), paths)
    return summary


def _compute(path: Path, todo_all: list[Case], *, workers: int, progress: bool, echo: Callable[[str], Any]) -> int:
    from compare import store
    from ked_research.atlas.run import run_records
    from ked_research.study_io import write_tables

    have = {r.key: r for r in stored(path)}
    todo = [c for c in todo_all if c.key not in have]
    if not todo:
        return 0
    echo(f"stress: {len(todo)} scene(s) to compute")
    path.parent.mkdir(parents=True, exist_ok=True)
    order = {c.key: i for i, c in enumerate(todo_all)}

    def commit(rows: list[Row]) -> None:
        have.update({r.key: r for r in rows})
        write_tables(path, {"scenes": sorted(have.values(), key=lambda r: order.get(r.key, len(order)))},
                     {"ratios": list(RATIOS), "tolerance": TOLERANCE, "elements_per_link": ELEMENTS,
                      "damping_ratio": DAMPING})

    def lost(case: Case, reason: str) -> list[Row]:
        nan = math.nan
        return [Row(case.key, case.group, case.linkage, case.mechanism, case.mass_model, "", case.r, nan, False,
                    reason[:300], "", nan, nan, nan, nan, nan, "", nan, nan, nan, nan, 0.0)]

    with store.writer_lock(path):
        run_records(todo, compute, commit, lost, workers=workers, scheduler=None, progress=progress, label="stress")
        with store.transaction(path, repack=True):  # the batches' rewrites leave free space behind
            pass
    return len(todo)
