"""Which lumping made an atlas table: the record of its extender and distributed scenes' lumps per link."""

from __future__ import annotations

ATTR = "lumps_by"
"""Atlas file attribute (JSON: table -> {"lumps", "dynamic_lumps"}): the lumping of the quasi-static and linear
answers of the table's rows (``ked_research.atlas.reconfirm`` confirms again the rows an older lumping made)."""
LEGACY = {"lumps": 5, "dynamic_lumps": None}
"""The lumping of the rows of a table without an :data:`ATTR` entry (5 lumps per link throughout, the default
before it was raised)."""


def lumping() -> dict[str, int | None]:
    """Today's default lumping: lumps per link of the scene and of the linear model's dynamics."""
    from ked_linear.settings import LinearSettings
    from ked_quasi.rules import DEFAULT_LUMPS

    return {"lumps": DEFAULT_LUMPS, "dynamic_lumps": LinearSettings().dynamic_lumps}
