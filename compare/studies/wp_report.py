"""Work-precision study: figures and the README section, drawn only from the stored ``/study`` tables.

Input: ``tables`` (table -> column -> array) and ``attrs`` as returned by
:func:`compare.studies.study_io.read_tables`. Errors are relative [1] (printed in %), wall times [s].
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import json

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from compare.studies.study_io import rows  # noqa: E402
from compare.studies.wp_analysis import (  # noqa: E402
    TARGETS,
    TIE,
    Discretization,
    WPPoint,
    choose,
    coarsest_failures,
    observed_order,
    pareto_mask,
    summary,
)
from ked_linear import UNRESOLVED_ESTIMATE

DPI = 100
LINEAR_COLOR = "teal"
EPL_COLORS = {1: "tab:blue", 2: "tab:orange", 4: "tab:green", 8: "tab:red", 16: "tab:purple"}
MASS_MODELS = ("tip", "joints", "extender", "distributed")


def wp_points(tables: dict[str, dict[str, np.ndarray]]) -> list[WPPoint]:
    """The ``dynamic`` table as :class:`WPPoint` records."""
    out = []
    for r in rows(tables.get("dynamic", {})):
        disc = Discretization(r["disc_element"], int(r["disc_elements_per_link"]), int(r["disc_steps_per_cycle"]),
                              float(r["disc_spectral_radius"]))
        out.append(WPPoint(r["family"], disc, bool(r["reference"]), bool(r["ok"]), float(r["wall_s"]),
                           int(r["repeats"]), float(r["error"]), int(r["cycles"]), int(r["newton_iterations"]),
                           str(r["message"]), float(r.get("wall_spread", 0.0))))
    return out


def default_disc(attrs: dict[str, Any]) -> Discretization:
    d = attrs["defaults"]
    d = json.loads(d) if isinstance(d, str) else d
    return Discretization(d["element"], int(d["elements_per_link"]), int(d["steps_per_cycle"]),
                          float(d["spectral_radius"]))


def families(points: Sequence[WPPoint]) -> list[str]:
    return sorted({p.family for p in points if not p.reference},
                  key=lambda f: (MASS_MODELS.index(f.split()[0]) if f.split()[0] in MASS_MODELS else 9, f))


def front(points: Sequence[WPPoint], family: str) -> list[WPPoint]:
    """Pareto front of one family's dynamic runs (cheapest first)."""
    pts = [p for p in points if p.family == family and not p.reference and p.ok and p.error > 0]
    mask = pareto_mask([p.wall_s for p in pts], [p.error for p in pts])
    return sorted((p for p, m in zip(pts, mask) if m), key=lambda p: p.wall_s)


def _marker(d: Discretization) -> str:
    if d.element == "gebeam":
        return "s"
    return {0.6: "v", 1.0: "^"}.get(d.spectral_radius, "o")


def work_precision_figure(tables: dict, attrs: dict) -> Figure:
    """One panel per mass model: every dynamic run (error vs wall time), its Pareto front, the current
    default, and the quasi-static solver and the linear KED model at each speed ratio against the dynamic
    reference."""
    points, dflt = wp_points(tables), default_disc(attrs)
    quasi = rows(tables.get("quasi_static", {}))
    linear = rows(tables.get("linear", {}))
    models = [m for m in MASS_MODELS if any(q["mass_model"] == m for q in quasi + linear)
              or any(p.family.split()[0] == m for p in points)]
    fig = Figure(figsize=(11, 8.2))
    axes = fig.subplots(2, 2).ravel()
    for ax, model in zip(axes, models):
        fams = [f for f in families(points) if f.split()[0] == model]
        for fam in fams:
            pts = [p for p in points if p.family == fam and not p.reference and p.ok and p.error > 0]
            series: dict[tuple, list[WPPoint]] = {}
            for p in pts:
                series.setdefault((p.disc.element, p.disc.elements_per_link, p.disc.spectral_radius), []).append(p)
            for (el, epl, _rho), ser in sorted(series.items()):
                ser.sort(key=lambda p: p.disc.steps_per_cycle)
                ax.plot([p.wall_s for p in ser], [p.error for p in ser], _marker(ser[0].disc) + "-",
                        color=EPL_COLORS.get(epl, "gray"), ms=4, lw=0.8, alpha=0.8,
                        mfc="none" if el == "gebeam" else EPL_COLORS.get(epl, "gray"))
            fr = front(points, fam)
            ax.step([p.wall_s for p in fr], [p.error for p in fr], "k-", where="post", lw=1.4, zorder=3)
            ax.plot([p.wall_s for p in fr], [p.error for p in fr], "o", mfc="none", mec="k", ms=9, zorder=3)
            for p in pts:
                if p.disc == dflt:
                    ax.plot(p.wall_s, p.error, "*", color="gold", mec="k", ms=16, zorder=4)
        qs = sorted((q for q in quasi if q["mass_model"] == model), key=lambda q: q["speed_ratio"])
        if qs:
            ax.plot([q["wall_s"] for q in qs], [q["error"] for q in qs], "D", color="crimson", ms=6, zorder=4)
            for q in qs:
                ax.annotate(f"QS r={q['speed_ratio']:.2g}", (q["wall_s"], q["error"]), fontsize=7,
                            xytext=(4, 2), textcoords="offset points", color="crimson")
        lin = sorted((q for q in linear if q["mass_model"] == model and math.isfinite(q["error"])),
                     key=lambda q: q["speed_ratio"])
        if lin:
            ax.plot([q["wall_s"] for q in lin], [q["error"] for q in lin], "X", color=LINEAR_COLOR, mec="k",
                    mew=0.5, ms=8, zorder=5)
            for q in lin:
                ax.annotate(f"lin r={q['speed_ratio']:.2g}", (q["wall_s"], q["error"]), fontsize=7,
                            xytext=(4, -8), textcoords="offset points", color=LINEAR_COLOR)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlim(3e-4, 200.0)
        ax.set_ylim(1e-4, 3.0)
        title = model + (f" ({', '.join(f.split(' ', 1)[1] for f in fams)})" if fams else " (quasi-static only)")
        ax.set_title(title, fontsize=10)
        ax.grid(True, which="both", alpha=0.25)
        ax.set_xlabel("wall time [s]")
        ax.set_ylabel("error vs dynamic reference [1]")
    for ax in axes[len(models):]:
        ax.set_visible(False)
    from matplotlib.lines import Line2D

    handles = [Line2D([], [], color=c, marker="o", ls="-", label=f"ANCF {n} el/link") for n, c in EPL_COLORS.items()
               if n <= 8]
    handles += [Line2D([], [], color="gray", marker="s", mfc="none", ls="-", label="GE beam (colour: el/link)"),
                Line2D([], [], color="gray", marker="v", ls="-", label="ANCF rho 0.6"),
                Line2D([], [], color="gray", marker="^", ls="-", label="ANCF rho 1.0"),
                Line2D([], [], color="k", marker="o", mfc="none", ms=9, ls="-", label="Pareto front"),
                Line2D([], [], color="gold", mec="k", marker="*", ms=14, ls="", label="current default"),
                Line2D([], [], color="crimson", marker="D", ls="", label="quasi-static"
                       + _lumps_label(rows(tables.get("quasi_static", {}))))]
    if rows(tables.get("linear", {})):
        handles.append(Line2D([], [], color=LINEAR_COLOR, mec="k", mew=0.5, marker="X", ms=8, ls="",
                              label="linear KED" + _lumps_label(rows(tables["linear"]))))
    fig.legend(handles=handles, loc="lower center", ncol=(len(handles) + 1) // 2, fontsize=8, frameon=False)
    fig.suptitle("Work-precision: steady-cycle error vs wall time (points along a line: 90..2880 steps/cycle)",
                 fontsize=11)
    fig.subplots_adjust(left=0.07, right=0.98, top=0.93, bottom=0.14, hspace=0.32, wspace=0.22)
    return fig


def _lumps_label(table: list[dict]) -> str:
    """`` (n lumps)`` for the lumps per link of a fast solver's scenes (one value), else ""."""
    lumps = {int(r["lumps"]) for r in table}
    return f" ({lumps.pop()} lumps)" if len(lumps) == 1 else ""


def lumps_figure(tables: dict) -> Figure:
    """Quasi-static lumps convergence: error vs lumps per link, and error vs solve time."""
    lp = rows(tables.get("lumps", {}))
    fig = Figure(figsize=(10, 4))
    a1, a2 = fig.subplots(1, 2)
    series: dict[tuple[str, str], list[dict]] = {}
    for r in lp:
        series.setdefault((r["model"], r["placement"]), []).append(r)
    for (model, placement), ser in sorted(series.items()):
        ser.sort(key=lambda r: r["lumps"])
        style = "-" if placement == "midpoint" else "--"
        color = "tab:blue" if model == "extender" else "tab:red"
        n = [r["lumps"] for r in ser]
        e = [max(r["error"], 1e-16) for r in ser]
        a1.plot(n, e, "o" + style, color=color, ms=4, label=f"{model}, {placement}")
        a2.plot([1e3 * r["wall_s"] for r in ser], e, "o", color=color, ms=4,
                mfc=color if placement == "midpoint" else "none", label=f"{model}, {placement}")
    ref = int(lp[0]["reference_lumps"]) if lp else 0
    for ax in (a1, a2):
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.grid(True, which="both", alpha=0.25)
        ax.set_ylabel(f"error vs {ref} lumps [1]")
    a1.set_xlabel("lumps per link")
    a2.set_xlabel("quasi-static solve time, 36 crank angles, median [ms]")
    a1.legend(fontsize=8)
    fig.suptitle("Quasi-static solver: lumps convergence (thesis source linkage)", fontsize=11)
    fig.subplots_adjust(left=0.08, right=0.98, top=0.88, bottom=0.14, wspace=0.28)
    return fig


def write_figures(tables: dict, attrs: dict, out_dir: Path) -> list[Path]:
    """Draw both figures into ``out_dir``; returns their paths."""
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, fig in (("work_precision.png", work_precision_figure(tables, attrs)),
                      ("work_precision_lumps.png", lumps_figure(tables))):
        p = out_dir / name
        fig.savefig(p, dpi=DPI)
        plt.close(fig)
        paths.append(p)
    return paths


def _pct(x: float) -> str:
    if not math.isfinite(x):
        return "-"
    return f"{100 * x:.3g} %"


def _disc(d: Discretization) -> str:
    el = "ANCF" if d.element == "ancf" else "GE beam"
    return f"{el} {d.elements_per_link} el, {d.steps_per_cycle} st, rho {d.spectral_radius:g}"


def markdown(tables: dict, attrs: dict, figures: Sequence[Path], base: Path) -> str:
    """The README section (every number from ``tables``/``attrs``)."""
    points, dflt = wp_points(tables), default_disc(attrs)
    fams = families(points)
    ref = attrs["reference"]
    ref = json.loads(ref) if isinstance(ref, str) else ref
    dd = json.loads(attrs["defaults"]) if isinstance(attrs["defaults"], str) else attrs["defaults"]
    ref_disc = Discretization(ref["element"], int(ref["elements_per_link"]), int(ref["steps_per_cycle"]),
                              float(ref["spectral_radius"]))
    transient = ", ".join(f"{_pct(p.error)} ({p.family})" for p in points
                          if p.disc == ref_disc and not p.reference and p.ok) or "-"
    rel = [os.path.relpath(p, base) for p in figures]
    n_fail = sum(1 for p in points if not p.ok)
    spreads = [p.wall_spread for p in points if p.repeats > 1]
    updated = json.loads(attrs.get("updated_tables", "[]"))
    lines = [
        "## Error against run time (work-precision)",
        "",
        "Regenerate: `ked study work-precision` (configs `results/studies/work_precision.toml`, "
        "`work_precision_quasi.toml`, `work_precision_refcheck.toml`; results `results/studies/work_precision.h5`, "
        f"derived tables in its `/study` group). Last run: {attrs['created_utc']}, {int(attrs['scenes'])} scenes, "
        f"campaign {attrs['campaign_wall_s'] / 60:.1f} min on {int(attrs['workers'])} workers, whole study "
        f"{attrs['study_wall_s'] / 60:.1f} min."
        + (f" Table{'s' if len(updated) > 1 else ''} {', '.join(f'`{t}`' for t in updated)} added "
           f"{attrs['updated_utc']} ({attrs['updated_wall_s'] / 60:.1f} min), the others kept." if updated else ""),
        "",
        f"![work-precision]({rel[0]})",
        "",
        "**Set-up.** Thesis source four-bar, 2 % damping, speed ratio Omega/omega1_min = "
        + ", ".join(sorted({f.split(' ', 1)[1] for f in fams}))
        + f" for the mass models {', '.join(f.split()[0] for f in fams)}. "
        "Every combination of element type (ANCF cable, geometrically exact beam), elements per link, steps per "
        "crank cycle and generalized-alpha spectral radius in `work_precision.toml`; the settings not studied are "
        f"pinned to the current defaults (ramp {dd['ramp_cycles']:g} cycle, steady to {dd['steady_tol']:g}"
        f"{' with extrapolation' if dd['extrapolate'] else ''}). "
        "**Error** of the returned steady cycle on the 10 deg grid: max |d - d_ref| of (dx, dy) relative to the "
        "reference peak of |dx|, |dy|, and of the rotation relative to its peak; the larger of the two. It "
        f"includes the transient left by the steady-state criterion: at the reference's own discretization the "
        f"default tolerance alone gives {transient}. "
        f"**Reference**: {ref['element'].upper()} {ref['elements_per_link']} elements/link, {ref['steps_per_cycle']} "
        f"steps/cycle, rho {ref['spectral_radius']:g}, steady to {ref['steady_tol']:g}. "
        f"**Wall time**: the dynamic solver's whole run; runs under {attrs['retime_below_s']:g} s in the campaign "
        f"({len(spreads)} runs) are the median of 3 (campaign run + 2 serial repeats), longer ones a single "
        f"campaign run ({int(attrs['workers'])} workers on 2 cores shared with other jobs). The 3 timings of a "
        f"run differ by {_pct(float(np.median(spreads)) if spreads else math.nan)} (median of (max - min) / "
        "median), which is the noise level of the times.",
    ]
    for r in rows(tables.get("refcheck", {})):
        lines.append("")
        lines.append(f"Reference check ({r['family']}): ANCF {int(r['elements_per_link'])} el/link and "
                     f"{int(r['steps_per_cycle'])} steps/cycle differ from the reference by {_pct(r['error'])} "
                     f"({r['wall_s']:.0f} s); errors below about that are not resolved.")
    lines += ["", "Pareto front per scene (cheapest first):", "",
              "| scene | discretization | wall s | error |", "| --- | --- | ---: | ---: |"]
    for fam in fams:
        for p in front(points, fam):
            lines.append(f"| {fam} | {_disc(p.disc)} | {p.wall_s:.2f} | {_pct(p.error)} |")
    lines += ["", "Cheapest discretization within an error budget on **every** scene (wall time summed over the "
              f"{len(fams)} scenes):", "", "| budget | discretization | total wall s | worst error |",
              "| ---: | --- | ---: | ---: |"]
    choices = [choose(points, t, len(fams)) for t in TARGETS]
    for c in choices:
        lines.append(f"| {_pct(c.target)} | {_disc(c.disc) if c.disc else 'none'} | "
                     f"{c.total_wall_s:.2f} | {_pct(c.worst_error)} |")
    cur = summary(points, dflt, len(fams))
    on_front = [fam for fam in fams if any(p.disc == dflt for p in front(points, fam))]
    if cur is not None:
        lines.append(f"| current default | {_disc(dflt)} | {cur[0]:.2f} | {_pct(cur[1])} |")
    lines += ["", _verdict(choices, dflt, cur, on_front, fams, points)]
    if n_fail:
        lines += ["", f"Failed dynamic runs ({n_fail}, not plotted):", ""]
        for p in points:
            if not p.ok:
                lines.append(f"* {p.family}, {_disc(p.disc)}: {re.sub(r' [(]time=.*[)]$', '', p.message)}")
    quasi = rows(tables.get("quasi_static", {}))
    lines += ["", "**Quasi-static solver on the same axes** (red diamonds): solve time (median of 21, 36 crank "
              "angles) and error against the dynamic reference of the same scene. Its error is the "
              "instantaneous-structure (model) error, which no discretization removes; it grows with the speed "
              "ratio. This is the trade: milliseconds and the error below, or the dynamic model's seconds and "
              f"(at the default discretization) at most {_pct(cur[1]) if cur else '-'} on the scenes above.", "",
              "| mass model | r | quasi-static error | QS time ms | dynamic reference s | QS peak mm "
              "| dynamic peak mm |",
              "| --- | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for q in quasi:
        lines.append(f"| {q['mass_model']} | {q['speed_ratio']:.3g} | {_pct(q['error'])} | {1e3 * q['wall_s']:.2f} | "
                     f"{q['dynamic_wall_s']:.1f} | {1e3 * q['qs_peak_m']:.3g} | {1e3 * q['dyn_peak_m']:.3g} |")
    lines += _linear_lines(rows(tables.get("linear", {})), quasi, points)
    lines += _lumps_lines(tables, rel[1] if len(rel) > 1 else "")
    return "\n".join(lines)


def _ms(x: float) -> str:
    """Milliseconds, 3 significant digits (whole ms from 1 s on)."""
    if not math.isfinite(x):
        return "-"
    return f"{1e3 * x:.3g}" if x < 1.0 else f"{1e3 * x:.0f}"


def _family_ratio(family: str) -> float:
    """The speed ratio of a family label (``tip r=0.3``), nan if it has none."""
    m = re.search(r"r=([0-9.eE+-]+)", family)
    return float(m.group(1)) if m else math.nan


def _linear_lines(linear: list[dict], quasi: list[dict], points: Sequence[WPPoint]) -> list[str]:
    """Where the linear KED model sits: a paragraph over all scenes (against the quasi-static solver, and
    against the cheapest dynamic run as accurate on the scenes with dynamic runs) and a row per mass model."""
    if not linear:
        return []
    qs = {(q["mass_model"], f"{q['speed_ratio']:.3g}"): q for q in quasi}
    pairs = [(r, qs.get((r["mass_model"], f"{r['speed_ratio']:.3g}"))) for r in linear]
    pairs = [(r, q) for r, q in pairs if q is not None]
    better = sum(1 for r, q in pairs if r["error"] < q["error"])
    ratio = float(np.median([r["error"] / q["error"] for r, q in pairs if q["error"] > 0])) if pairs else math.nan
    zetas = sorted({r["damping_ratio"] for r in linear})
    reps = sorted({int(r["repeats"]) for r in linear})
    walls = [r["wall_s"] for r in linear]
    spread = float(np.median([r.get("wall_spread", math.nan) for r in linear]))
    unstable = [r for r in linear if not r["stable"]]
    loose = [r for r in linear if r["stable"] and not r["error_estimate"] <= UNRESOLVED_ESTIMATE]
    ratios = sorted({f"{r['speed_ratio']:.2g}" for r in linear}, key=float)
    text = (f"**Linear KED model on the same axes** ({LINEAR_COLOR} crosses): `ked_linear.solve_linear` with the "
            f"scene's damping ratio ({', '.join(f'{z:g}' for z in zetas)}) and its default resolution; solve time "
            f"the median of {reps[-1]} solves"
            + (f" ({reps[0]} where one solve takes over a second)" if len(reps) > 1 else "") + ", error against "
            f"the same dynamic reference with the same measure. Over the {len(linear)} scenes its median solve time "
            f"is {_ms(float(np.median(walls)))} ms ({_ms(min(walls))} to {_ms(max(walls))} ms) against "
            f"{_ms(float(np.median([q['wall_s'] for q in quasi]))) if quasi else '-'} ms for the quasi-static "
            f"solver and {float(np.median([r['dynamic_wall_s'] for r in linear])):.1f} s for the dynamic reference "
            f"(the timings of a scene differ by {_pct(spread)}"
            ", median of (max - min) / median); "
            f"its error is below the quasi-static one on {better} of {len(pairs)} scenes (median ratio "
            f"{ratio:.2g}).")
    if unstable:
        text += (" No stable periodic steady state (Floquet) on: "
                 + ", ".join(f"{r['mass_model']} r={r['speed_ratio']:.2g}" for r in unstable) + ".")
    if loose:
        text += (f" Its own error estimate exceeds {_pct(UNRESOLVED_ESTIMATE)} (flagged unresolved) on: "
                 + ", ".join(f"{r['mass_model']} r={r['speed_ratio']:.2g} ({_pct(r['error_estimate'])})"
                             for r in loose) + ".")
    matched = []
    for r in linear:
        fam = [p for p in points if not p.reference and p.ok and p.family.split()[0] == r["mass_model"]
               and math.isclose(_family_ratio(p.family), r["speed_ratio"], rel_tol=1e-6)]
        if fam and math.isfinite(r["error"]):
            good = [p.wall_s for p in fam if p.error <= r["error"]]
            matched.append(f"{fam[0].family} {min(good):.2f} s" if good else f"{fam[0].family} none")
            matched[-1] += f" (linear {r['wall_s']:.2f} s)"
    if matched:
        text += (" The cheapest dynamic run at least as accurate as the linear model on the same scene takes "
                 + ", ".join(matched) + ".")
    r_head = " / ".join(ratios)
    out = ["", text, "", f"| mass model | linear error, r = {r_head} | quasi-static error | linear time ms "
           "| dynamic reference s |", "| --- | ---: | ---: | ---: | ---: |"]
    for model in [m for m in MASS_MODELS if any(r["mass_model"] == m for r in linear)]:
        by_r = {f"{r['speed_ratio']:.2g}": (r, q) for r, q in
                [(r, qs.get((r["mass_model"], f"{r['speed_ratio']:.3g}"))) for r in linear if r["mass_model"] == model]}
        cell = [by_r.get(k) for k in ratios]
        out.append(f"| {model} | " + " / ".join(_pct(c[0]["error"]) if c else "" for c in cell)
                   + " | " + " / ".join(_pct(c[1]["error"]) if c and c[1] else "" for c in cell)
                   + " | " + " / ".join(_ms(c[0]["wall_s"]) if c else "" for c in cell)
                   + " | " + " / ".join(f"{c[0]['dynamic_wall_s']:.1f}" if c else "" for c in cell) + " |")
    return out


def _verdict(choices, dflt: Discretization, cur, on_front: list[str], fams: list[str], points) -> str:
    c1 = choices[0]
    if c1.disc is None or cur is None:
        return "**Default.** Not enough data to judge the default (see failures)."
    text = (f"**Default.** The current default ({_disc(dflt)}) costs {cur[0]:.2f} s over the {len(fams)} scenes "
            f"with a worst error of {_pct(cur[1])}; it is on the Pareto front of "
            f"{len(on_front)} of {len(fams)} scenes{(' (' + ', '.join(on_front) + ')') if on_front else ''}. ")
    tied = ", ".join(_disc(d) for d in c1.tied)
    if c1.disc == dflt:
        text += f"The data support it: it is the cheapest setting within the {_pct(c1.target)} budget"
        text += f" (within the {100 * TIE:g} % timing noise of it: {tied})." if tied else "."
    elif dflt in c1.tied:
        text += (f"The data support it: within the {_pct(c1.target)} budget it ties (within the {100 * TIE:g} % "
                 f"timing noise) with the cheapest, {_disc(c1.disc)} ({c1.total_wall_s:.2f} s, worst "
                 f"{_pct(c1.worst_error)}).")
    else:
        ratio = cur[0] / c1.total_wall_s
        text += (f"The cheapest setting within the {_pct(c1.target)} budget is {_disc(c1.disc)} "
                 f"({c1.total_wall_s:.2f} s, worst {_pct(c1.worst_error)}; the default takes {ratio:.2f}x its "
                 "time). ")
        text += ("The default also meets the budget." if cur[1] <= c1.target
                 else "The default does not meet that budget on every scene.")
    fails = coarsest_failures(points)
    same = {k: v for k, v in fails.items() if k[0] == dflt.element and k[1] == dflt.elements_per_link}
    if same:
        worst_steps = same.get((dflt.element, dflt.elements_per_link, dflt.spectral_radius), 1)
        text += (f" Robustness ({dflt.element.upper()} {dflt.elements_per_link} el/link): the most steps per cycle "
                 "at which a run still failed (Newton) on some scene: "
                 + ", ".join(f"rho {k[2]:g}: {v}" for k, v in sorted(same.items()))
                 + f"; the default's {dflt.steps_per_cycle} steps leave a margin of "
                 f"{dflt.steps_per_cycle / worst_steps:g}x"
                 " at its spectral radius.")
    return text


def _lumps_lines(tables: dict, fig: str) -> list[str]:
    lp = [dict(r, lumps=int(r["lumps"]), reference_lumps=int(r["reference_lumps"]))
          for r in rows(tables.get("lumps", {}))]
    if not lp:
        return []
    ref = lp[0]["reference_lumps"]
    ns = sorted({r["lumps"] for r in lp})
    series: dict[tuple[str, str], dict[int, dict]] = {}
    for r in lp:
        series.setdefault((r["model"], r["placement"]), {})[r["lumps"]] = r
    out = ["", "**Quasi-static discretization**: lumps per link in the extender and distributed models "
           f"(`MassModel(lumps=n, placement=...)`) against n = {ref}. The relative error does not depend on the "
           "crank speed (every load scales with omega^2).", "", f"![lumps]({fig})", "",
           "| model, placement | " + " | ".join(f"n={n}" for n in ns) + " | order |",
           "| --- | " + " | ".join("---:" for _ in ns) + " | ---: |"]
    for (model, placement), d in sorted(series.items()):
        order = observed_order([n for n in ns if n in d], [d[n]["error"] for n in ns if n in d])
        out.append(f"| {model}, {placement} | " + " | ".join(_pct(d[n]["error"]) if n in d else "" for n in ns)
                   + f" | {order:.2f} |")
    walls = [r["wall_s"] for r in lp if r["model"] == "distributed" and r["placement"] == "midpoint"]
    first = {r["lumps"]: r for r in lp if r["model"] == "distributed" and r["placement"] == "midpoint"}
    if walls:
        out += ["", f"Solve time (distributed, midpoint): {1e3 * first[ns[0]]['wall_s']:.2f} ms at n={ns[0]}, "
                f"{1e3 * first[5]['wall_s'] if 5 in first else float('nan'):.2f} ms at n=5, "
                f"{1e3 * first[ns[-1]]['wall_s']:.2f} ms at n={ns[-1]}."]
    out += _lumps_advice(series, ns)
    return out


def _lumps_advice(series: dict, ns: list[int]) -> list[str]:
    lines = []
    for (model, placement), d in sorted(series.items()):
        for target in (0.01, 0.001):
            n_ok = next((n for n in ns if d.get(n) and d[n]["error"] <= target), None)
            lines.append(f"* {model}, {placement}: {'n = ' + str(n_ok) if n_ok else 'more than ' + str(ns[-1])} "
                         f"lumps for {_pct(target)}")
    return ["", "Lumps needed:", ""] + lines
