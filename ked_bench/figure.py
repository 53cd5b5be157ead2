"""The slider-crank benchmark's validity figure: each tier's midspan history error against Simeon's reference
per speed ratio r = Omega / omega1 (``ked benchmark simeon --figure PATH``; matplotlib object API, Agg)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

CURVES = (
    ("quasi_static_error", "quasi-static vs reference (linear stiffness)", "o-", "C0"),
    ("linear_error", "linear KED, no prestress vs reference (linear stiffness)", "s-", "C1"),
    ("dynamic_error", "Exudyn vs reference (linear stiffness)", "^--", "C2"),
    ("linear_prestressed_error_geometric", "linear KED, prestressed vs reference (geometric stiffness)", "D:", "C4"),
    ("dynamic_error_geometric", "Exudyn vs reference (geometric stiffness)", "v-", "C3"),
)
"""(key of a ``speeds`` row, legend label, line style, colour) of each curve."""


def write_validity_figure(rows: list[dict[str, Any]], path: str | Path) -> Path:
    """Draw the per-speed history errors [%] of ``rows`` (the ``speeds`` list of ``ked benchmark simeon
    --json``) against r on a log axis, with the 2 % target line, into the PNG ``path``; returns it."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(7.5, 4.8))
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    for key, label, style, colour in CURVES:
        pts = [(r["speed_ratio"], 100.0 * r[key]) for r in rows if r.get(key) is not None]
        if pts:
            ax.plot(*zip(*pts), style, color=colour, label=label, markersize=4)
    ax.axhline(2.0, color="0.4", lw=0.8, ls="--")
    ax.text(rows[0]["speed_ratio"] if rows else 0.02, 2.15, "2 %", color="0.3", fontsize=8)
    ax.set_yscale("log")
    ax.set_xlabel("speed ratio r = crank speed / rod's first bending frequency")
    ax.set_ylabel("midspan history error [% of reference peak]")
    ax.set_title("Simeon's flexible slider-crank: tiers against the reference (damped steady state)",
                 fontsize=9)
    ax.grid(True, which="both", lw=0.3)
    ax.legend(fontsize=7, loc="upper left")
    fig.tight_layout()
    out = Path(path)
    fig.savefig(out, dpi=120)
    return out
