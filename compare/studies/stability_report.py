"""Stability study: the README section, generated only from the stored ``/study/cases`` table."""

from __future__ import annotations

import json
import math
import re
from typing import Any

from compare.studies.stability_analysis import AMPLIFICATION_BAND, DEVIATION_LIMIT, SUBCRITICAL
from compare.studies.study_io import rows


def _f(x: Any, fmt: str = ".3g", scale: float = 1.0) -> str:
    try:
        x = float(x)
    except (TypeError, ValueError):
        return str(x)
    return "-" if not math.isfinite(x) else format(scale * x, fmt)


def _qs_peak(r: dict) -> str:
    """Quasi-static peak [mm]; with the peak over the non-flagged angles in parentheses if different."""
    full, kept = _f(r["qs_peak_m"], ".3g", 1e3), _f(r["qs_peak_unflagged_m"], ".3g", 1e3)
    return full if full == kept else f"{full} ({kept})"


def _dynamic(r: dict) -> str:
    if r["status"] == "ok":
        return "converged"
    if r["status"] == "refused":
        return "not run (refused at load)"
    if r["stage"] in ("setup", "frequencies", "quasi_static"):
        return f"not run ({r['stage']})"
    return f"**failed** ({r['stage']}: {r['error_type']})"


def markdown(tables: dict, attrs: dict) -> str:
    """The ``stability`` section of results/README.md."""
    cases = rows(tables.get("cases", {}))
    dd = json.loads(attrs["defaults"]) if isinstance(attrs["defaults"], str) else attrs["defaults"]
    n_ok = sum(1 for r in cases if r["status"] == "ok")
    n_pass = sum(1 for r in cases if r["check"] == "pass")
    lines = [
        "## Numerical stability on stiff and extreme cases",
        "",
        "Regenerate: `ked study stability` (one campaign config per case in `results/studies/stability/`, all "
        "run into `results/studies/stability.h5`; the table below is its `/study/cases` group). Last run: "
        f"{attrs['created_utc']}, {len(cases)} scenes in {len({r['case'] for r in cases})} cases, "
        f"{n_ok} converged ({n_pass} pass the check), {len(cases) - n_ok} failed with a recorded reason, "
        f"{int(attrs.get('lost', 0))} lost; campaign {attrs['campaign_wall_s']:.0f} s on {int(attrs['workers'])} "
        f"workers, whole study {attrs['study_wall_s']:.0f} s. Exudyn settings are the defaults unless the scene "
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
        "| case | scene | r | QS peak mm | QS cond. max | flagged deg | toggle dist. deg | dynamic | cycles | "
        "Newton it. | steps | wall s | dyn. peak mm | ampl. | dev. from default | check | steps needed |",
        "| --- | --- | ---: | ---: | ---: | --- | ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- "
        "| ---: |",
    ]
    for r in cases:
        stable = int(r["stable_steps_per_cycle"])
        lines.append(
            f"| {r['case']} | {r['variant']} | {_f(r['speed_ratio'])} | {_qs_peak(r)} | "
            f"{_f(r['qs_condition_max'], '.3g')} | {r['qs_flagged_deg'] or '-'} | "
            f"{_f(r['qs_toggle_distance_deg'], '.3g')} | {_dynamic(r)} | "
            f"{int(r['dyn_cycles']) if r['dyn_cycles'] >= 0 else '-'} | "
            f"{int(r['dyn_newton_iterations']) if r['dyn_newton_iterations'] >= 0 else '-'} | "
            f"{int(r['dyn_steps']) if r['dyn_steps'] >= 0 else '-'} | {_f(r['dyn_wall_s'], '.2f')} | "
            f"{_f(r['dyn_peak_m'], '.3g', 1e3)} | {_f(r['amplification'], '.3g')} | "
            f"{_f(r['deviation_from_default'], '.2g', 100)}{' %' if math.isfinite(r['deviation_from_default']) else ''}"
            f" | {r['check']} | "
            f"{stable if stable > 0 else 'none' if r['ladder'] else '-'} |")
    failed = [r for r in cases if r["status"] != "ok"]
    if failed:
        lines += ["", "Recorded reasons of the failures:", ""]
        for r in failed:
            extra = f" Step search: {r['ladder']}." if r["ladder"] else ""
            msg = re.sub(r" [(]time=.*[)]$", "", r["message"])
            lines.append(f"* **{r['case']}** ({r['variant']}), stage `{r['stage']}`, `{r['error_type']}`: "
                         f"{msg}.{extra}")
    return "\n".join(lines)
