"""Studies that answer the harness's questions: each one checked-in campaign configs under
``results/studies/`` plus one :func:`run` that regenerates its HDF5 file(s), figures and its own
section of ``results/README.md``.

Every study has the same signature (:func:`run`): it resumes what is stored (nothing is deleted
unless ``fresh``), writes into one results directory (HDF5 files in ``studies/``, PNG figures in
``figures/``, the README section in ``README.md``), and ``report_only`` redraws figures and README
from the stored files without computing.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from compare.paths import COMMITTED, StudyPaths

STUDIES = ("validity", "work-precision", "stability", "tiers", "atlas", "stress")


def run(name: str, paths: StudyPaths = COMMITTED, *, workers: int = 2, fresh: bool = False,
        report_only: bool = False, progress: bool = False, echo: Callable[[str], Any] = print,
        **options: Any) -> dict[str, Any]:
    """Run (resume) study ``name`` into ``paths`` and regenerate its figures and README section;
    ``fresh`` deletes the study's stored HDF5 files first; ``report_only`` computes nothing.
    ``options``: the study's own (validity: ``configs``, ``retry``, ``refine``; work-precision:
    ``retime_below_s``; stability: ``ladder``; atlas: ``linkages``, ``seed``, ``scheduler``, ``confirm``).
    Returns a summary (JSON-able)."""
    if name not in STUDIES:
        raise ValueError(f"study must be one of {', '.join(STUDIES)}; got {name!r}")
    from ked_research.atlas import study as atlas
    from ked_research.stability import study as stability
    from ked_research.stress import study as stress
    from ked_research.tiers import study as tiers
    from ked_research.validity import study as validity
    from ked_research.work_precision import study as work_precision

    module = {"validity": validity, "work-precision": work_precision, "stability": stability, "tiers": tiers,
              "atlas": atlas, "stress": stress}[name]
    return module.run(paths, workers=workers, fresh=fresh, report_only=report_only, progress=progress, echo=echo,
                      **options)
