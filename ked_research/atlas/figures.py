"""The atlas's figures, from the stored tables (plus the two recomputed coupler curves)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from compare.limits import TOLERANCES
from ked_quasi.massmodel import MASS_MODELS
from ked_research.atlas.analysis import crossed, within

MARKERS = dict(zip(MASS_MODELS, "osD^"))
COLORS = dict(zip(MASS_MODELS, ("C0", "C1", "C2", "C3")))


def _figure(size: tuple[float, float]):  # noqa: ANN202 - matplotlib Figure
    from matplotlib.figure import Figure

    return Figure(figsize=size, layout="constrained")


def _axes(ax, xlabel: str, ylabel: str, legend: float | None = 8, which: str = "major", **legend_kw: float) -> None:
    """Axis labels, the grid and, of font size ``legend`` (None: none), the legend."""
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.grid(alpha=0.3, which=which)
    if legend:
        ax.legend(fontsize=legend, **legend_kw)


def _save(fig, path: Path) -> Path:  # noqa: ANN001
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    return path


def limits_histogram(fam: dict[str, np.ndarray], path: Path) -> Path:
    """Distribution of the quasi-static 5 % and 10 % limits per mass model."""
    fig = _figure((11, 4))
    bins = np.linspace(0.0, 0.25, 41)
    for ax, tag, tol in zip(fig.subplots(1, 2), ("r5", "r10"), ("5 %", "10 %")):
        for mm in MASS_MODELS:
            r = np.asarray(fam[tag], float)[crossed(fam, tag, mm)]
            ax.hist(r, bins=bins, histtype="step", lw=1.6, color=COLORS[mm], label=f"{mm} ({r.size})")
        _axes(ax, f"quasi-static limit r* ({tol} history error against the linear model)", "families")
    return _save(fig, path)


def features(fam: dict[str, np.ndarray], feats: dict[str, np.ndarray], path: Path) -> Path:
    """r10 against the features that move it, one marker per mass model."""
    names = list(feats)
    fig = _figure((12, 7.5))
    axes = fig.subplots(2, (len(names) + 1) // 2).ravel()
    rng = np.random.default_rng(0)
    for ax, name in zip(axes, names):
        for mm in MASS_MODELS:
            m = crossed(fam, "r10", mm)
            x = np.asarray(feats[name], float)[m]
            if name.startswith("k_sig"):
                x = x + rng.uniform(-0.25, 0.25, x.size)
            ax.scatter(x, np.asarray(fam["r10"], float)[m], s=6, alpha=0.5, marker=MARKERS[mm], color=COLORS[mm],
                       label=mm)
        _axes(ax, name, "quasi-static r* (10 %)", None)
    axes[0].legend(fontsize=8, markerscale=2)
    for ax in axes[len(names):]:
        ax.set_visible(False)
    return _save(fig, path)


def predictions(fam: dict[str, np.ndarray], rule_r10: np.ndarray, path: Path) -> Path:
    """Predicted against atlas r10: the one-mode estimate and the rule k_sig r <= c, +-25 % band."""
    fig = _figure((11, 4.5))
    m = crossed(fam, "r10")
    actual = np.asarray(fam["r10"], float)
    for ax, pred, title in zip(fig.subplots(1, 2), (np.asarray(fam["one_mode_r10"], float), rule_r10),
                               ("one-mode estimate", "rule k_sig r <= c")):
        for mm in MASS_MODELS:
            sel = m & (np.asarray(fam["mass_model"], dtype=object) == mm)
            ax.scatter(actual[sel], pred[sel], s=6, alpha=0.5, marker=MARKERS[mm], color=COLORS[mm], label=mm)
        x = np.array([0.0, 0.3])
        ax.plot(x, x, "k-", lw=0.8)
        ax.fill_between(x, 0.75 * x, 1.25 * x, color="grey", alpha=0.2, label="+-25 %")
        ok = within(pred[m], actual[m])
        ax.set_title(f"{title}: {ok.mean():.0%} of {m.sum()} families within +-25 %", fontsize=10)
        ax.set_xlim(0, 0.3)
        ax.set_ylim(0, 0.3)
        _axes(ax, "atlas r* (10 %)", "predicted r* (10 %)", markerscale=2)
    return _save(fig, path)


def design_map(fam: dict[str, np.ndarray], x: tuple[str, np.ndarray], y: tuple[str, np.ndarray], path: Path) -> Path:
    """r10 as a map over two design parameters, one panel per mass model."""
    fig = _figure((12, 9))
    vmin, vmax = np.nanpercentile(np.asarray(fam["r10"], float)[crossed(fam, "r10")], [2, 98])
    for ax, mm in zip(fig.subplots(2, 2).ravel(), MASS_MODELS):
        m = crossed(fam, "r10", mm)
        sc = ax.scatter(np.asarray(x[1], float)[m], np.asarray(y[1], float)[m], c=np.asarray(fam["r10"], float)[m],
                        s=14, cmap="viridis", vmin=vmin, vmax=vmax)
        ax.set_title(f"{mm}: quasi-static r* (10 %)", fontsize=10)
        ax.set_xlabel(x[0])
        ax.set_ylabel(y[0])
        fig.colorbar(sc, ax=ax)
    return _save(fig, path)


def confirm(conf: dict[str, np.ndarray], path: Path) -> Path:
    """The Exudyn sample: quasi-static error against Exudyn vs against the linear model; the linear
    model's error against Exudyn over r / r10."""
    fig = _figure((12, 4.5))
    ax1, ax2 = fig.subplots(1, 2)
    ok = np.asarray(conf["status"], dtype=object) == "ok"
    for mm in MASS_MODELS:
        m = ok & (np.asarray(conf["mass_model"], dtype=object) == mm)
        ax1.scatter(conf["qs_vs_linear"][m], conf["qs_vs_dyn"][m], s=12, marker=MARKERS[mm], color=COLORS[mm],
                    label=mm)
        ax2.scatter(conf["factor"][m], conf["linear_vs_dyn"][m], s=12, marker=MARKERS[mm], color=COLORS[mm],
                    label=mm)
    lim = np.array([1e-3, 10.0])
    ax1.plot(lim, lim, "k-", lw=0.8)
    for ax, xlabel, ylabel in ((ax1, "quasi-static vs linear (atlas tier)", "quasi-static vs Exudyn"),
                               (ax2, "r / quasi-static r* (10 %)", "linear vs Exudyn")):
        ax.set_yscale("log")
        for tol in TOLERANCES:
            ax.axhline(tol, color="r", lw=0.8, ls=":")
        _axes(ax, xlabel, ylabel, which="both")
    ax1.set_xscale("log")
    return _save(fig, path)


def coupler_curves(curves: Sequence[dict], path: Path) -> Path:
    """Rigid vs deflected coupler curves (deflections magnified) of the recomputed linkages.

    ``curves``: dicts with title, rigid (n, 2), quasi_static (n, 2), linear (n, 2) [m], magnification."""
    fig = _figure((5.5 * len(curves), 5))
    for ax, c in zip(np.atleast_1d(fig.subplots(1, len(curves))), curves):
        rig, mag = c["rigid"], c["magnification"]
        close = np.r_[np.arange(len(rig)), 0]
        ax.plot(*rig[close].T, "k-", lw=1.2, label="rigid")
        ax.plot(*(rig + mag * c["quasi_static"])[close].T, "C0--", lw=1.2, label=f"quasi-static x{mag:.3g}")
        ax.plot(*(rig + mag * c["linear"])[close].T, "C3-", lw=1.2, label=f"linear KED x{mag:.3g}")
        ax.set_aspect("equal")
        ax.set_title(c["title"], fontsize=9)
        _axes(ax, "x [m]", "y [m]")
    return _save(fig, path)


def threshold(e: np.ndarray, measured: np.ndarray, mass_model: np.ndarray, factor: np.ndarray, tolerance: float,
              holds_below: float, fails_above: float, path: Path) -> Path:
    """The threshold sample: measured (quasi-static vs Exudyn) against predicted (quasi-static vs linear)
    error, with the tolerance and the chosen margins; the measured error over r / r10."""
    fig = _figure((12, 4.5))
    ax1, ax2 = fig.subplots(1, 2)
    mm_all = np.asarray(mass_model, dtype=object)
    for mm in MASS_MODELS:
        m = (mm_all == mm) & np.isfinite(measured)
        ax1.scatter(np.asarray(e)[m], np.asarray(measured)[m], s=10, marker=MARKERS[mm], color=COLORS[mm], label=mm)
        ax2.scatter(np.asarray(factor)[m], np.asarray(measured)[m], s=10, marker=MARKERS[mm], color=COLORS[mm],
                    label=mm)
    lim = np.array([0.02, 0.4])
    ax1.plot(lim, lim, "k-", lw=0.6)
    ax1.axhline(tolerance, color="r", lw=0.8, ls=":", label=f"tolerance {tolerance:.0%}")
    ax1.axvline(holds_below * tolerance, color="g", lw=0.8, ls="--", label=f"holds below {holds_below:g} x tol")
    ax1.axvline(fails_above * tolerance, color="m", lw=0.8, ls="--", label=f"fails above {fails_above:g} x tol")
    ax1.set_xlim(*lim)
    ax1.set_ylim(*lim)
    ax1.set_xscale("log")
    ax1.set_yscale("log")
    from matplotlib.ticker import NullFormatter

    for axis in (ax1.xaxis, ax1.yaxis):
        axis.set_minor_formatter(NullFormatter())
    ax2.axhline(tolerance, color="r", lw=0.8, ls=":")
    ax2.set_yscale("log")
    _axes(ax1, "predicted: quasi-static vs linear", "measured: quasi-static vs Exudyn", 7, "both")
    _axes(ax2, "r / family's interpolated quasi-static r10", "measured: quasi-static vs Exudyn", 7, "both")
    return _save(fig, path)
