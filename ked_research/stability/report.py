"""Stability study: the README section, formatted from :class:`StabilityFindings` only."""

from __future__ import annotations

import math
import re

from compare.markdown import Column, num, table
from ked_research.stability.analysis import (
    AMPLIFICATION_BAND,
    DEVIATION_LIMIT,
    SUBCRITICAL,
    StabilityFindings,
    analyse,
)
from ked_research.study_io import rows

COLUMNS = (Column("case"), Column("scene"), Column("r", right=True), Column("QS peak", "mm", True),
           Column("QS cond. max", right=True), Column("flagged", "deg"), Column("toggle dist.", "deg", True),
           Column("dynamic"), Column("cycles", right=True), Column("Newton it.", right=True),
           Column("steps", right=True), Column("wall", "s", True), Column("dyn. peak", "mm", True),
           Column("ampl.", right=True), Column("dev. from default", right=True), Column("check"),
           Column("steps needed", right=True))


def _qs_peak(r: dict) -> str:
    """Quasi-static peak [mm]; with the peak over the non-flagged angles in parentheses if different."""
    full, kept = num(r["qs_peak_m"], ".3g", 1e3), num(r["qs_peak_unflagged_m"], ".3g", 1e3)
    return full if full == kept else f"{full} ({kept})"


def _dynamic(r: dict) -> str:
    if r["status"] == "ok":
        return "converged"
    if r["status"] == "refused":
        return "not run (refused at load)"
    if r["stage"] in ("setup", "frequencies", "quasi_static"):
        return f"not run ({r['stage']})"
    return f"**failed** ({r['stage']}: {r['error_type']})"


def _count(x: int) -> str:
    return str(int(x)) if x >= 0 else "-"


def _cells(r: dict) -> list[str]:
    stable = int(r["stable_steps_per_cycle"])
    dev = r["deviation_from_default"]
    return [r["case"], r["variant"], num(r["speed_ratio"]), _qs_peak(r), num(r["qs_condition_max"]),
            r["qs_flagged_deg"] or "-", num(r["qs_toggle_distance_deg"]), _dynamic(r), _count(r["dyn_cycles"]),
            _count(r["dyn_newton_iterations"]), _count(r["dyn_steps"]), num(r["dyn_wall_s"], ".2f"),
            num(r["dyn_peak_m"], ".3g", 1e3), num(r["amplification"]),
            num(dev, ".2g", 100) + (" %" if math.isfinite(dev) else ""), r["check"],
            str(stable) if stable > 0 else "none" if r["ladder"] else "-"]


def format_findings(f: StabilityFindings) -> str:
    """The ``stability`` section of results/README.md."""
    dd = f.defaults
    lines = [
        "## Numerical stability on stiff and extreme cases",
        "",
        "Regenerate: `ked study stability` (one campaign config per case in `results/studies/stability/`, all "
        "run into `results/studies/stability.h5`; the table below is its `/study/cases` group). Last run: "
        f"{f.created_utc}, {f.scenes} scenes in {f.cases} cases, "
        f"{f.converged} converged ({f.passed} pass the check), {f.failed} failed with a recorded reason, "
        f"{f.lost} lost; campaign {f.campaign_wall_s:.0f} s on {f.workers} "
        f"workers, whole study {f.study_wall_s:.0f} s. Exudyn settings are the defaults unless the scene "
        f"says otherwise ({dd['element'].upper()}, {dd['elements_per_link']} elements/link, {dd['steps_per_cycle']} "
        f"steps/cycle, rho {dd['spectral_radius']:g}, damping ratio {dd['damping_ratio']:g}).",
        "",
        "Quasi-static columns: peak of |dx|, |dy| of P; largest condition number 1/|sin mu| over the 10 deg grid; "
        "crank angles flagged as near-toggle (transmission angle mu within 1 deg of 0/180 deg, `ToggleWarning`); "
        "the smallest distance of mu from a toggle (in parentheses after the peak: the peak over the angles not "
        "flagged). Dynamic columns: outcome, constant-speed cycles, Newton "
        "iterations and time steps in total, wall time, peak, amplification (dynamic peak / quasi-static peak over "
        "the angles not flagged), deviation from the same scene at default settings (max |d - d_default| of dx, dy "
        "over the peak). "
        f"**Check** of a converged result: finite, steady, amplification within {AMPLIFICATION_BAND} when "
        f"r < {SUBCRITICAL} except near a toggle (there the frozen structure is nearly singular over a range of "
        "angles, so the quasi-static peak is no yardstick, and r is meaningless because the lowest frozen "
        "frequency vanishes at the toggle; those cases carry a refined run, more elements and steps, see the "
        "scene column, "
        f"instead), and within {100 * DEVIATION_LIMIT:g} % of the same scene at default settings where "
        "the study has it. **Steps needed**: steps per cycle with which the integration ran through (after a "
        "Newton failure: the first of 2x, 4x, 8x the scene's steps that did).",
        "",
    ]
    lines += table(COLUMNS, [_cells(r) for r in f.rows])
    if f.failures:
        lines += ["", "Recorded reasons of the failures:", ""]
        for r in f.failures:
            extra = f" Step search: {r['ladder']}." if r["ladder"] else ""
            msg = re.sub(r" [(]time=.*[)]$", "", r["message"])
            lines.append(f"* **{r['case']}** ({r['variant']}), stage `{r['stage']}`, `{r['error_type']}`: "
                         f"{msg}.{extra}")
    return "\n".join(lines)


def markdown(tables: dict, attrs: dict) -> str:
    """The ``stability`` section from the stored tables and attributes (load -> analyse -> format)."""
    return format_findings(analyse(rows(tables.get("cases", {})), attrs))
