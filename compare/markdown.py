"""Markdown formatting for the study reports: numbers, percentages and tables, in one place.

Formatting only: every function takes values already computed (SI units, fractions as [1]) and returns
text; a non-finite number prints as "-".
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np


def num(x: Any, spec: str = ".3g", scale: float = 1.0) -> str:
    """``scale * x`` formatted with ``spec``; "-" if not finite, ``str(x)`` if not a number."""
    try:
        x = float(x)
    except (TypeError, ValueError):
        return str(x)
    return "-" if not math.isfinite(x) else format(scale * x, spec)


def pct(x: float, spec: str = ".3g") -> str:
    """A fraction [1] as a percentage, e.g. ``pct(0.0123) == "1.23 %"``; "-" if not finite."""
    return f"{100 * x:{spec}} %" if math.isfinite(x) else "-"


@dataclass(frozen=True)
class Column:
    """A table column: its name, its unit (appended to the header, e.g. "wall s"; "" for none) and
    whether it is right-aligned (numbers)."""

    name: str
    unit: str = ""
    right: bool = False

    @property
    def header(self) -> str:
        return f"{self.name} {self.unit}" if self.unit else self.name


def table(columns: Sequence[Column | str], rows: Sequence[Sequence[str]], *, dense: bool = False) -> list[str]:
    """A Markdown table: header, alignment line and one line per row of already formatted cells.
    ``dense`` writes the alignment line without spaces (``|---|---|``)."""
    cols = [c if isinstance(c, Column) else Column(c) for c in columns]
    rule = [("---:" if c.right else "---") for c in cols]
    line = "|" + "|".join(rule) + "|" if dense else "| " + " | ".join(rule) + " |"
    return ["| " + " | ".join(c.header for c in cols) + " |", line] + ["| " + " | ".join(r) + " |" for r in rows]


def median_range(values: Any, spec: str = ".3f") -> str:
    """'**median** [P10-P90]' of the finite values; "-" if none."""
    v = np.asarray(values, float)
    v = v[np.isfinite(v)]
    if not v.size:
        return "-"
    p10, p50, p90 = np.percentile(v, [10, 50, 90])
    return f"**{p50:{spec}}** [{p10:{spec}}-{p90:{spec}}]"
