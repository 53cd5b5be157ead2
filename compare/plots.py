"""Figures of a campaign, PNG unless asked (:data:`FORMATS`; matplotlib object API, no global pyplot state).
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

``index.json`` maps each scene figure to its key, label and a stamp of the stored scene; a figure
whose stamp is unchanged is not drawn again.  Its entry ``"@ked-harness"`` (not a file) is the manifest:
``{"written_by": "ked-harness", "files": [...], "results_file": ..., "results_id": ...}``, every file the
harness wrote in the directory and the results file they were drawn from (one per directory).  A
file of the same name that the manifest does not list (the user's own ``index.json``, ``amplification.png``
or ``scene_*.png``) is never overwritten: :class:`FigureDirError` names it instead.
"""

from __future__ import annotations

import contextlib
import json
import math
from collections import defaultdict
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from compare import solvers as registry
from compare.inspect import rpm_text, speed_ratio
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
        f"{speed_ratio(r):.3g}, {status}{verdict}",
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
    failed = [r for r in results if not r.ok and math.isfinite(speed_ratio(r))]
    for i, r in enumerate(failed):
        for ax in (ax_a, ax_e):
            ax.axvline(speed_ratio(r), color="r", lw=0.8, ls=":", label="failed scene (no error)" if i == 0 and
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


FORMATS = ("png", "svg", "pdf")
"""File formats of the figures (matplotlib's writers); PNG unless asked."""
DPI = 110
"""Resolution of the figures [dots per inch] unless asked (PNG; SVG and PDF are vector drawings)."""


class FigureWriteError(OSError):
    """A figure (or the index) could not be written: its ``filename`` names the file."""


def save_figure(fig: Figure, path: Path, dpi: int = DPI, metadata: dict | None = None) -> Path:
    """Write ``fig`` to ``path`` (format from its suffix) through a temporary file renamed into place:
    ``path`` is either its old self or the whole new figure.  An OS failure (a full disk) removes the
    temporary file and raises :class:`FigureWriteError` naming ``path``."""
    tmp = path.with_name(path.name + ".tmp")
    try:
        fig.savefig(tmp, dpi=dpi, format=path.suffix[1:], metadata=metadata)
        tmp.replace(path)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise FigureWriteError(exc.errno, exc.strerror or str(exc), str(path)) from None
    return path


def _write_scene_png(r: SceneResult, path: Path, dpi: int) -> Path:
    return save_figure(scene_figure(r), path, dpi, metadata={"Title": f"{r.spec.label} [{r.key}]"})


def figure_names(results: Sequence[SceneResult], fmt: str = "png") -> dict[str, str]:
    """key -> file name of its scene figure: the label, plus the key where labels repeat."""
    safe = {r.key: "scene_" + "".join(ch if ch.isalnum() or ch in "-." else "_" for ch in r.spec.label)
            for r in results}
    counts = defaultdict(int)
    for name in safe.values():
        counts[name] += 1
    return {k: (f"{n}_{k}" if counts[n] > 1 else n) + f".{fmt}" for k, n in safe.items()}


def _stamp(r: SceneResult, dpi: int = DPI) -> str:
    """What a scene figure depends on: the stored scene (finished time, status, solvers), the resolution
    and this module."""
    return (f"{r.key}|{r.status}|{r.stats.finished_utc}|{','.join(sorted(r.solutions))}|{_FIGURE_VERSION}"
            + ("" if dpi == DPI else f"|dpi{dpi}"))


_FIGURE_VERSION = 4


MANIFEST = "@ked-harness"
"""The entry of ``index.json`` that lists the files the harness wrote in its directory."""
INDEX = "index.json"
AMPLIFICATION = "amplification.png"


def amplification_name(fmt: str = "png") -> str:
    """The file name of the amplification figure in format ``fmt``."""
    return f"amplification.{fmt}"


class FigureDirError(ValueError):
    """The figure directory holds a file of a name the harness would write that the harness did not write,
    or the figures of another results file."""


def _owned(out: Path) -> tuple[dict, set[str], tuple[str, str] | None]:
    """The scene entries of ``out``'s index, the names of the files the harness wrote there and the
    results file they were drawn from (its identity and path; None: not recorded).  Raises :class:`FigureDirError` if
    ``index.json`` exists but is not a figure index of the harness."""
    import json

    index_path = out / INDEX
    if not index_path.exists() and not index_path.is_symlink():
        return {}, set(), None
    try:
        data = json.loads(index_path.read_text()) if index_path.is_file() else None
    except (OSError, ValueError):  # includes undecodable bytes
        data = None
    manifest = data.get(MANIFEST) if isinstance(data, dict) else None
    entries = {k: v for k, v in data.items() if k != MANIFEST} if isinstance(data, dict) else {}
    legacy = bool(entries) and all(isinstance(v, dict) and {"key", "label", "stamp"} <= set(v)
                                   for v in entries.values())
    source = None
    if isinstance(manifest, dict) and manifest.get("written_by") == "ked-harness":
        files = {f for f in manifest.get("files", []) if isinstance(f, str)}
        if isinstance(manifest.get("results_id"), str):
            source = (manifest["results_id"], str(manifest.get("results_file")))
    elif legacy and manifest is None:  # written by a harness version before the manifest
        files = set(entries) | {AMPLIFICATION}
    else:
        raise FigureDirError(f"{index_path}: not a figure index written by ked-harness (a file of yours?); it is "
                             "left as it is: choose another figure directory")
    return entries, files | {INDEX}, source


def _source_id(source: str | Path | None) -> str | None:
    """Which results file figures were drawn from: its file name and creation time (a results file moved
    with its figure directory is still the same one; a copy under another name is not)."""
    if source is None:
        return None
    from compare import store

    try:
        created = str(store.file_info(source).get("created_utc", ""))
    except (store.StoreError, OSError):
        created = ""
    return f"{Path(source).name}|{created}"


def check_figure_dir(out_dir: str | Path, names: Sequence[str] = (), fmt: str = "png",
                     source: str | Path | None = None) -> None:
    """Refuse (:class:`FigureDirError`, naming the file) if writing the figures ``names`` (besides the
    index and the amplification figure in format ``fmt``) into ``out_dir`` would overwrite a file the
    harness did not write, or if the directory holds the figures of a results file other than ``source``
    (one figure directory, one index, per results file)."""
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise FigureDirError(f"{out}: not a directory; the figures need a directory")
    _, files, drawn_from = _owned(out)
    mine = _source_id(source)
    if mine is not None and drawn_from is not None and drawn_from[0] != mine:
        raise FigureDirError(f"{out}: holds the figures of another results file ({drawn_from[1]}); they are "
                             f"left as they are: choose another figure directory for {source}")
    for name in (INDEX, amplification_name(fmt), *names):
        if (out / name).exists() or (out / name).is_symlink():
            if name not in files:
                raise FigureDirError(f"{out / name}: exists and was not written by ked-harness (not in its "
                                     f"{INDEX}); it is left as it is: choose another figure directory")


def _draw_in_pool(jobs: list[tuple[SceneResult, Path]], dpi: int, workers: int, written: list[Path],
                  on_each: Callable[[Path], Any] | None) -> None:
    """Scene figures in ``workers`` spawned processes that die with this one (no orphan keeps drawing
    after kill -9) and are killed at once on an interrupt or failure; each figure written is appended to
    ``written`` as it completes."""
    import concurrent.futures as cf
    import multiprocessing

    from compare.executor import _start_children_quietly, default_workers, kill_pool, worker_init

    pool = cf.ProcessPoolExecutor(min(workers, default_workers()), mp_context=multiprocessing.get_context("spawn"),
                                  initializer=worker_init)
    try:
        with _start_children_quietly():
            futures = [pool.submit(_write_scene_png, r, p, dpi) for r, p in jobs]
        for f in cf.as_completed(futures):
            written.append(f.result())
            if on_each is not None:
                on_each(written[-1])
    except BaseException:
        kill_pool(pool)
        raise
    pool.shutdown(wait=True)


def figure_count(results: Sequence[SceneResult]) -> int:
    """How many figures :func:`write_figures` draws at most for ``results`` (a progress bar's total)."""
    return len(results) + 1


def write_figures(results: Sequence[SceneResult], out_dir: str | Path, dpi: int = DPI,
                  workers: int = 1, fmt: str = "png", source: str | Path | None = None,
                  on_each: Callable[[Path], Any] | None = None) -> list[Path]:
    """Write the campaign figures (format ``fmt``, one of :data:`FORMATS`) into ``out_dir`` (scene
    figures in ``workers`` processes), skipping scene figures whose stored scene did not change; returns
    the paths written.  Only files the harness wrote there for the results file ``source`` are replaced
    (see :class:`FigureDirError`).  Each figure goes through a temporary file renamed into place; then
    the index, the same way, lists only the figures there.  An OS failure (a full disk) raises
    :class:`FigureWriteError` naming the file, after the index is brought up to date where it can be.
    ``on_each``: called with each path written (progress)."""
    if fmt not in FORMATS:
        raise ValueError(f"figure format {fmt!r}: allowed {', '.join(FORMATS)}")
    out = Path(out_dir)
    names = figure_names(results, fmt)
    amp_name = amplification_name(fmt)
    check_figure_dir(out, sorted(names.values()), fmt, source)
    out.mkdir(parents=True, exist_ok=True)
    old, files, _ = _owned(out)
    index = {names[r.key]: {"key": r.key, "label": r.spec.label, "stamp": _stamp(r, dpi)} for r in results}
    jobs = [(r, out / names[r.key]) for r in results
            if old.get(names[r.key], {}).get("stamp") != _stamp(r, dpi) or not (out / names[r.key]).exists()]
    head = {"written_by": "ked-harness"} | ({"results_file": str(Path(source).resolve()),
                                             "results_id": _source_id(source)} if source is not None else {})
    # the claim first (the files about to be written are the harness's, should it be stopped mid-way);
    # the scene entries only for figures that are there
    claimed = (files | set(index) | {amp_name}) - {INDEX}
    kept = {k: v for k, v in old.items() if (out / k).exists()}
    if jobs or not (out / INDEX).exists() or claimed != files - {INDEX}:
        _write_index(out / INDEX, {**kept, MANIFEST: head | {"files": sorted(claimed)}})
    written: list[Path] = []
    try:
        if workers > 1 and len(jobs) > 2 * workers:
            _draw_in_pool(jobs, dpi, workers, written, on_each)
        else:
            for r, p in jobs:
                written.append(_write_scene_png(r, p, dpi))
                if on_each is not None:
                    on_each(written[-1])
        p = out / amp_name
        if jobs or not p.exists() or set(old) != set(index):
            written.append(save_figure(amplification_figure(results), p, dpi))
            if on_each is not None:
                on_each(p)
    except BaseException:  # the index lists what is there; the first failure is the one reported
        with contextlib.suppress(OSError):
            _final_index(out, kept, index, written, claimed, head)
        raise
    _final_index(out, kept, index, written, claimed, head)
    return written


def _final_index(out: Path, kept: dict, index: dict, written: list[Path], claimed: set[str], head: dict) -> None:
    """The index after drawing: the scene entries of the figures there (a figure not redrawn keeps its
    old entry: its old content is there), the manifest listing the harness's files that exist."""
    done = {p.name for p in written}
    entries = kept | {k: v for k, v in index.items() if k in done}
    final = {**entries, MANIFEST: head | {"files": sorted(f for f in claimed if (out / f).exists())}}
    try:
        current = json.loads((out / INDEX).read_text())
    except (OSError, ValueError):
        current = None
    if _moved_only(current, final):  # the same results file by another path (moved, a bind mount): record it
        with contextlib.suppress(OSError):  # where it can be: nothing else changed (a read-only copy stays valid)
            _write_index(out / INDEX, final)
    elif current != final:
        _write_index(out / INDEX, final)


def _moved_only(current: object, final: dict) -> bool:
    """Whether the index on disk differs from ``final`` only in the results file's path (same results id)."""
    if not isinstance(current, dict) or not isinstance(current.get(MANIFEST), dict):
        return False
    path = final[MANIFEST].get("results_file")
    return current != final and {**current, MANIFEST: {**current[MANIFEST], "results_file": path}} == final


def _write_index(index_path: Path, index: dict) -> None:
    tmp = index_path.with_name(index_path.name + ".tmp")
    try:
        tmp.write_text(json.dumps(index, indent=1, sort_keys=True))
        tmp.replace(index_path)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise FigureWriteError(exc.errno, exc.strerror or str(exc), str(index_path)) from None
