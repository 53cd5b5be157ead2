"""Figures of a campaign (matplotlib object API, no global pyplot state).
Each solver has one colour in every figure (:data:`SOLVER_COLORS`).

- ``scene_<label>.png`` (the scene label with ``/`` as ``_``; ``_<key>`` appended only where two
  scenes share a label): every solver's history of every stored component over the crank angle [deg],
  and the rigid coupler curve with each solver's deflected curve (deflections magnified by the factor
  shown in the legend).  Histories are drawn as their stored samples (the scene's grid, stated on the
  axis): the quasi-static one joined by a line, the others as markers, whose vibration a line between
  samples would alias.  An answer outside its model's range (validity flags) or of a failed solver is
  grey and hollow, "NOT VALID" and its flags in the legend, and leaves the axis limits to the valid
  answers (it may run off them).  The scene key is in the PNG's metadata (``Title``) and in ``index.json``.
- ``amplification.png``: dynamic amplification and verdict error vs speed ratio r = Omega/omega1_min
  (rpm on a second axis, or per family in the legend), one line per (mechanism, mass model, stiffness,
  damping, direction) family; points whose quasi-static answer or reference is outside its model's
  range are circled in grey with the reasons in the legend; failed scenes are marked on the speed
  axis, not drawn as errors.

Writing them into a figure directory: :mod:`compare.figure_dir`.
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Sequence
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from compare import solvers as registry
from compare.inspect import rpm_text
from compare.results import SceneResult
from compare.solvers import STRESS_PREFIX

_LABELS = {"dx": "dx [mm]", "dy": "dy [mm]", "rotation": "rotation [mrad]"}
_SCALE = {"dx": 1e3, "dy": 1e3, "rotation": 1e3}


INVALID_COLOR = "0.6"
"""Colour of an answer outside its model's range (validity flags): grey, hollow markers, dashed."""
SAMPLED = "quasi_static"
"""The one solver drawn as a line between its samples: its answer is a smooth function of the crank
angle (inertia loads of the rigid motion).  Every other solver's history may vibrate between the stored
samples of the scene's grid, so it is drawn as markers (a line would alias vibration into zigzags)."""


SOLVER_COLORS = {"quasi_static": "tab:blue", "linear_classic": "tab:purple", "linear": "tab:orange",
                 "dynamic": "tab:green"}
"""One colour per solver in every figure (an answer not valid is drawn in :data:`INVALID_COLOR` instead, and
the others keep theirs)."""
_OTHER_COLORS = ("tab:brown", "tab:pink", "tab:olive", "tab:cyan", "tab:red")


def solver_color(name: str) -> str:
    """The colour of solver ``name`` (:data:`SOLVER_COLORS`; a registered extra solver gets one of the
    remaining colours from a checksum of its name: the same in every figure and run)."""
    import zlib

    return SOLVER_COLORS.get(name) or _OTHER_COLORS[zlib.crc32(name.encode()) % len(_OTHER_COLORS)]


def magnification(r: SceneResult) -> float:
    """Display factor so that the largest valid deflection is about 10 % of the coupler-curve size [1]
    (an answer outside its model's range counts only when no answer is valid)."""
    if r.coupler_point is None:
        return 1.0
    size = float(np.max(np.ptp(r.coupler_point, axis=0)))
    shown = [s for s in r.solutions.values() if valid(s)] or list(r.solutions.values())
    peak = 0.0
    for side in (s.deflection for s in shown):
        if "dx" in side and "dy" in side:
            peak = max(peak, float(np.nanmax(np.hypot(side["dx"], side["dy"]), initial=0.0)))
    if peak <= 0.0 or not math.isfinite(peak):
        return 1.0
    raw = 0.1 * size / peak
    if raw < 1.0:
        return 1.0
    decade = 10 ** math.floor(math.log10(raw))
    return float(max(m * decade for m in (1, 2, 5) if m * decade <= raw))


def _short(text: str, n: int = 110) -> str:
    return text if len(text) <= n else text[: n - 3] + "..."


def solver_legend(name: str, sol: Any, short: bool = False) -> str:
    """A solver's legend text: its label, and for an answer outside its model's range that it is not
    valid and why (its flags; ``short``: "not valid" only); a failed solver says so."""
    text = registry.label(name)
    if not sol.ok:
        return text + " (failed)"
    if sol.flags:
        return f"{text}: NOT VALID" + ("" if short else _wrap_label(
            f" (outside its model's range: {', '.join(sol.flags)})", 40))
    return text


def _line_style(name: str, sol: Any, styles: dict[str, str], ms: float) -> dict[str, Any]:
    """matplotlib keywords of one solver's curve: its marker and colour; markers only for a solver
    other than :data:`SAMPLED`; greyed, hollow and dashed when its answer carries validity flags."""
    fmt = styles[name]
    marker = fmt[0]
    ls = fmt[1:] or "-"
    kw: dict[str, Any] = dict(marker=marker, ms=ms, ls=ls if name == SAMPLED else "none", lw=1.2,
                              color=solver_color(name))
    if not valid(sol):
        kw.update(color=INVALID_COLOR, mfc="none", ls="--" if name == SAMPLED else "none", lw=1.0)
    return kw


def valid(sol: Any) -> bool:
    """A solver's answer is drawn as valid: it succeeded and carries no validity flags."""
    return sol.ok and not sol.flags


def _scale_to(ax: Any, points: Sequence[np.ndarray]) -> None:
    """Data limits of ``ax`` from ``points`` ((n, 2) arrays: the answers drawn as valid) alone, then
    autoscaled (margins and aspect as usual); an answer not valid that reaches beyond them runs off the
    axes (its legend says it is not valid)."""
    xy = np.vstack(points) if points else np.empty((0, 2))
    xy = xy[np.all(np.isfinite(xy), axis=1)]
    if len(xy) == 0:
        return
    ax.ignore_existing_data_limits = True
    ax.update_datalim(xy)
    ax.autoscale_view()


def _grid_text(r: SceneResult) -> str:
    step = r.spec.step_deg
    return (f"crank angle [deg]; stored every {step:g} deg: {registry.label(SAMPLED)} as a line, "
            "other solvers as their samples")


def scene_figure(r: SceneResult) -> Figure:
    """Histories and coupler curves of one scene.  Every solver's stored samples are drawn as markers
    (the quasi-static one joined by a line, see :data:`SAMPLED`); an answer outside its model's range
    is greyed and hollow with its flags in the legend, and does not set the axis limits while a valid
    answer is drawn on the same axes (it may run off the scale: the legend says it is not valid)."""
    comps = [c for c in r.spec.outputs if any(c in s.deflection for s in r.solutions.values())]
    links = list(dict.fromkeys(lk for s in r.solutions.values() for lk in s.stress))
    styles = _styles(r)
    nrows = max(1, len(comps) + len(links))
    height = 2.6 * nrows + 1.2
    fig = Figure(figsize=(11, height))  # fixed margins: a layout engine would double the drawing time
    gs = fig.add_gridspec(nrows, 2, width_ratios=(1.4, 1.0), left=0.075, right=0.985, bottom=0.55 / height,
                          top=1.0 - 1.15 / height, hspace=0.5, wspace=0.22)
    status = "ok" if r.ok else f"FAILED at {r.stage}: {r.error_type}\n{_short(r.message, 100)}"
    verdict = ""
    v = r.verdict
    if v is not None:
        verdict = (f"\nquasi-static error vs {registry.label(v.reference)} {v.verdict_error:.1%} -> "
                   f"{'holds' if v.holds else 'FAILS'} (tol {v.tolerance:.0%})")
    fig.suptitle(
        f"{r.spec.label}  [{r.key}]\n{rpm_text(r.rpm)} rpm, Omega/w1min = "
        f"{r.speed_ratio:.3g}, {status}{verdict}",
        fontsize=10,
    )
    valid_any = {c: any(c in s.deflection and valid(s) for s in r.solutions.values()) for c in comps}
    if r.crank_angle is not None:
        deg = np.degrees(r.crank_angle)
        for i, c in enumerate(comps):
            ax = fig.add_subplot(gs[i, 0])
            shown = []
            for name, sol in r.solutions.items():
                if c in sol.deflection:
                    d = np.append(sol.deflection[c], sol.deflection[c][:1])
                    if valid(sol) or not valid_any[c]:
                        shown.append(np.column_stack([np.append(deg, 360.0), _SCALE[c] * d]))
                    ax.plot(np.append(deg, 360.0), _SCALE[c] * d, label=solver_legend(name, sol),
                            **_line_style(name, sol, styles, 3))
            _scale_to(ax, shown)
            ax.set_ylabel(_LABELS[c])
            ax.set_xlim(0, 360)
            ax.set_xticks(range(0, 361, 60))
            ax.grid(alpha=0.3)
            if v is not None and c in [m.component for m in v.components]:
                cm = v.component(c)
                shift = round(math.degrees(cm.phase_shift), 1) + 0.0  # no "-0.0"
                ax.set_title(f"{c}: quasi-static history error {cm.history_error:.1%}, amplification "
                             f"{cm.amplification:.3f}, peak shift {shift:.1f} deg", fontsize=9)
            if i == 0:
                ax.legend(fontsize=6.5, loc="best", framealpha=0.7)
            if i == nrows - 1:
                ax.set_xlabel(_grid_text(r), fontsize=8)
        for i, lk in enumerate(links, start=len(comps)):
            _stress_axes(fig.add_subplot(gs[i, 0]), r, lk, styles, deg)
            if i == nrows - 1:
                fig.axes[-1].set_xlabel(_grid_text(r), fontsize=8)
    ax = fig.add_subplot(gs[:max(1, len(comps)), 1])
    if r.coupler_point is not None:
        P = r.coupler_point * 1e3
        k = magnification(r)
        closed = np.vstack([P, P[:1]])
        ax.plot(closed[:, 0], closed[:, 1], "k-", lw=1.5, label="rigid")
        valid_xy = any("dx" in s.deflection and "dy" in s.deflection and valid(s) for s in r.solutions.values())
        shown = [closed]
        for name, sol in r.solutions.items():
            side = sol.deflection
            if "dx" in side and "dy" in side:
                D = P + k * 1e3 * np.column_stack([side["dx"], side["dy"]])
                D = np.vstack([D, D[:1]])
                if valid(sol) or not valid_xy:
                    shown.append(D)
                ax.plot(D[:, 0], D[:, 1], label=f"{solver_legend(name, sol, short=True)} (x{k:g})",
                        **(_line_style(name, sol, styles, 2.5) | {"lw": 1.0}))
        _scale_to(ax, shown)
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel("x [mm]")
        ax.set_ylabel("y [mm]")
        ax.set_title("coupler curve of P (deflections magnified)", fontsize=9)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="best", framealpha=0.6)
    return fig


def _stress_axes(ax: Any, r: SceneResult, link: str, styles: dict[str, str], deg: np.ndarray) -> None:
    """One link's largest and smallest extreme-fibre stress [MPa] of every solver (an answer outside its model's
    range greyed, as the deflections), titled with the quasi-static stress's error against the reference."""
    x = np.append(deg, 360.0)
    valid_any = any(link in s.stress and valid(s) for s in r.solutions.values())
    shown = []
    for name, sol in r.solutions.items():
        if link not in sol.stress:
            continue
        sig = np.vstack([sol.stress[link], sol.stress[link][:1]]) * 1e-6
        if valid(sol) or not valid_any:
            shown += [np.column_stack([x, sig[:, 0]]), np.column_stack([x, sig[:, 1]])]
        style = _line_style(name, sol, styles, 3)
        ax.plot(x, sig[:, 0], **style)
        ax.plot(x, sig[:, 1], **(style | {"alpha": 0.5}))
    _scale_to(ax, shown)
    ax.set_ylabel(f"{link} sigma\n[MPa]")
    ax.set_xlim(0, 360)
    ax.set_xticks(range(0, 361, 60))
    ax.grid(alpha=0.3)
    v = r.verdict
    name = STRESS_PREFIX + link
    if v is not None and name in [m.component for m in v.components]:
        cm = v.component(name)
        ax.set_title(f"{link} stress (largest and smallest fibre): quasi-static history error {cm.history_error:.1%}"
                     f" -> {'holds' if cm.holds else 'FAILS'}", fontsize=9)


_STYLES = ("o-", "s--", "^:", "D-.", "v-", "x--")


def _styles(r: SceneResult) -> dict[str, str]:
    """A line style per solver, in fidelity order (the same solver keeps its style across figures)."""
    return {n: _STYLES[i % len(_STYLES)] for i, n in enumerate(registry.names())} | {
        n: _STYLES[-1] for n in r.solutions if n not in registry.names()}


def family_label(r: SceneResult) -> str:
    """A reader's name of a scene's family: mechanism, mass model, damping ratio in %, and the
    stiffness scale and direction where they are not the defaults (e.g. "source, tip mass model,
    damping ratio 2 %")."""
    s = r.spec
    text = f"{s.mechanism}, {s.mass_model.name} mass model, damping ratio {100 * s.damping_ratio:g} %"
    if s.stiffness_scale != 1.0:
        text += f", stiffness x{s.stiffness_scale:g}"
    if s.direction != "ccw":
        text += f", crank {s.direction}"
    return text


def _family(r: SceneResult) -> str:
    s = r.spec
    extra = []
    if s.stiffness_scale != 1.0:
        extra.append(f"k{s.stiffness_scale:g}")
    extra.append(f"z{s.damping_ratio:g}")
    if s.direction != "ccw":
        extra.append(s.direction)
    return f"{s.mechanism}/{s.mass_model.name}/" + "/".join(extra)


def invalid_reasons(r: SceneResult) -> list[str]:
    """Why a scene's verdict point is not a valid comparison: "<solver> (<flags>)" for the quasi-static
    answer and the reference when their answers carry validity flags (empty: valid)."""
    out = []
    for name in dict.fromkeys(("quasi_static", r.reference)):
        sol = r.solutions.get(name) if name else None
        if sol is not None and sol.flags:
            out.append(f"{registry.label(name)} ({', '.join(sol.flags)})")
    return out


def _rpm_per_ratio(rs: Sequence[SceneResult]) -> float | None:
    """rpm per unit speed ratio shared by the scenes (omega1_min alike within 1e-6), else None."""
    w = {round(r.omega1_min, 6) for r in rs if math.isfinite(r.omega1_min) and r.omega1_min > 0}
    return 60.0 * w.pop() / (2.0 * math.pi) if len(w) == 1 else None


def amplification_figure(results: Sequence[SceneResult], tolerance: float | None = None) -> Figure:
    """Dynamic amplification and relative error vs speed ratio, one line per scene family.

    A point whose quasi-static answer or reference is outside its model's range (validity flags) is
    circled in grey, its reasons in the legend.  rpm stands beside r: on a second axis at the top where
    every family has the same omega1_min, else in each family's legend entry (the rpm of r = 0.1).  The
    legend sits below both panels; the error axis is logarithmic where the errors and the tolerance span
    more than a decade (:func:`error_scale`)."""
    fig = Figure(figsize=(12, 5.5), layout="constrained")
    ax_a, ax_e = fig.subplots(1, 2)
    fams: dict[str, list[SceneResult]] = defaultdict(list)
    for r in results:
        if r.verdict is not None and r.verdict.components:
            fams[_family(r)].append(r)
    per = _rpm_per_ratio([r for rs in fams.values() for r in rs])
    markers = "osD^v<>pPX*h"
    reasons: set[str] = set()
    invalid_x: list[float] = []
    invalid_a: list[float] = []
    invalid_e: list[float] = []
    for i, (fam, rs) in enumerate(sorted(fams.items())):
        rs = sorted(rs, key=lambda r: r.verdict.speed_ratio)
        x = [r.verdict.speed_ratio for r in rs]
        amp = [r.verdict.max_amplification for r in rs]
        err = [100 * r.verdict.verdict_error for r in rs]
        label = family_label(rs[0])
        own = _rpm_per_ratio(rs)
        if per is None and own is not None:
            label += f" (r = 0.1 at {rpm_text(0.1 * own)} rpm)"
        style = dict(marker=markers[i % len(markers)], ls="-" if fam.startswith("source") else "--", ms=5)
        ax_a.plot(x, amp, label=label, **style)
        ax_e.plot(x, err, label=label, **style)
        for r, xi, ai, ei in zip(rs, x, amp, err):
            why = invalid_reasons(r)
            if why:
                reasons.update(why)
                invalid_x.append(xi)
                invalid_a.append(ai)
                invalid_e.append(ei)
    if invalid_x:
        label = "not valid: outside its model's range: " + "; ".join(sorted(reasons))
        ring = dict(marker="o", ms=11, mfc="none", mec=INVALID_COLOR, mew=1.5, ls="none")
        ax_a.plot(invalid_x, invalid_a, **ring)
        ax_e.plot(invalid_x, invalid_e, label=_wrap_label(label, 90), **ring)
    failed = [r for r in results if not r.ok and math.isfinite(r.speed_ratio)]
    for i, r in enumerate(failed):
        for ax in (ax_a, ax_e):
            ax.axvline(r.speed_ratio, color="r", lw=0.8, ls=":", label="failed scene (no error)" if i == 0 and
                       ax is ax_e else None)
    ax_a.axhline(1.0, color="k", lw=0.8)
    xlabel = "speed ratio r = Omega / omega1_min [1]"
    ax_a.set_xlabel(xlabel)
    ax_a.set_ylabel("max|reference| / max|quasi-static| [1], worst component")
    ax_a.set_title("dynamic amplification", fontsize=10)
    ax_e.set_xlabel(xlabel)
    ax_e.set_ylabel("quasi-static history error of (dx, dy) [%]")
    tols = {r.verdict.tolerance for rs in fams.values() for r in rs}
    if tolerance is None and len(tols) == 1:
        tolerance = tols.pop()
    if tolerance is not None:
        ax_e.axhline(100 * tolerance, color="r", lw=1, ls=":", label=f"tolerance {tolerance:.0%}")
    errors = [100 * r.verdict.verdict_error for rs in fams.values() for r in rs]
    if error_scale(errors, tolerance) == "log":
        from matplotlib.ticker import FuncFormatter

        ax_e.set_yscale("log", nonpositive="mask")
        ax_e.yaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
        ax_e.set_ylabel(ax_e.get_ylabel() + ", log scale")
    ax_e.set_title("quasi-static error relative to the reference's peak", fontsize=10)
    for ax in (ax_a, ax_e):
        ax.grid(alpha=0.3)
        if per is not None:
            top = ax.secondary_xaxis("top", functions=(lambda r, k=per: r * k, lambda n, k=per: n / k))
            top.set_xlabel("crank speed [rpm]", fontsize=9)
    if fams or failed:
        handles, labels = ax_e.get_legend_handles_labels()
        fig.legend(handles, labels, fontsize=7, loc="outside lower center", ncols=min(3, len(labels)),
                   frameon=False)
    return fig


ERROR_DECADES = 1.0
"""The error axis of the amplification figure is logarithmic where the errors [%] and the tolerance span
more than this many decades (largest over smallest positive value above 10): on a linear axis the
tolerance line would sit among errors of 100 % and more, squeezed at the bottom."""


def error_scale(errors_pct: Sequence[float], tolerance: float | None = None) -> str:
    """``"log"`` or ``"linear"``: the scale of an error axis showing ``errors_pct`` [%] and the tolerance
    line (a fraction, e.g. 0.10) (see :data:`ERROR_DECADES`)."""
    values = [e for e in errors_pct if math.isfinite(e) and e > 0]
    if tolerance is not None and tolerance > 0:
        values.append(100 * tolerance)
    if len(values) < 2:
        return "linear"
    return "log" if math.log10(max(values) / min(values)) > ERROR_DECADES else "linear"


def _wrap_label(text: str, width: int = 45) -> str:
    import textwrap

    lines = textwrap.wrap(text, width=width, break_on_hyphens=False)
    return (" " if text.startswith(" ") else "") + "\n".join(lines)
