"""The project's own regression reference, on the machinery of ``ked diff`` (:mod:`compare.diff`).

``results/reference/`` holds ``reference.toml`` (a small campaign with pinned Exudyn settings, its
``[tolerances]`` and ``[expect]`` tables) and ``reference.h5`` (its stored results).  :func:`check` compares a
rerun with the stored results by :func:`compare.diff.diff_files`, with the config's tolerances and expectations;
the same check from the command line::

    ked run results/reference/reference.toml --out rerun.h5 && ked diff results/reference/reference.h5 rerun.h5 \\
        --tolerances results/reference/reference.toml

Regenerate after an intended change of the solvers with ``python -m compare.reference results/reference``.
"""

from __future__ import annotations

import sys
from pathlib import Path

from compare.diff import DiffReport, diff_files

CONFIG, RESULTS = "reference.toml", "reference.h5"


def rerun(directory: str | Path, out: str | Path, workers: int | None = None) -> Path:
    """Run ``<directory>/reference.toml`` into the new file ``out``; returns its path."""
    from compare.config import load_config
    from compare.runner import run_campaign

    return Path(run_campaign(load_config(Path(directory) / CONFIG), out, workers=workers, progress=False).out)


def check(directory: str | Path, new: str | Path) -> DiffReport:
    """The comparison of results file ``new`` with the stored reference, by the config's tolerances and
    expectations."""
    from compare.config import load_config

    d = Path(directory)
    cfg = load_config(d / CONFIG)
    return diff_files(d / RESULTS, new, cfg.tolerances, cfg.expect)


def regenerate(directory: str | Path, workers: int | None = None) -> Path:
    """Rerun ``<directory>/reference.toml`` into a fresh ``reference.h5`` (replacing the stored one: called only
    on purpose, after an intended change); returns its path."""
    h5 = Path(directory) / RESULTS
    tmp = h5.with_name(h5.name + ".new")
    if tmp.exists():
        tmp.unlink()
    rerun(directory, tmp, workers)
    tmp.replace(h5)
    return h5


if __name__ == "__main__":  # pragma: no cover
    print(regenerate(sys.argv[1] if len(sys.argv) > 1 else "results/reference"))
