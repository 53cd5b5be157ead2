"""Summaries of stored scenes: table rows, detail records and their text rendering (pure functions).

Every registered solver that a scene ran gets its own columns; nothing here names a solver except
the quasi-static one, whose error decides the verdict (:data:`compare.metrics.VERDICT_METRIC`: the
history error of the deflection vector (dx, dy)).  The quasi-static rotation's history error has its
own column and never enters the verdict.  Column units: rpm [rev/min], Omega/w1 [1] (crank speed over
the lowest first natural circular frequency), errors relative to the reference's peak [%],
amplification [1], wall time [s].
"""

from __future__ import annotations

import math
import textwrap
from collections.abc import Sequence
from dataclasses import asdict
from typing import Any

from compare import solvers as registry
from compare.metrics import VERDICT_METRIC, pair_name
from compare.results import SceneResult
from compare.scenes import FOUR_BAR, SLIDER_KIND
from compare.solvers import STRESS_PREFIX


def _num(x: float | None) -> float | None:
    return None if x is None or (isinstance(x, float) and not math.isfinite(x)) else float(x)


def rpm_text(rpm: float) -> str:
    """A crank speed [rev/min] as a plain number of four significant digits, never in exponent notation
    (11043.2 -> "11040", 81.818 -> "81.82", 0.5 -> "0.5")."""
    import numpy as np

    if not math.isfinite(rpm):
        return str(rpm)
    return np.format_float_positional(rpm, precision=4, unique=False, fractional=False, trim="-")


def short_reason(r: SceneResult, n: int = 60) -> str:
    """One short line on why a scene failed ("" if it did not)."""
    if r.ok:
        return ""
    cls = f"{r.failure_class}: " if r.failure_class else ""
    first = r.message.split("\n")[0].split(" (time=")[0]
    text = f"{r.stage}: {cls}{first}"
    return text if len(text) <= n else text[: n - 3] + "..."


def summary_row(r: SceneResult) -> dict[str, Any]:
    """One summary record (JSON-serialisable; non-finite numbers become ``None``).

    ``verdict_error`` is the verdict error (quasi-static against the reference, history error of the
    deflection vector (dx, dy)) and ``holds`` the verdict (``verdict_error`` < tolerance); for every other
    solver that is not the reference, ``verdict_error_<solver>`` is its own error of the same measure.
    ``relative_error_<component>`` and ``amplification_<component>`` are per component (dx, dy,
    rotation, vector).  Kept with their old meaning, not verdicts: ``max_relative_error`` and
    ``error_<solver>``, the worst history error of dx, dy and rotation (the campaign verdict's measure
    before the vector one), and ``max_amplification``, the worst component's amplification.  A scene with link
    stresses adds the stress verdict: ``stress_error`` (the quasi-static stress's history error against the
    reference's, worst link), ``stress_worst_link`` and ``stress_holds`` (``stress_error`` < tolerance);
    ``relative_error_stress_<link>`` per link."""
    v = r.verdict
    ref = r.reference
    row: dict[str, Any] = {
        "key": r.key, "label": r.spec.label, "mechanism": r.spec.mechanism, "mass_model": r.spec.mass_model.name,
        "rpm": _num(r.rpm), "speed_ratio": _num(r.speed_ratio), "status": r.status, "stage": r.stage,
        "message": r.message, "failure_class": r.failure_class, "reason": short_reason(r),
        "solvers": list(r.solutions), "reference": ref,
        "verdict_error": _num(v.verdict_error) if v else None,
        "max_relative_error": _num(v.worst_component_error) if v else None,
        "max_amplification": _num(v.max_amplification) if v else None,
        "holds": v.holds if v else None, "wall_s": _num(r.stats.total_wall_s),
    }
    if v:
        for c in v.components:
            row[f"relative_error_{c.component}"] = _num(c.history_error)
            row[f"amplification_{c.component}"] = _num(c.amplification)
        if v.stress_worst is not None:
            row.update(stress_error=_num(v.stress_error), stress_holds=v.stress_holds,
                       stress_worst_link=v.stress_worst.component.removeprefix(STRESS_PREFIX))
    for name in r.solutions:
        m = r.metrics.get(pair_name(name, ref)) if ref else None
        if name not in ("quasi_static", ref) and m is not None:
            row[f"verdict_error_{name}"] = _num(m.verdict_error)
            row[f"error_{name}"] = _num(m.worst_component_error)
        if r.solutions[name].flags:
            row[f"flags_{name}"] = list(r.solutions[name].flags)
    return row


def verdict_text(holds: bool | None) -> str:
    return "-" if holds is None else ("holds" if holds else "FAILS")


WIDTH = 100
"""Columns of every human-readable line (tables, notes) by default."""


def _wrap(text: str, indent: str = "  ", width: int = WIDTH) -> str:
    """``text`` wrapped to ``width`` columns (continuation lines indented); long words never split."""
    return textwrap.fill(text, width=width, subsequent_indent=indent, break_on_hyphens=False, break_long_words=False)


def _columns(rows: Sequence[dict[str, Any]], wide: bool = True) -> list[tuple[str, str, str]]:
    """(row key, title, format) of the table's columns; a title's "\n" splits it over header lines.
    ``wide``: every column with long titles; else the compact layout (short titles, no status or
    wall time: the verdict column says "failed", the reasons follow the table)."""
    extra = sorted({k[len(_OTHER):] for row in rows for k in row if k.startswith(_OTHER)}, key=registry.fidelity)
    if wide:
        cols = [("key", "key", "{}"), ("label", "scene", "{}"), ("rpm", "rpm", "{:.1f}"),
                ("speed_ratio", "Omega/w1", "{:.3f}"), ("status", "status", "{}"),
                ("verdict_error", "quasi-static err %", "%"), ("relative_error_rotation", "qs rot err %", "%")]
        cols += [(_OTHER + k, f"{registry.label(k)} err %", "%") for k in extra]
        cols += [("max_amplification", "amplif.", "{:.3f}"), ("holds", "verdict", "")]
        cols += _stress_columns(rows, wide) + [("wall_s", "wall s", "{:.1f}")]
        if any(row.get("reason") for row in rows):
            cols.append(("reason", "reason (failed scenes)", "{}"))
        return cols
    cols = [("key", "key", "{}"), ("label", "scene", "{}"), ("rpm", "rpm", "{:.1f}"),
            ("speed_ratio", "r", "{:.3f}"), ("verdict_error", "qs\nerr %", "%"),
            ("relative_error_rotation", "qs rot\nerr %", "%")]
    cols += [(_OTHER + k, "\n".join(k.split("_")) + "\nerr %", "%") for k in extra]
    cols += [("max_amplification", "amplif.", "{:.3f}"), ("holds", "verdict", "")]
    return cols + _stress_columns(rows, wide)


def _stress_columns(rows: Sequence[dict[str, Any]], wide: bool) -> list[tuple[str, str, str]]:
    """The stress verdict's columns, where a scene has link stresses."""
    if not any("stress_error" in row for row in rows):
        return []
    if wide:
        return [("stress_error", "qs stress err %", "%"), ("stress_holds", "stress verdict", "")]
    return [("stress_error", "qs stress\nerr %", "%"), ("stress_holds", "stress\nverdict", "")]


_OTHER = "verdict_error_"
"""Key prefix of the verdict error of a solver other than the quasi-static one."""
_QUASI_STATIC_KEYS = ("verdict_error", "relative_error_rotation", "max_relative_error", "stress_error")

FLAG_MARK = "*"
FLAG_NOTE = (f"{FLAG_MARK} that solver's answer is outside the range where its model holds (validity flags, "
             "e.g. large_deflection); the number is not a valid answer: `ked inspect FILE KEY` names the flags")
"""The note of the wide layout before it named the solvers (kept for callers; see :func:`flag_note`)."""


def _solver_of(key: str) -> str | None:
    return ("quasi_static" if key in _QUASI_STATIC_KEYS else key[len(_OTHER):] if key.startswith(_OTHER)
            else None)


def _flagged(row: dict[str, Any], key: str) -> bool:
    """An error whose solver's answer, or whose reference (every error is measured against it), carries
    validity flags."""
    solver = _solver_of(key)
    return solver is not None and (bool(row.get(f"flags_{solver}")) or bool(row.get(f"flags_{row.get('reference')}")))


def flag_note(rows: Sequence[dict[str, Any]]) -> str:
    """The note under a table whose errors carry :data:`FLAG_MARK`: which solver's answers are outside
    their model's range, in how many scenes, and the flags (empty if none)."""
    found: dict[str, tuple[int, set[str]]] = {}
    for row in rows:
        for k, v in row.items():
            if k.startswith("flags_") and v:
                n, flags = found.get(k[len("flags_"):], (0, set()))
                found[k[len("flags_"):]] = (n + 1, flags | set(v))
    if not found:
        return ""
    parts = [f"{registry.label(s)} in {n} scene{'s' if n != 1 else ''} ({', '.join(sorted(f))})"
             for s, (n, f) in sorted(found.items(), key=lambda kv: registry.fidelity(kv[0]))]
    return _wrap(f"{FLAG_MARK} an error of an answer outside the range where its model holds, not a valid answer: "
                 + "; ".join(parts) + ". `ked inspect FILE KEY` names the flags of each solver.")


def _short_keys(rows: Sequence[dict[str, Any]], n: int = 8) -> dict[str, str]:
    """Key -> its shortest prefix of at least ``n`` hex digits that no other row's key shares (a
    prefix names the scene in `ked inspect FILE KEY`)."""
    keys = [str(row.get("key", "")) for row in rows]
    out = {}
    for k in keys:
        m = n
        while m < len(k) and any(o != k and o.startswith(k[:m]) for o in keys):
            m += 1
        out[k] = k[:m]
    return out


def _common_segments(labels: Sequence[str]) -> list[tuple[int, str]]:
    """(position, text) of the label segments ("/"-separated) that every label shares."""
    split = [lb.split("/") for lb in labels]
    if not split or len({len(s) for s in split}) != 1:
        return []
    return [(i, seg) for i, seg in enumerate(split[0]) if all(s[i] == seg for s in split)]


def _render(rows: Sequence[dict[str, Any]], cols: list[tuple[str, str, str]], marked: bool,
            text: dict[str, dict[str, str]] | None = None) -> list[str]:
    """The table's lines (header lines, a rule, one line per row); ``text``: row key -> column ->
    replacement cell text."""

    def cell(row: dict[str, Any], key: str, fmt: str) -> str:
        own = (text or {}).get(str(row.get("key")), {})
        if key in own:
            return own[key]
        v = row.get(key)
        if key == "stress_holds":
            return "-" if v is None else verdict_text(v)
        if key == "holds":
            return "failed" if row.get("status") not in (None, "ok") and text is not None else verdict_text(v)
        if v is None or v == "":
            return "-"
        mark = FLAG_MARK if _flagged(row, key) else " " if marked else ""
        out = f"{100.0 * v:.1f}" if fmt == "%" else fmt.format(v)
        if text is not None and len(out) > 7 and isinstance(v, float):  # compact: 3 digits of a huge number
            out = f"{100.0 * v:.3g}" if fmt == "%" else f"{v:.3g}"
        return out + mark if fmt == "%" else out

    titles = [title.split("\n") for _, title, _ in cols]
    depth = max(len(t) for t in titles)
    head = [[""] * (depth - len(t)) + t for t in titles]
    body = [[cell(row, key, fmt) for key, _, fmt in cols] for row in rows]
    widths = [max([len(x) for x in head[i]] + [len(r[i]) for r in body]) for i in range(len(cols))]
    left = {"key", "label", "status", "holds", "stress_holds", "reason"}

    # two spaces around a text column, one between two numbers (right-aligned, so they stay apart)
    seps = ["" if i == 0 else " " if text is not None and cols[i][0] not in left and cols[i - 1][0] not in left
            else "  " for i in range(len(cols))]

    def line(parts: Sequence[str]) -> str:
        return "".join(seps[i] + (p.ljust(widths[i]) if cols[i][0] in left else p.rjust(widths[i]))
                       for i, p in enumerate(parts)).rstrip()

    lines = [line([h[d] for h in head]) for d in range(depth)]
    lines.append(line(["-" * w for w in widths]))
    return lines + [line(r) for r in body]


def format_table(rows: Sequence[dict[str, Any]], wide: bool = True, width: int = WIDTH) -> str:
    """Fixed-width text table of summary rows; an error whose solver's answer carries validity flags is
    marked with :data:`FLAG_MARK` and explained in a note under the table, naming the solver.

    ``wide``: every column with its long title (the failure reason in the last column; lines may be
    longer than ``width``); else the compact layout of at most ``width`` columns: keys shortened to a
    unique prefix, label segments that every scene shares stated above the table where the full labels
    do not fit, r = Omega/omega1_min, no status or wall time, failure reasons listed under the table."""
    cols = _columns(rows, wide)
    marked = any(_flagged(row, key) and row.get(key) is not None for row in rows for key, _, _ in cols)
    note = flag_note(rows) if marked else ""
    if wide:
        return "\n".join(_render(rows, cols, marked) + ([note] if note else []))
    keys = _short_keys(rows)
    text = {str(row.get("key")): {"key": keys[str(row.get("key", ""))]} for row in rows}
    lines = _render(rows, cols, marked, text)
    above = []
    labels = [str(row.get("label", "")) for row in rows]
    if max(map(len, lines)) > width and len(rows) > 1:
        common = _common_segments(labels)
        drop = {i for i, _ in common}
        if drop and len(drop) < len(labels[0].split("/")):
            for row, lb in zip(rows, labels):
                text[str(row.get("key"))]["label"] = "/".join(s for i, s in enumerate(lb.split("/")) if i not in drop)
            above = [_wrap("every scene: " + ", ".join(
                f"{_SEGMENT_NAMES[i] if i < len(_SEGMENT_NAMES) else 'part'} {seg}" for i, seg in common)
                + " (scene column: the rest of the label)")]
            lines = _render(rows, cols, marked, text)
    over = max(map(len, lines)) - width
    if over > 0:  # a label too long even so: shorten it (the key names the scene; --wide shows it whole)
        room = max(8, max(len(text[str(r.get("key"))].get("label", lb)) for r, lb in zip(rows, labels)) - over)
        for row, lb in zip(rows, labels):
            t = text[str(row.get("key"))].get("label", lb)
            text[str(row.get("key"))]["label"] = t if len(t) <= room else t[: room - 3] + "..."
        lines = _render(rows, cols, marked, text)
    legend = _wrap("r = Omega/omega1_min; errors: history error relative to the reference's peak, qs = "
                   "quasi-static (the verdict: its vector (dx, dy) error; rot: its rotation's error), other "
                   "solvers: their vector error; --wide: all columns and whole labels")
    reasons = [_wrap(f"failed {keys[str(row.get('key', ''))]}: {_failure_text(row)}", indent="    ")
               for row in rows if row.get("reason")]
    return "\n".join(above + lines + [legend] + ([note] if note else []) + reasons)


def _failure_text(row: dict[str, Any]) -> str:
    """Where (the solver's label when a solver failed), why and the first line of the message."""
    stage = str(row.get("stage") or "")
    where = registry.label(stage) if stage in registry.names() else stage
    cls = f"{row['failure_class']}: " if row.get("failure_class") else ""
    first = str(row.get("message") or "").split("\n")[0].split(" (time=")[0]
    text = f"{where}: {cls}{first}"
    return text if len(text) <= 180 else text[:177] + "..."


_SEGMENT_NAMES = ("mechanism", "mass model", "speed", "stiffness", "damping", "direction")
"""What each "/"-separated segment of a scene label states (:attr:`compare.scenes.SceneSpec.label`)."""


def format_counts(results: Sequence[SceneResult]) -> str:
    """How many scenes, ok, failed (by class), verdicts; and which metric the verdict uses."""
    ok = [r for r in results if r.ok]
    holds = sum(1 for r in ok if r.verdict is not None and r.verdict.holds)
    failed = [r for r in results if not r.ok]
    classes = sorted({r.failure_class or "unclassified" for r in failed})
    by_class = ", ".join(f"{sum(1 for r in failed if (r.failure_class or 'unclassified') == c)} {c}" for c in classes)
    text = (f"{len(results)} scenes: {len(ok)} ok, {len(failed)} failed{f' ({by_class})' if failed else ''}; "
            f"quasi-static holds in {holds} of {len(ok)} ok scenes (verdict: {VERDICT_METRIC} "
            "against the highest-fidelity solver of the scene, below the campaign tolerance)")
    text = _wrap(text) + _stress_count(ok)
    if failed:
        text += "\nfailed scenes: `ked inspect FILE KEY` shows the whole message"
    return text


def _stress_count(ok: Sequence[SceneResult]) -> str:
    """The stress verdict's count line ("" without link stresses): against which reference it was measured."""
    with_stress = [r for r in ok if r.verdict is not None and r.verdict.stress_holds is not None]
    if not with_stress:
        return ""
    holds = sum(1 for r in with_stress if r.verdict.stress_holds)
    refs = sorted({registry.label(r.reference or "") for r in with_stress})
    caveat = ("" if refs == [registry.label("dynamic")] else
              "; measured against a reference that is not Exudyn, so it is not calibrated against Exudyn")
    return "\n" + _wrap(f"link stresses: the quasi-static stress holds in {holds} of {len(with_stress)} scenes "
                        f"(stress verdict: history error of each link's extreme-fibre stress against "
                        f"{' / '.join(refs)}, worst link, below the campaign tolerance{caveat})")


def _pair_record(m: Any) -> dict[str, Any]:
    return {"solver": m.solver, "reference": m.reference, "speed_ratio": _num(m.speed_ratio),
            "tolerance": m.tolerance, "holds": m.holds, "verdict_error": _num(m.verdict_error),
            "stress_error": _num(m.stress_error), "stress_holds": m.stress_holds,
            "verdict_metric": VERDICT_METRIC, "worst_component_error": _num(m.worst_component_error),
            "components": {c.component: {k: (_num(v) if isinstance(v, float) else v) for k, v in asdict(c).items()}
                           for c in m.components}}


def scene_detail(r: SceneResult) -> dict[str, Any]:
    """Everything about one scene as a JSON-serialisable dict (arrays as lists)."""

    def arr(a: Any) -> Any:
        return None if a is None else [[_num(float(x)) for x in row] if hasattr(row, "__len__") else
                                       _num(float(row)) for row in a]

    v = r.verdict
    return {
        "key": r.key, "label": r.spec.label, "status": r.status, "stage": r.stage, "error_type": r.error_type,
        "message": r.message, "failure_class": r.failure_class, "warnings": r.warnings, "rpm": _num(r.rpm),
        "omega1_min_rad_s": _num(r.omega1_min), "speed_ratio": _num(r.speed_ratio), "parameters": r.spec.to_dict(),
        "reference": r.reference,
        "verdict": None if v is None else {"holds": v.holds, "metric": VERDICT_METRIC, "error": _num(v.verdict_error),
                                           "worst_component_error": _num(v.worst_component_error)},
        "solutions": {n: {"status": s.status, "message": s.message, "error_type": s.error_type,
                          "failure_class": s.failure_class, "flags": list(s.flags), "settings": s.settings,
                          "stats": s.stats, "deflection": {c: arr(h) for c, h in s.deflection.items()},
                          "stress_pa": {lk: arr(h) for lk, h in s.stress.items()}}
                      for n, s in r.solutions.items()},
        "metrics": {name: _pair_record(m) for name, m in r.metrics.items()},
        "run_stats": asdict(r.stats),
        "crank_angle_rad": arr(r.crank_angle),
        "natural_frequencies_hz": arr(r.natural_frequencies),
    }


def _linkage_lines(s: Any) -> list[str]:
    """The mechanism and linkage lines of a scene's description (by its linkage kind)."""
    return _LINKAGE_LINES[s.kind](s, s.linkage)


def _four_bar_lines(s: Any, lk: Any) -> list[str]:
    return [f"  mechanism   : {s.mechanism}, branch {lk.branch}, direction {s.direction}",
            f"  linkage [m] : crank {lk.crank:.4g}, coupler {lk.coupler:.4g}, follower {lk.follower:.4g}, "
            f"extender {lk.extender:.4g}, coupler angle {math.degrees(lk.coupler_angle):.4g} deg"]


def _slider_lines(s: Any, lk: Any) -> list[str]:
    rigid = [n for n, r in zip(("crank", "coupler"), lk.rigid) if r]
    return [f"  mechanism   : slider-crank, direction {s.direction}",
            f"  linkage [m] : crank {lk.crank:.4g}, coupler {lk.coupler:.4g}, offset {lk.offset:.4g}, coupler "
            f"point at {lk.coupler_point:.4g} of the coupler, slider {lk.slider_mass:.4g} kg"
            + (f", rigid {' and '.join(rigid)}" if rigid else "")]


_LINKAGE_LINES = {FOUR_BAR: _four_bar_lines, SLIDER_KIND: _slider_lines}
"""Linkage kind -> its description lines (a new kind adds its entry)."""


def format_detail(r: SceneResult) -> str:
    """Human-readable description of one scene (no arrays)."""
    s = r.spec
    lines = [
        f"scene {r.key}  {s.label}",
        f"  status      : {r.status}" + (f" (stage {r.stage}, {r.failure_class or 'unclassified'}, {r.error_type}: "
                                         f"{r.message})" if not r.ok else ""),
        *_linkage_lines(s),
        f"  mass model  : {s.mass_model.name} (lumps {s.mass_model.lumps}, payload {s.mass_model.payload:.4g} kg)",
        f"  speed       : {s.speed.label()} -> {rpm_text(r.rpm)} rpm; omega1_min {r.omega1_min:.4g} rad/s; "
        f"Omega/omega1_min = {r.speed_ratio:.4g}",
        f"  stiffness x : {s.stiffness_scale:g}; damping ratio {s.damping_ratio:g}; grid step {s.step_deg:g} deg",
        f"  run stats   : total {r.stats.total_wall_s:.2f} s (frequencies {r.stats.frequencies_wall_s:.2f}); "
        f"worker {r.stats.worker}",
    ]
    for name, sol in r.solutions.items():
        stats = ", ".join(f"{k} {v:.3g}" if isinstance(v, float) else f"{k} {v}" for k, v in sol.stats.items())
        lines.append(f"  {registry.label(name):<12}: {sol.status}"
                     + (f" ({sol.failure_class or 'unclassified'}: {sol.message})" if not sol.ok else "")
                     + (f"; flags {', '.join(sol.flags)}" if sol.flags else "") + f"; {stats}")
        if sol.settings:
            lines.append(f"  {'':<12}  settings: {', '.join(f'{k}={v}' for k, v in sorted(sol.settings.items()))}")
    if r.warnings:
        lines.append(f"  warnings    : {r.warnings}")
    for m in r.metrics.values():
        lines.append(f"  {registry.label(m.solver)} vs {registry.label(m.reference)}: {verdict_text(m.holds)} "
                     f"(vector (dx, dy) history error {m.verdict_error:.1%}, tolerance {m.tolerance:.1%})"
                     + ("" if m.stress_holds is None else f"; stress {verdict_text(m.stress_holds)} (worst link's "
                        f"stress history error {m.stress_error:.1%})"))
        w = max(9, *(len(c.component) for c in m.components))
        lines.append(f"    {'component':<{w}}  units  max|err|     rms err      history  peak err  phase[deg]  amplif.")
        for c in m.components:
            lines.append(f"    {c.component:<{w}}  {c.units:<5}  {c.max_abs_error:<11.4g}  {c.rms_error:<11.4g}  "
                         f"{c.history_error:>7.1%}  {c.peak_error:>8.1%}  {math.degrees(c.phase_shift):>10.2f}  "
                         f"{c.amplification:>7.3f}")
    return "\n".join(_wrap(ln, indent=" " * 16) if len(ln) > WIDTH else ln for ln in lines)


def sort_key(r: SceneResult) -> tuple:
    """Grid-like display order: mechanism, mass model, stiffness, damping, direction, speed."""
    return spec_sort_key(r.spec)


def spec_sort_key(s: Any) -> tuple:
    """:func:`sort_key` of a scene not yet computed (a :class:`~compare.scenes.SceneSpec`)."""
    return (s.mechanism, s.mass_model.name, s.stiffness_scale, s.damping_ratio, s.direction,
            s.speed.kind, s.speed.value, s.key)


def find_scene(results: Sequence[SceneResult], ident: str) -> SceneResult:
    """Scene whose key starts with ``ident`` or whose label equals it, or that a label the summary table prints
    names (:func:`label_names`: segments every scene shares dropped, a long label cut with "..."); ValueError
    if none/ambiguous."""
    hits = [r for r in results if r.key.startswith(ident) or r.spec.label == ident]
    if not hits:
        hits = [r for r in results if label_names(ident, r.spec.label)]
    if not hits:
        raise ValueError(f"no scene matches {ident!r}")
    if len(hits) > 1:
        raise ValueError(f"{ident!r} is ambiguous: {', '.join(r.key for r in hits)}")
    return hits[0]


def label_names(shown: str, label: str) -> bool:
    """True when ``shown``, a label as a table prints it, names the scene ``label``: its "/"-separated segments
    are segments of ``label`` in their order (the table drops the segments every scene shares), the last one
    possibly cut with "..." (a label too long for the table)."""
    cut = shown.endswith("...")
    want = (shown[:-3] if cut else shown).split("/")
    have = label.split("/")
    i = 0
    for n, seg in enumerate(want):
        last = n == len(want) - 1
        while i < len(have) and not (have[i] == seg or (last and cut and have[i].startswith(seg))):
            i += 1
        if i == len(have):
            return False
        i += 1
    return bool(shown)
