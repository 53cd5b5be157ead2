"""compare.markdown: the study reports' formatting helpers (expected strings by hand)."""

from __future__ import annotations

import math

import numpy as np

from compare.markdown import Column, median_range, num, pct, table


def test_numbers_and_percentages() -> None:
    assert num(0.0012345, ".3g", 1e3) == "1.23" and num(math.nan) == "-" and num("text") == "text"
    assert pct(0.0123) == "1.23 %" and pct(0.5, ".0f") == "50 %" and pct(math.inf) == "-"


def test_median_range_of_the_finite_values() -> None:
    # 0..10: median 5, 10th percentile 1, 90th 9 (linear interpolation); the nan is left out
    assert median_range([*range(11), math.nan]) == "**5.000** [1.000-9.000]"
    assert median_range(np.array([math.nan])) == "-"


def test_table_header_units_alignment_and_rows() -> None:
    lines = table(("case", Column("wall", "s", right=True)), [["a", "1.00"]])
    assert lines == ["| case | wall s |", "| --- | ---: |", "| a | 1.00 |"]
    assert table(("x", "y"), [], dense=True) == ["| x | y |", "|---|---|"]
