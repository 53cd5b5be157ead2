"""Validity study figures (PNG, ~100 dpi), drawn from the family summaries only."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from compare.limits import TOLERANCES, one_mode_curves  # noqa: E402
from ked_research.study_io import save_figures  # noqa: E402
from ked_research.validity.summary import FamilySummary  # noqa: E402

DPI = 100
COLORS = {"tip": "tab:red", "joints": "tab:blue", "extender": "tab:green", "distributed": "tab:purple"}
HISTORY_RATIOS = (0.06, 0.15, 0.33)
"""Speed ratios (nearest on the grid) of the deflection-history figure."""


def reference(summaries: Sequence[FamilySummary], damping: float = 0.02, direction: str = "ccw"
              ) -> dict[tuple[str, str], list[FamilySummary]]:
    """Reference families grouped by (linkage, mechanism), in order."""
    out: dict[tuple[str, str], list[FamilySummary]] = {}
    for fs in summaries:
        if fs.damping == damping and fs.direction == direction:
            out.setdefault((fs.linkage, fs.mechanism), []).append(fs)
    return out


def _grid(n: int) -> tuple[Figure, np.ndarray]:
    cols = 2 if n > 1 else 1
    rows = math.ceil(n / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(5.2 * cols, 3.6 * rows), squeeze=False)
    for ax in axes.flat[n:]:
        ax.set_visible(False)
    return fig, axes


def _layout(fig: Figure) -> None:
    """Fixed margins (no layout engine: several times faster than tight_layout)."""
    h = fig.get_figheight()
    fig.subplots_adjust(left=0.08, right=0.98, bottom=0.5 / h, top=1.0 - 0.6 / h, wspace=0.25,
                        hspace=1.1 / (h / max(1, len(fig.axes) // 2 or 1)))


def _resonances(ax, tolerances: bool = True) -> None:
    """Dotted resonance lines k r = 1 (k = 1, 2, 3) and, with ``tolerances``, the 5 % and 10 % lines."""
    for tol in TOLERANCES if tolerances else ():
        ax.axhline(tol, color="k", lw=0.8, ls="-." if tol < 0.1 else "-")
    for k in (2, 3):
        ax.axvline(1.0 / k, color="0.75", lw=0.8, ls=":")
    ax.axvline(1.0, color="0.6", lw=0.8, ls=":")


def _qs_shape(fs: FamilySummary) -> np.ndarray | None:
    for s in fs.slots:
        if s.point.qs is not None:
            return s.point.qs
    return None


def _log_axes(ax, title: str, ylabel: str, ylim: tuple[float, float] | None = None, legend_loc: str = "best"
              ) -> None:
    """Log-log axes over the speed ratio r, with title, labels, grid and legend."""
    ax.set_xscale("log")
    ax.set_yscale("log")
    if ylim:
        ax.set_ylim(*ylim)
    ax.set_title(title)
    ax.set_xlabel("r = Omega / omega1_min")
    ax.set_ylabel(ylabel)
    ax.grid(True, alpha=0.25)
    ax.legend(fontsize=7, loc=legend_loc)


def error_figure(summaries: Sequence[FamilySummary]) -> Figure:
    """Relative error of the quasi-static solution vs r: history error (solid), peak error (dashed);
    x at the top: dynamic solver failed; open markers: solved by the retry (4x steps per cycle)."""
    groups = reference(summaries)
    fig, axes = _grid(len(groups))
    for ax, ((lk, mech), fams) in zip(axes.flat, groups.items()):
        for fs in fams:
            c = COLORS.get(fs.mass_model, "k")
            ok = [s for s in fs.slots if s.ok]
            r = [s.r for s in ok]
            ax.plot(r, [s.errors.history for s in ok], "-o", color=c, ms=3.5, label=fs.mass_model)
            ax.plot(r, [s.errors.peak for s in ok], "--", color=c, lw=1)
            re = [s for s in ok if s.retried]
            ax.plot([s.r for s in re], [s.errors.history for s in re], "o", mfc="white", color=c, ms=5)
            bad = [s.r for s in fs.slots if not s.ok]
            ax.plot(bad, [8.0] * len(bad), "x", color=c, ms=6)
        _resonances(ax)
        _log_axes(ax, f"{lk} / {mech}", "relative error of quasi-static", (1e-3, 10), "lower right")
    fig.suptitle("Quasi-static error vs speed ratio (solid: whole history, dashed: peak |d|; "
                 "x: dynamic failed; lines 5 %, 10 %)", fontsize=9)
    _layout(fig)
    return fig


def amplification_figure(summaries: Sequence[FamilySummary]) -> Figure:
    """Dynamic amplification max|d_dyn| / max|d_qs| vs r, with the one-mode estimate (dotted)."""
    groups = reference(summaries)
    fig, axes = _grid(len(groups))
    for ax, ((lk, mech), fams) in zip(axes.flat, groups.items()):
        for fs in fams:
            c = COLORS.get(fs.mass_model, "k")
            ok = [s for s in fs.slots if s.ok]
            ax.plot([s.r for s in ok], [s.errors.amplification for s in ok], "-o", color=c, ms=3.5,
                    label=fs.mass_model)
            qs = _qs_shape(fs)
            if qs is not None and ok:
                rs = np.linspace(0.01, max(s.r for s in fs.slots), 600)
                ax.plot(rs, one_mode_curves(qs, rs, fs.damping)["amplification"], ":", color=c, lw=1)
            bad = [s.r for s in fs.slots if not s.ok]
            ax.plot(bad, [0.55] * len(bad), "x", color=c, ms=6)
        _resonances(ax, tolerances=False)
        ax.axhline(1.0, color="k", lw=0.6)
        _log_axes(ax, f"{lk} / {mech}", "dynamic amplification", (0.5, 20), "upper left")
    fig.suptitle("Dynamic amplification of the peak deflection (dotted: one-mode estimate; "
                 "x: dynamic failed)", fontsize=9)
    _layout(fig)
    return fig


def nearest_slots(fs: FamilySummary, targets: Sequence[float]) -> list:
    """The solved slots nearest to each target ratio (None where nothing solved)."""
    ok = [s for s in fs.slots if s.ok]
    return [min(ok, key=lambda s: abs(math.log(s.r / t))) if ok else None for t in targets]


def history_figure(summaries: Sequence[FamilySummary], linkage: str = "thesis", mechanism: str = "source"
                   ) -> Figure:
    """dx, dy of P [mm] over the crank angle, dynamic (markers: the stored samples, which a line would
    alias into zigzags where the linkage vibrates) vs quasi-static (dashed), per mass model (rows) at
    the ratios nearest to :data:`HISTORY_RATIOS` (columns)."""
    fams = reference(summaries).get((linkage, mechanism)) or next(iter(reference(summaries).values()), [])
    fig, axes = plt.subplots(len(fams), len(HISTORY_RATIOS), figsize=(11, 2.4 * len(fams) + 0.6),
                             squeeze=False)
    for row, fs in zip(axes, fams):
        for ax, s in zip(row, nearest_slots(fs, HISTORY_RATIOS)):
            if s is None:
                ax.set_visible(False)
                continue
            p = s.point
            th = np.degrees(p.theta)
            for j, (name, c) in enumerate((("dx", "tab:blue"), ("dy", "tab:orange"))):
                ax.plot(th, 1e3 * p.dyn[:, j], "o", color=c, ms=2.5, label=f"{name} dynamic (samples)")
                ax.plot(th, 1e3 * p.qs[:, j], "--", color=c, label=f"{name} quasi-static")
            ax.set_title(f"{fs.mass_model}, r = {p.r:.3g} ({p.rpm:.0f} rpm): error "
                         f"{100 * s.errors.history:.1f} %", fontsize=8)
            ax.set_xlim(0, 360)
            ax.set_xticks(range(0, 361, 90))
            ax.tick_params(labelsize=7)
            ax.grid(True, alpha=0.25)
        row[0].set_ylabel("deflection [mm]", fontsize=8)
    axes[0, 0].legend(fontsize=6, loc="best")
    for ax in axes[-1]:
        ax.set_xlabel("crank angle [deg]", fontsize=8)
    step = _step_deg(fams)
    fig.suptitle(f"Deflection of P, {linkage} {mechanism}: dynamic steady state (dots: stored every "
                 f"{step} deg) vs quasi-static (dashed)", fontsize=9)
    _layout(fig)
    return fig


def _step_deg(fams: Sequence[FamilySummary]) -> str:
    """The crank-angle step [deg] of the histories drawn, as text ("?" if none)."""
    for fs in fams:
        for s in fs.slots:
            if s.ok and s.point.theta is not None and len(s.point.theta) > 1:
                return f"{np.degrees(s.point.theta[1] - s.point.theta[0]):.3g}"
    return "?"


def variants_figure(summaries: Sequence[FamilySummary]) -> Figure | None:
    """History error vs r for the damping / direction variants (families with more than one
    (damping, direction) pair)."""
    groups: dict[tuple[str, str, str], list[FamilySummary]] = {}
    for fs in summaries:
        groups.setdefault((fs.linkage, fs.mechanism, fs.mass_model), []).append(fs)
    groups = {k: v for k, v in groups.items() if len(v) > 1}
    if not groups:
        return None
    fig, axes = _grid(len(groups))
    for ax, ((lk, mech, mm), fams) in zip(axes.flat, groups.items()):
        for fs in sorted(fams, key=lambda f: (f.direction, f.damping)):
            ok = [s for s in fs.slots if s.ok]
            ls = "-" if fs.direction == "ccw" else "--"
            ax.plot([s.r for s in ok], [s.errors.history for s in ok], ls, marker="o", ms=3,
                    label=f"zeta {100 * fs.damping:g} %, {fs.direction}")
        _resonances(ax)
        _log_axes(ax, f"{lk} / {mech} / {mm}", "history error")
    fig.suptitle("Effect of damping ratio and crank direction on the quasi-static error", fontsize=9)
    _layout(fig)
    return fig


def rule_figure(summaries: Sequence[FamilySummary]) -> Figure:
    """Left: dynamic validity limit vs the one-mode prediction; right: implied fraction k_sig * r_lim."""
    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 4))
    ref = [fs for fams in reference(summaries).values() for fs in fams]
    marks = {("history", 0.05): "o", ("history", 0.10): "s", ("peak", 0.05): "^", ("peak", 0.10): "v"}
    for (kind, tol), m in marks.items():
        x, y, c = [], [], []
        for fs in ref:
            lim = fs.limits[(kind, tol)]
            if lim.status == "crossed":
                x.append(fs.one_mode[(kind, tol)])
                y.append(lim.r_limit)
                c.append(COLORS.get(fs.mass_model, "k"))
        a.scatter(x, y, marker=m, c=c, s=22, label=f"{kind}, {100 * tol:g} %")
    a.plot([0.03, 0.18], [0.03, 0.18], "k-", lw=0.6)
    a.set_xlim(0.03, 0.18)
    a.set_ylim(0.03, 0.18)
    a.set_xlabel("one-mode prediction of the limit r")
    a.set_ylabel("dynamic limit r (Exudyn)")
    a.legend(fontsize=7)
    a.grid(True, alpha=0.25)
    labels, vals = [], []
    for fs in ref:
        lim = fs.limits[("history", 0.10)]
        if lim.status == "crossed":
            labels.append(f"{fs.linkage}/{fs.mechanism[:3]}/{fs.mass_model}")
            vals.append((fs.k_significant[0.01] * lim.r_limit, fs.k_significant[0.05] * lim.r_limit,
                         COLORS.get(fs.mass_model, "k")))
    xs = np.arange(len(vals))
    b.bar(xs - 0.2, [v[0] for v in vals], 0.4, color=[v[2] for v in vals])
    b.bar(xs + 0.2, [v[1] for v in vals], 0.4, color=[v[2] for v in vals], alpha=0.45)
    b.set_xticks(xs, labels, rotation=70, fontsize=6)
    b.set_ylabel("k_sig * r_lim (10 %, history)")
    b.set_title("solid: k_sig at 1 % of the largest load harmonic, light: at 5 %", fontsize=8)
    b.grid(True, axis="y", alpha=0.25)
    fig.suptitle("Does 'highest significant crank harmonic below a fraction of omega1' explain the limit?",
                 fontsize=9)
    fig.subplots_adjust(left=0.07, right=0.98, bottom=0.27, top=0.88, wspace=0.25)
    return fig


FIGURES = {
    "validity_error.png": error_figure,
    "validity_amplification.png": amplification_figure,
    "validity_histories.png": history_figure,
    "validity_variants.png": variants_figure,
    "validity_rule.png": rule_figure,
}
"""File name -> figure function (None when the study has nothing to show), in report order."""


def write_figures(summaries: Sequence[FamilySummary], out_dir: Path) -> list[Path]:
    """Write every figure of the study; returns their paths."""
    return save_figures({name: make(summaries) for name, make in FIGURES.items()}, out_dir, DPI)
