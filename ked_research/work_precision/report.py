"""Work-precision study: figures and the README section, drawn only from the stored ``/study`` tables.

Input: ``tables`` (table -> column -> array) and ``attrs`` as returned by
:func:`ked_research.study_io.read_tables`. Errors are relative [1] (printed in %), wall times [s].
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

from matplotlib.figure import Figure  # noqa: E402

from compare.markdown import Column, pct, table  # noqa: E402
from ked_linear import UNRESOLVED_ESTIMATE
from ked_research.study_io import rows, save_figures  # noqa: E402
from ked_research.work_precision.analysis import (  # noqa: E402
    MASS_MODELS,
    TIE,
    DefaultFindings,
    Discretization,
    LinearFindings,
    LumpsFindings,
    WPFindings,
    WPPoint,
    analyse,
    disc_of,
    families,
    front,
    wp_points,
)

DPI = 100
LINEAR_COLOR = "teal"
EPL_COLORS = {1: "tab:blue", 2: "tab:orange", 4: "tab:green", 8: "tab:red", 16: "tab:purple"}


def _marker(d: Discretization) -> str:
    if d.element == "gebeam":
        return "s"
    return {0.6: "v", 1.0: "^"}.get(d.spectral_radius, "o")


def work_precision_figure(tables: dict, attrs: dict) -> Figure:
    """One panel per mass model: every dynamic run (error vs wall time), its Pareto front, the current
    default, and the quasi-static solver and the linear KED model at each speed ratio against the dynamic
    reference."""
    points, dflt = wp_points(tables), disc_of(attrs["defaults"])
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
        for tab, name, dy, fmt, kw in ((quasi, "QS", 2, "D", dict(color="crimson", ms=6, zorder=4)),
                                       (linear, "lin", -8, "X", dict(color=LINEAR_COLOR, mec="k", mew=0.5, ms=8,
                                                                     zorder=5))):
            pts = sorted((q for q in tab if q["mass_model"] == model and (name == "QS" or math.isfinite(q["error"]))),
                         key=lambda q: q["speed_ratio"])
            if pts:
                ax.plot([q["wall_s"] for q in pts], [q["error"] for q in pts], fmt, **kw)
            for q in pts:
                ax.annotate(f"{name} r={q['speed_ratio']:.2g}", (q["wall_s"], q["error"]), fontsize=7,
                            xytext=(4, dy), textcoords="offset points", color=kw["color"])
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
                Line2D([], [], color="crimson", marker="D", ls="", label="quasi-static" + _lumps_label(quasi))]
    if linear:
        handles.append(Line2D([], [], color=LINEAR_COLOR, mec="k", mew=0.5, marker="X", ms=8, ls="",
                              label="linear KED" + _lumps_label(linear)))
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
    return save_figures({"work_precision.png": work_precision_figure(tables, attrs),
                         "work_precision_lumps.png": lumps_figure(tables)}, out_dir, DPI)


def _disc(d: Discretization) -> str:
    el = "ANCF" if d.element == "ancf" else "GE beam"
    return f"{el} {d.elements_per_link} el, {d.steps_per_cycle} st, rho {d.spectral_radius:g}"


def markdown(tables: dict, attrs: dict, figures: Sequence[Path], base: Path) -> str:
    """The README section from the stored tables (load -> analyse -> format)."""
    return format_findings(analyse(tables, attrs), [os.path.relpath(p, base) for p in figures])


def format_findings(f: WPFindings, rel: Sequence[str]) -> str:
    """The README section, formatted from the findings only (``rel``: the figures' relative paths)."""
    a, dd, ref = f.attrs, f.attrs["defaults"], f.attrs["reference"]
    cur = f.default.cost
    lines = [
        "## Error against run time (work-precision)",
        "",
        "Regenerate: `ked study work-precision` (configs `results/studies/work_precision.toml`, "
        "`work_precision_quasi.toml`, `work_precision_refcheck.toml`; results `results/studies/work_precision.h5`, "
        f"derived tables in its `/study` group). Last run: {a['created_utc']}, {int(a['scenes'])} scenes, "
        f"campaign {a['campaign_wall_s'] / 60:.1f} min on {int(a['workers'])} workers, whole study "
        f"{a['study_wall_s'] / 60:.1f} min."
        + (f" Table{'s' if len(f.updated) > 1 else ''} {', '.join(f'`{t}`' for t in f.updated)} added "
           f"{a['updated_utc']} ({a['updated_wall_s'] / 60:.1f} min), the others kept." if f.updated else ""),
        "",
        f"![work-precision]({rel[0]})",
        "",
        "**Set-up.** Thesis source four-bar, 2 % damping, speed ratio Omega/omega1_min = "
        + ", ".join(sorted({fam.split(' ', 1)[1] for fam in f.families}))
        + f" for the mass models {', '.join(fam.split()[0] for fam in f.families)}. "
        "Every combination of element type (ANCF cable, geometrically exact beam), elements per link, steps per "
        "crank cycle and generalized-alpha spectral radius in `work_precision.toml`; the settings not studied are "
        f"pinned to the current defaults (ramp {dd['ramp_cycles']:g} cycle, steady to {dd['steady_tol']:g}"
        f"{' with extrapolation' if dd['extrapolate'] else ''}). "
        "**Error** of the returned steady cycle on the 10 deg grid: max |d - d_ref| of (dx, dy) relative to the "
        "reference peak of |dx|, |dy|, and of the rotation relative to its peak; the larger of the two. It "
        f"includes the transient left by the steady-state criterion: at the reference's own discretization the "
        f"default tolerance alone gives {', '.join(f'{pct(e)} ({fam})' for e, fam in f.transient) or '-'}. "
        f"**Reference**: {ref['element'].upper()} {ref['elements_per_link']} elements/link, {ref['steps_per_cycle']} "
        f"steps/cycle, rho {ref['spectral_radius']:g}, steady to {ref['steady_tol']:g}. "
        f"**Wall time**: the dynamic solver's whole run; runs under {a['retime_below_s']:g} s in the campaign "
        f"({f.timed} runs) are the median of 3 (campaign run + 2 serial repeats), longer ones a single "
        f"campaign run ({int(a['workers'])} workers on 2 cores shared with other jobs). The 3 timings of a "
        f"run differ by {pct(f.spread)} (median of (max - min) / "
        "median), which is the noise level of the times.",
    ]
    for r in f.refcheck:
        lines.append("")
        lines.append(f"Reference check ({r['family']}): ANCF {int(r['elements_per_link'])} el/link and "
                     f"{int(r['steps_per_cycle'])} steps/cycle differ from the reference by {pct(r['error'])} "
                     f"({r['wall_s']:.0f} s); errors below about that are not resolved.")
    lines += ["", "Pareto front per scene (cheapest first):", ""]
    lines += table(("scene", "discretization", Column("wall", "s", True), Column("error", right=True)),
                   [[fam, _disc(p.disc), f"{p.wall_s:.2f}", pct(p.error)] for fam, fr in f.fronts.items() for p in fr])
    lines += ["", "Cheapest discretization within an error budget on **every** scene (wall time summed over the "
              f"{len(f.families)} scenes):", ""]
    budget = [[pct(c.target), _disc(c.disc) if c.disc else "none", f"{c.total_wall_s:.2f}", pct(c.worst_error)]
              for c in f.choices]
    if cur is not None:
        budget.append(["current default", _disc(f.default.default), f"{cur[0]:.2f}", pct(cur[1])])
    lines += table((Column("budget", right=True), "discretization", Column("total wall", "s", True),
                    Column("worst error", right=True)), budget)
    lines += ["", _verdict(f.default)]
    if f.failed:
        lines += ["", f"Failed dynamic runs ({len(f.failed)}, not plotted):", ""]
        for p in f.failed:
            lines.append(f"* {p.family}, {_disc(p.disc)}: {re.sub(r' [(]time=.*[)]$', '', p.message)}")
    lines += ["", "**Quasi-static solver on the same axes** (red diamonds): solve time (median of 21, 36 crank "
              "angles) and error against the dynamic reference of the same scene. Its error is the "
              "instantaneous-structure (model) error, which no discretization removes; it grows with the speed "
              "ratio. This is the trade: milliseconds and the error below, or the dynamic model's seconds and "
              f"(at the default discretization) at most {pct(cur[1]) if cur else '-'} on the scenes above.", ""]
    lines += table(("mass model", Column("r", right=True), Column("quasi-static error", right=True),
                    Column("QS time", "ms", True), Column("dynamic reference", "s", True),
                    Column("QS peak", "mm", True), Column("dynamic peak", "mm", True)),
                   [[q["mass_model"], f"{q['speed_ratio']:.3g}", pct(q["error"]), f"{1e3 * q['wall_s']:.2f}",
                     f"{q['dynamic_wall_s']:.1f}", f"{1e3 * q['qs_peak_m']:.3g}", f"{1e3 * q['dyn_peak_m']:.3g}"]
                    for q in f.quasi])
    lines += _linear_lines(f.linear) if f.linear else []
    lines += _lumps_lines(f.lumps, rel[1] if len(rel) > 1 else "") if f.lumps else []
    return "\n".join(lines)


def _ms(x: float) -> str:
    """Milliseconds, 3 significant digits (whole ms from 1 s on)."""
    if not math.isfinite(x):
        return "-"
    return f"{1e3 * x:.3g}" if x < 1.0 else f"{1e3 * x:.0f}"


def _linear_lines(f: LinearFindings) -> list[str]:
    """Where the linear KED model sits: a paragraph over all scenes and a row per mass model."""
    reps, (w_med, w_min, w_max) = f.repeats, f.wall_s
    text = (f"**Linear KED model on the same axes** ({LINEAR_COLOR} crosses): `ked_linear.solve_linear` with the "
            f"scene's damping ratio ({', '.join(f'{z:g}' for z in f.damping_ratios)}) and its default resolution; "
            f"solve time the median of {reps[-1]} solves"
            + (f" ({reps[0]} where one solve takes over a second)" if len(reps) > 1 else "") + ", error against "
            f"the same dynamic reference with the same measure. Over the {f.scenes} scenes its median solve time "
            f"is {_ms(w_med)} ms ({_ms(w_min)} to {_ms(w_max)} ms) against "
            f"{_ms(f.quasi_wall_s)} ms for the quasi-static "
            f"solver and {f.dynamic_wall_s:.1f} s for the dynamic reference "
            f"(the timings of a scene differ by {pct(f.spread)}"
            ", median of (max - min) / median); "
            f"its error is below the quasi-static one on {f.better} of {f.pairs} scenes (median ratio "
            f"{f.median_ratio:.2g}).")
    if f.unstable:
        text += (" No stable periodic steady state (Floquet) on: "
                 + ", ".join(f"{m} r={r:.2g}" for m, r in f.unstable) + ".")
    if f.unresolved:
        text += (f" Its own error estimate exceeds {pct(UNRESOLVED_ESTIMATE)} (flagged unresolved) on: "
                 + ", ".join(f"{m} r={r:.2g} ({pct(e)})" for m, r, e in f.unresolved) + ".")
    if f.matched:
        text += (" The cheapest dynamic run at least as accurate as the linear model on the same scene takes "
                 + ", ".join((f"{fam} {w:.2f} s" if math.isfinite(w) else f"{fam} none") + f" (linear {lw:.2f} s)"
                             for fam, w, lw in f.matched) + ".")

    def join(cells: list, fmt) -> str:
        return " / ".join(fmt(c) if c else "" for c in cells)

    heads = ("mass model", Column(f"linear error, r = {' / '.join(f.ratios)}", right=True),
             Column("quasi-static error", right=True), Column("linear time", "ms", True),
             Column("dynamic reference", "s", True))
    return ["", text, ""] + table(heads, [
        [model, join(c, lambda x: pct(x[0])), " / ".join(pct(x[1]) if x and x[1] is not None else "" for x in c),
         join(c, lambda x: _ms(x[2])), join(c, lambda x: f"{x[3]:.1f}")] for model, c in f.cells.items()])


def _verdict(f: DefaultFindings) -> str:
    c1, dflt, cur = f.choice, f.default, f.cost
    if c1.disc is None or cur is None:
        return "**Default.** Not enough data to judge the default (see failures)."
    text = (f"**Default.** The current default ({_disc(dflt)}) costs {cur[0]:.2f} s over the {f.families} scenes "
            f"with a worst error of {pct(cur[1])}; it is on the Pareto front of "
            f"{len(f.on_front)} of {f.families} scenes{(' (' + ', '.join(f.on_front) + ')') if f.on_front else ''}. ")
    tied = ", ".join(_disc(d) for d in c1.tied)
    if c1.disc == dflt:
        text += f"The data support it: it is the cheapest setting within the {pct(c1.target)} budget"
        text += f" (within the {100 * TIE:g} % timing noise of it: {tied})." if tied else "."
    elif dflt in c1.tied:
        text += (f"The data support it: within the {pct(c1.target)} budget it ties (within the {100 * TIE:g} % "
                 f"timing noise) with the cheapest, {_disc(c1.disc)} ({c1.total_wall_s:.2f} s, worst "
                 f"{pct(c1.worst_error)}).")
    else:
        text += (f"The cheapest setting within the {pct(c1.target)} budget is {_disc(c1.disc)} "
                 f"({c1.total_wall_s:.2f} s, worst {pct(c1.worst_error)}; the default takes "
                 f"{cur[0] / c1.total_wall_s:.2f}x its time). ")
        text += ("The default also meets the budget." if cur[1] <= c1.target
                 else "The default does not meet that budget on every scene.")
    if f.failed_steps:
        text += (f" Robustness ({dflt.element.upper()} {dflt.elements_per_link} el/link): the most steps per cycle "
                 "at which a run still failed (Newton) on some scene: "
                 + ", ".join(f"rho {rho:g}: {v}" for rho, v in f.failed_steps.items())
                 + f"; the default's {dflt.steps_per_cycle} steps leave a margin of "
                 f"{dflt.steps_per_cycle / f.failed_steps.get(dflt.spectral_radius, 1):g}x"
                 " at its spectral radius.")
    return text


def _lumps_lines(f: LumpsFindings, fig: str) -> list[str]:
    out = ["", "**Quasi-static discretization**: lumps per link in the extender and distributed models "
           f"(`MassModel(lumps=n, placement=...)`) against n = {f.reference}. The relative error does not depend "
           "on the crank speed (every load scales with omega^2).", "", f"![lumps]({fig})", ""]
    out += table(("model, placement", *(Column(f"n={n}", right=True) for n in f.ns), Column("order", right=True)),
                 [[f"{m}, {pl}", *(pct(d[n]) if n in d else "" for n in f.ns), f"{f.orders[m, pl]:.2f}"]
                  for (m, pl), d in f.errors.items()])
    if f.times_s is not None:
        t0, t5, t1 = f.times_s
        out += ["", f"Solve time (distributed, midpoint): {1e3 * t0:.2f} ms at n={f.ns[0]}, "
                f"{1e3 * t5:.2f} ms at n=5, {1e3 * t1:.2f} ms at n={f.ns[-1]}."]
    out += ["", "Lumps needed:", ""]
    for (m, pl), need in f.needed.items():
        out += [f"* {m}, {pl}: {'n = ' + str(n) if n else 'more than ' + str(f.ns[-1])} lumps for {pct(t)}"
                for t, n in need.items()]
    return out
