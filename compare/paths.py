"""Where the checkout keeps its committed results: the one place that knows the repository layout.

``ROOT`` is the checkout (the directory holding ``compare/``); every study and the atlas write under
``ROOT / "results"`` unless given another results directory (:class:`StudyPaths`).  Only studies and
the atlas use these paths: the design check reads its limits as package data, never through them.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "results"
"""The committed results: study HDF5 files, figures, README, reference scenes, the atlas."""
CONFIG_DIR = RESULTS / "studies"
"""The checked-in study configs."""
ATLAS_FILE = RESULTS / "atlas" / "atlas.h5"
"""The committed atlas file."""


@dataclass(frozen=True)
class StudyPaths:
    """Where a study writes: ``results`` holds ``studies/`` (HDF5), ``figures/`` and ``README.md``."""

    results: Path = RESULTS

    @property
    def studies(self) -> Path:
        return self.results / "studies"

    @property
    def figures(self) -> Path:
        return self.results / "figures"

    @property
    def readme(self) -> Path:
        return self.results / "README.md"


COMMITTED = StudyPaths()
"""The checkout's own results directory (the studies' default)."""


def remove_outputs(files: list[Path], echo: Callable[[str], Any]) -> None:
    """Delete a study's stored HDF5 files (only on an explicit ``fresh``)."""
    for f in files:
        if f.exists():
            f.unlink()
            echo(f"removed {f} (--fresh)")
