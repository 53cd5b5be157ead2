"""Stress study: the families' limits, the figure and the README section, from the stored rows only."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from compare.limits import Limit, validity_limit
from compare.markdown import num, table
from compare.paths import StudyPaths
from compare.sections import write_section
from ked_research.stress.data import ELEMENTS, MATERIALS, RATIOS, SECTION, TOLERANCE, Row

FIGURE = "stress_limits.png"


@dataclass(frozen=True)
class Family:
    """One family's rows (sorted by r) and its limits: quasi-static deflection and worst-link stress against
    Exudyn, and the linear stress against Exudyn."""

    group: str
    linkage: str
    mechanism: str
    mass_model: str
    rows: tuple[Row, ...]
    deflection: Limit
    stress: Limit
    linear_stress: Limit


def _limit(rows: Sequence[Row], attr: str) -> Limit:
    return validity_limit([r.r for r in rows], [getattr(r, attr) for r in rows],
                          [r.ok and not r.flags for r in rows], TOLERANCE)


def families(rows: Sequence[Row]) -> list[Family]:
    """The rows grouped by family, in stored order."""
    groups: dict[tuple[str, str, str, str], list[Row]] = {}
    for r in rows:
        groups.setdefault((r.group, r.linkage, r.mechanism, r.mass_model), []).append(r)
    out = []
    for (g, lk, mech, mm), rs in groups.items():
        rs = sorted(rs, key=lambda r: r.r)
        out.append(Family(g, lk, mech, mm, tuple(rs), _limit(rs, "deflection_qs"), _limit(rs, "stress_qs"),
                          _limit(rs, "stress_linear")))
    return out


def _lim(lim: Limit) -> str:
    if lim.status == "below_grid":
        return f"< {RATIOS[0]:g}"
    if lim.status == "above_grid":
        return f">= {lim.r_pass:g}"
    if lim.status == "failure":
        return f">= {lim.r_pass:g} (no valid answer at {lim.r_fail:g})" if math.isfinite(lim.r_pass) else "no data"
    return "no data" if lim.status == "no_data" else f"{lim.r_limit:g}"


def _at_deflection_limit(f: Family) -> Row | None:
    """The family's row at its deflection limit (the fastest speed the deflection verdict would grant)."""
    if not math.isfinite(f.deflection.r_limit):
        return None
    return next((r for r in f.rows if r.r == f.deflection.r_limit), None)


def _pct(x: float) -> str:
    return f"{100 * x:.1f} %" if math.isfinite(x) else "-"


def family_table(fams: Sequence[Family]) -> list[str]:
    cols = ("family", "material", "r* deflection (QS)", "r* stress (QS)", "r* stress (linear)",
            "QS stress error at r* deflection", "worst link", "Goodman QS / Exudyn at r* deflection")
    body = []
    for f in fams:
        at = _at_deflection_limit(f)
        over = at.goodman_qs / at.goodman_exudyn if at is not None and at.goodman_exudyn > 0 else math.nan
        body.append([f"{f.linkage} {f.mechanism} {f.mass_model}", f.rows[0].material or "-", _lim(f.deflection),
                     _lim(f.stress), _lim(f.linear_stress), _pct(at.stress_qs) if at else "-",
                     at.worst_link if at else "-", num(over, ".3f") if math.isfinite(over) else "-"])
    return table(cols, body)


def by_mass_model(fams: Sequence[Family]) -> list[str]:
    """Per mass model: families whose stress limit lies below their deflection limit, and the median ratio."""
    cols = ("mass model", "families", "stress limit below deflection limit", "median r* stress / r* deflection",
            "QS stress error at r* deflection (median, max)")
    body = []
    for mm in dict.fromkeys(f.mass_model for f in fams):
        fs = [f for f in fams if f.mass_model == mm]
        both = [(f.stress.r_limit, f.deflection.r_limit) for f in fs
                if math.isfinite(f.stress.r_limit) and math.isfinite(f.deflection.r_limit)]
        below = sum(1 for f in fs if _below(f))
        errs = [r.stress_qs for f in fs if (r := _at_deflection_limit(f)) is not None and math.isfinite(r.stress_qs)]
        ratio = float(np.median([s / d for s, d in both])) if both else math.nan
        body.append([mm, str(len(fs)), str(below), num(ratio, ".2f") if math.isfinite(ratio) else "-",
                     f"{_pct(float(np.median(errs)))}, {_pct(max(errs))}" if errs else "-"])
    return table(cols, body)


def _below(f: Family) -> bool:
    """Whether the stress's first crossing comes at a lower grid ratio than the deflection's."""
    s = f.stress.r_fail if f.stress.status in ("crossed", "below_grid") else math.inf
    d = f.deflection.r_fail if f.deflection.status in ("crossed", "below_grid") else math.inf
    return s < d


def figure(fams: Sequence[Family]) -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    groups = [g for g in ("thesis", "simeon", "atlas") if any(f.group == g for f in fams)]
    fig, axes = plt.subplots(1, len(groups), figsize=(5.2 * len(groups), 4.2), squeeze=False)
    colors = {"tip": "C0", "joints": "C1", "extender": "C2", "distributed": "C3"}
    for ax, g in zip(axes[0], groups):
        for f in (f for f in fams if f.group == g):
            r = np.array([x.r for x in f.rows])
            ok = np.array([x.ok and not x.flags for x in f.rows])
            c = colors.get(f.mass_model, "k")
            ls = "-" if f.mechanism == "source" else ":"
            valid = np.where(ok, 1.0, np.nan)  # an answer without a valid reference is not drawn as a value
            ax.plot(r, valid * [x.stress_qs * 100 for x in f.rows], ls, color=c, marker="o", ms=3)
            ax.plot(r, valid * [x.deflection_qs * 100 for x in f.rows], ls, color=c, alpha=0.45)
            bad = ~ok
            if bad.any():
                ax.plot(r[bad], np.zeros(bad.sum()), "x", color="k")
        ax.axhline(TOLERANCE * 100, color="k", lw=0.8)
        ax.set_xlabel("speed ratio r = Omega / omega1,min")
        ax.set_ylabel("quasi-static error against Exudyn [%]")
        ax.set_ylim(0, 40)
        ax.set_title(g)
    handles = [plt.Line2D([], [], color=c, label=m) for m, c in colors.items()]
    handles += [plt.Line2D([], [], color="k", marker="o", ms=3, label="stress (worst link)"),
                plt.Line2D([], [], color="k", alpha=0.45, label="coupler-point deflection"),
                plt.Line2D([], [], color="k", ls=":", label="cognate (solid: source)"),
                plt.Line2D([], [], color="k", marker="x", ls="", label="no valid Exudyn answer")]
    axes[0][0].legend(handles=handles, fontsize=7)
    fig.tight_layout()
    return fig


def section(rows: Sequence[Row], fams: Sequence[Family]) -> str:
    n_ok = sum(r.ok and not r.flags for r in rows)
    wall = sum(r.wall_s for r in rows) / 60
    mats = "; ".join(f"{k}: {v.source}" for k, v in MATERIALS.items())
    lines = [
        "## Link stresses: where the quasi-static stress holds",
        "",
        f"Regenerate: `ked study stress` (resumable; stored: `studies/stress.h5`, {len(rows)} scenes, {n_ok} with a "
        f"valid Exudyn answer; solver time stored {wall:.0f} CPU-min). Every scene solved by the quasi-static, linear "
        "and Exudyn tiers (Exudyn: `DynamicSettings()` defaults, 720 steps per cycle from the ramp, with "
        f"{ELEMENTS} beam elements per link, the link "
        "stresses from the beam elements' own section forces over one more steady cycle). Errors against Exudyn: the "
        "coupler point's vector history error, and per link max |sigma - sigma_Exudyn| of the largest and smallest "
        "fibre stress over the Exudyn peak of that link (a scene's stress error: its worst link's). Limits: first "
        f"crossings of {TOLERANCE:.0%} on r = {', '.join(f'{r:g}' for r in RATIOS)} (a scene without a valid answer "
        "ends the walk: Exudyn's beyond the small-deflection range, or no linear stress where the linear steady state "
        "of the masses is not resolved). Per-family rows: the tiers' measured errors; no margin, no calibration.",
        "",
        "**Per mass model** (every family of the thesis linkage, Simeon's slider-crank and the atlas sample):",
        "",
        *by_mass_model(fams),
        "",
        "**Per family.** Goodman: the smallest safety factor over the links, quasi-static over Exudyn's (above 1: "
        f"the quasi-static factor is optimistic). Materials (unmodified endurance limits): {mats}.",
        "",
        *family_table(fams),
        "",
        f"![stress limits](figures/{FIGURE})",
    ]
    return "\n".join(lines)


def write_report(rows: Sequence[Row], paths: StudyPaths) -> dict[str, Any]:
    """Figure and README section from the stored rows."""
    from ked_research.study_io import save_figures

    fams = families(rows)
    figs = save_figures({FIGURE: figure(fams)}, paths.figures, 110)
    write_section(paths.readme, SECTION, section(rows, fams))
    return {"figures": [str(p) for p in figs], "readme": str(paths.readme), "families": len(fams)}
