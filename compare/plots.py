"""PNG figures of a campaign (matplotlib object API, Agg canvas, no global pyplot state).

- ``scene_<key>.png``: dynamic vs quasi-static histories of every stored component over the crank
  angle [deg], and the rigid coupler curve with the quasi-static and dynamic deflected curves
  (deflections magnified by the factor shown in the legend).
- ``amplification.png``: dynamic amplification and relative error vs speed ratio Omega/omega1_min,
  one line per (mechanism, mass model, stiffness, damping, direction) family.
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from compare.results import SceneResult

_LABELS = {"dx": "dx [mm]", "dy": "dy [mm]", "rotation": "rotation [mrad]"}
_SCALE = {"dx": 1e3, "dy": 1e3, "rotation": 1e3}


def magnification(r: SceneResult) -> float:
    """Display factor so that the largest deflection is about 10 % of the coupler-curve size [1]."""
    if r.coupler_point is None:
        return 1.0
    size = float(np.max(np.ptp(r.coupler_point, axis=0)))
    peak = 0.0
    for side in (r.quasi_static, r.dynamic):
        if "dx" in side and "dy" in side:
            peak = max(peak, float(np.max(np.hypot(side["dx"], side["dy"]))))
    if peak <= 0.0 or not math.isfinite(peak):
        return 1.0
    raw = 0.1 * size / peak
    if raw < 1.0:
        return 1.0
    decade = 10 ** math.floor(math.log10(raw))
    return float(max(m * decade for m in (1, 2, 5) if m * decade <= raw))


def _short(text: str, n: int = 110) -> str:
    return text if len(text) <= n else text[: n - 3] + "..."


def scene_figure(r: SceneResult) -> Figure:
    """Histories and coupler curves of one scene."""
    comps = [c for c in r.spec.outputs if c in r.quasi_static or c in r.dynamic]
    nrows = max(1, len(comps))
    height = 2.6 * nrows + 1.0
    fig = Figure(figsize=(11, height))  # fixed margins: a layout engine would double the drawing time
    gs = fig.add_gridspec(nrows, 2, width_ratios=(1.4, 1.0), left=0.075, right=0.985, bottom=0.55 / height,
                          top=1.0 - 0.95 / height, hspace=0.5, wspace=0.22)
    status = "ok" if r.ok else f"FAILED at {r.stage}: {r.error_type}\n{_short(r.message)}"
    verdict = ""
    if r.metrics is not None:
        verdict = (f"; max rel. error {r.metrics.max_relative_error:.1%} -> quasi-static "
                   f"{'holds' if r.metrics.holds else 'FAILS'} (tol {r.metrics.tolerance:.0%})")
    fig.suptitle(
        f"{r.spec.label}  [{r.key}]\n{r.rpm:.4g} rpm, Omega/w1min = "
        f"{_speed_ratio(r):.3g}, {status}{verdict}",
        fontsize=10,
    )
    if r.crank_angle is not None:
        deg = np.degrees(r.crank_angle)
        for i, c in enumerate(comps):
            ax = fig.add_subplot(gs[i, 0])
            if c in r.quasi_static:
                ax.plot(deg, _SCALE[c] * r.quasi_static[c], "o-", ms=3, lw=1.2, label="quasi-static")
            if c in r.dynamic:
                ax.plot(deg, _SCALE[c] * r.dynamic[c], "s--", ms=3, lw=1.2, label="dynamic (steady state)")
            ax.set_ylabel(_LABELS[c])
            ax.set_xlim(0, 360)
            ax.set_xticks(range(0, 361, 60))
            ax.grid(alpha=0.3)
            if r.metrics is not None and c in [m.component for m in r.metrics.components]:
                cm = r.metrics.component(c)
                shift = round(math.degrees(cm.phase_shift), 1) + 0.0  # no "-0.0"
                ax.set_title(f"{c}: rel. error {cm.relative_error:.1%}, amplification "
                             f"{cm.amplification:.3f}, peak shift {shift:.1f} deg", fontsize=9)
            if i == 0:
                ax.legend(fontsize=8)
            if i == nrows - 1:
                ax.set_xlabel("crank angle [deg]")
    ax = fig.add_subplot(gs[:, 1])
    if r.coupler_point is not None:
        P = r.coupler_point * 1e3
        k = magnification(r)
        closed = np.vstack([P, P[:1]])
        ax.plot(closed[:, 0], closed[:, 1], "k-", lw=1.5, label="rigid")
        for side, name, style in ((r.quasi_static, "quasi-static", "o-"), (r.dynamic, "dynamic", "s--")):
            if "dx" in side and "dy" in side:
                D = P + k * 1e3 * np.column_stack([side["dx"], side["dy"]])
                D = np.vstack([D, D[:1]])
                ax.plot(D[:, 0], D[:, 1], style, ms=2.5, lw=1.0, label=f"{name} (x{k:g})")
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel("x [mm]")
        ax.set_ylabel("y [mm]")
        ax.set_title("coupler curve of P (deflections magnified)", fontsize=9)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    return fig


def _speed_ratio(r: SceneResult) -> float:
    if r.metrics is not None:
        return r.metrics.speed_ratio
    if math.isfinite(r.rpm) and math.isfinite(r.omega1_min) and r.omega1_min > 0:
        return r.rpm * 2 * math.pi / 60 / r.omega1_min
    return float("nan")


def _family(r: SceneResult) -> str:
    s = r.spec
    extra = []
    if s.stiffness_scale != 1.0:
        extra.append(f"k{s.stiffness_scale:g}")
    extra.append(f"z{s.damping_ratio:g}")
    if s.direction != "ccw":
        extra.append(s.direction)
    return f"{s.mechanism}/{s.mass_model.name}/" + "/".join(extra)


def amplification_figure(results: Sequence[SceneResult], tolerance: float | None = None) -> Figure:
    """Dynamic amplification and relative error vs speed ratio, one line per scene family."""
    fig = Figure(figsize=(12, 5), layout="constrained")
    ax_a, ax_e = fig.subplots(1, 2)
    fams: dict[str, list[SceneResult]] = defaultdict(list)
    for r in results:
        if r.metrics is not None and r.metrics.components:
            fams[_family(r)].append(r)
    markers = "osD^v<>pPX*h"
    for i, (fam, rs) in enumerate(sorted(fams.items())):
        rs = sorted(rs, key=lambda r: r.metrics.speed_ratio)
        x = [r.metrics.speed_ratio for r in rs]
        amp = [r.metrics.max_amplification for r in rs]
        err = [100 * r.metrics.max_relative_error for r in rs]
        style = dict(marker=markers[i % len(markers)], ls="-" if fam.startswith("source") else "--", ms=5)
        ax_a.plot(x, amp, label=fam, **style)
        ax_e.plot(x, err, label=fam, **style)
    failed = [r for r in results if not r.ok and math.isfinite(_speed_ratio(r))]
    if failed:
        ax_e.plot([_speed_ratio(r) for r in failed], [0.0] * len(failed), "rx", ms=9,
                  label="failed scenes (no metrics)")
    ax_a.axhline(1.0, color="k", lw=0.8)
    ax_a.set_xlabel("speed ratio Omega / omega1_min [1]")
    ax_a.set_ylabel("max|dyn| / max|qs| [1], worst component")
    ax_a.set_title("dynamic amplification", fontsize=10)
    ax_e.set_xlabel("speed ratio Omega / omega1_min [1]")
    ax_e.set_ylabel("max|dyn - qs| / max|dyn| [%], worst component")
    tols = {r.metrics.tolerance for rs in fams.values() for r in rs}
    if tolerance is None and len(tols) == 1:
        tolerance = tols.pop()
    if tolerance is not None:
        ax_e.axhline(100 * tolerance, color="r", lw=1, ls=":", label=f"tolerance {tolerance:.0%}")
    ax_e.set_title("quasi-static error relative to the dynamic peak", fontsize=10)
    for ax in (ax_a, ax_e):
        ax.grid(alpha=0.3)
    if fams or failed:
        ax_e.legend(fontsize=7, loc="upper left")
    return fig


def _write_scene_png(r: SceneResult, path: Path, dpi: int) -> Path:
    scene_figure(r).savefig(path, dpi=dpi)
    return path


def write_figures(results: Sequence[SceneResult], out_dir: str | Path, dpi: int = 110,
                  workers: int = 1) -> list[Path]:
    """Write all campaign figures into ``out_dir`` (scene figures in ``workers`` processes);
    returns the paths written."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    jobs = [(r, out / f"scene_{r.key}.png") for r in results]
    if workers > 1 and len(jobs) > 2 * workers:
        import concurrent.futures as cf
        import multiprocessing

        with cf.ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn")) as pool:
            paths = list(pool.map(_write_scene_png, *zip(*jobs), [dpi] * len(jobs)))
    else:
        paths = [_write_scene_png(r, p, dpi) for r, p in jobs]
    p = out / "amplification.png"
    amplification_figure(results).savefig(p, dpi=dpi)
    paths.append(p)
    return paths
