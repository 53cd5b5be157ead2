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
from collections.abc import Sequence
from dataclasses import asdict
from typing import Any

from compare import solvers as registry
from compare.metrics import VERDICT_METRIC, pair_name
from compare.results import SceneResult
from ked_quasi.units import rpm_to_rad_s


def _num(x: float | None) -> float | None:
    return None if x is None or (isinstance(x, float) and not math.isfinite(x)) else float(x)


def speed_ratio(r: SceneResult) -> float:
    """Omega / omega1_min [1] (nan if unknown)."""
    if not (math.isfinite(r.rpm) and math.isfinite(r.omega1_min) and r.omega1_min > 0):
        return math.nan
    return rpm_to_rad_s(r.rpm) / r.omega1_min


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
    before the vector one), and ``max_amplification``, the worst component's amplification."""
    v = r.verdict
    ref = r.reference
    row: dict[str, Any] = {
        "key": r.key, "label": r.spec.label, "mechanism": r.spec.mechanism, "mass_model": r.spec.mass_model.name,
        "rpm": _num(r.rpm), "speed_ratio": _num(speed_ratio(r)), "status": r.status, "stage": r.stage,
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


def _columns(rows: Sequence[dict[str, Any]]) -> list[tuple[str, str, str]]:
    extra = sorted({k[len(_OTHER):] for row in rows for k in row if k.startswith(_OTHER)}, key=registry.fidelity)
    cols = [("key", "key", "{}"), ("label", "scene", "{}"), ("rpm", "rpm", "{:.1f}"),
            ("speed_ratio", "Omega/w1", "{:.3f}"), ("status", "status", "{}"),
            ("verdict_error", "quasi-static err %", "%"), ("relative_error_rotation", "qs rot err %", "%")]
    cols += [(_OTHER + k, f"{registry.label(k)} err %", "%") for k in extra]
    cols += [("max_amplification", "amplif.", "{:.3f}"), ("holds", "verdict", ""), ("wall_s", "wall s", "{:.1f}")]
    if any(row.get("reason") for row in rows):
        cols.append(("reason", "reason (failed scenes)", "{}"))
    return cols


_OTHER = "verdict_error_"
"""Key prefix of the verdict error of a solver other than the quasi-static one."""
_QUASI_STATIC_KEYS = ("verdict_error", "relative_error_rotation", "max_relative_error")

FLAG_MARK = "*"
FLAG_NOTE = (f"{FLAG_MARK} that solver's answer is outside the range where its model holds (validity flags, "
             "e.g. large_deflection); the number is not a valid answer: `ked inspect FILE KEY` names the flags")


def _flagged(row: dict[str, Any], key: str) -> bool:
    solver = ("quasi_static" if key in _QUASI_STATIC_KEYS else key[len(_OTHER):] if key.startswith(_OTHER)
              else None)
    return solver is not None and bool(row.get(f"flags_{solver}"))


def format_table(rows: Sequence[dict[str, Any]]) -> str:
    """Fixed-width text table of summary rows; an error whose solver's answer carries validity flags is
    marked with :data:`FLAG_MARK` and explained in a note under the table."""
    cols = _columns(rows)
    marked = any(_flagged(row, key) and row.get(key) is not None for row in rows for key, _, _ in cols)

    def cell(row: dict[str, Any], key: str, fmt: str) -> str:
        v = row.get(key)
        if key == "holds":
            return verdict_text(v)
        if v is None or v == "":
            return "-"
        mark = FLAG_MARK if _flagged(row, key) else " " if marked else ""
        return f"{100.0 * v:.1f}{mark}" if fmt == "%" else fmt.format(v)

    table = [[title for _, title, _ in cols]] + [[cell(row, key, fmt) for key, _, fmt in cols] for row in rows]
    widths = [max(len(r[i]) for r in table) for i in range(len(cols))]
    left = {"key", "label", "status", "holds", "reason"}
    lines = []
    for n, r in enumerate(table):
        parts = [r[i].ljust(widths[i]) if cols[i][0] in left else r[i].rjust(widths[i]) for i in range(len(cols))]
        lines.append("  ".join(parts).rstrip())
        if n == 0:
            lines.append("  ".join("-" * w for w in widths))
    if marked:
        lines.append(FLAG_NOTE)
    return "\n".join(lines)


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
    if failed:
        text += "\nfailed scenes: `ked inspect FILE KEY` shows the whole message"
    return text


def _pair_record(m: Any) -> dict[str, Any]:
    return {"solver": m.solver, "reference": m.reference, "speed_ratio": _num(m.speed_ratio),
            "tolerance": m.tolerance, "holds": m.holds, "verdict_error": _num(m.verdict_error),
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
        "omega1_min_rad_s": _num(r.omega1_min), "speed_ratio": _num(speed_ratio(r)), "parameters": r.spec.to_dict(),
        "reference": r.reference,
        "verdict": None if v is None else {"holds": v.holds, "metric": VERDICT_METRIC, "error": _num(v.verdict_error),
                                           "worst_component_error": _num(v.worst_component_error)},
        "solutions": {n: {"status": s.status, "message": s.message, "error_type": s.error_type,
                          "failure_class": s.failure_class, "flags": list(s.flags), "settings": s.settings,
                          "stats": s.stats, "deflection": {c: arr(h) for c, h in s.deflection.items()}}
                      for n, s in r.solutions.items()},
        "metrics": {name: _pair_record(m) for name, m in r.metrics.items()},
        "run_stats": asdict(r.stats),
        "crank_angle_rad": arr(r.crank_angle),
        "natural_frequencies_hz": arr(r.natural_frequencies),
    }


def _linkage_lines(s: Any) -> list[str]:
    """The mechanism and linkage lines of a scene's description (four-bar or slider-crank)."""
    lk = s.linkage
    if s.kind != "four-bar":
        rigid = [n for n, r in zip(("crank", "coupler"), lk.rigid) if r]
        return [f"  mechanism   : slider-crank, direction {s.direction}",
                f"  linkage [m] : crank {lk.crank:.4g}, coupler {lk.coupler:.4g}, offset {lk.offset:.4g}, coupler "
                f"point at {lk.coupler_point:.4g} of the coupler, slider {lk.slider_mass:.4g} kg"
                + (f", rigid {' and '.join(rigid)}" if rigid else "")]
    return [f"  mechanism   : {s.mechanism}, branch {lk.branch}, direction {s.direction}",
            f"  linkage [m] : crank {lk.crank:.4g}, coupler {lk.coupler:.4g}, follower {lk.follower:.4g}, "
            f"extender {lk.extender:.4g}, coupler angle {math.degrees(lk.coupler_angle):.4g} deg"]


def format_detail(r: SceneResult) -> str:
    """Human-readable description of one scene (no arrays)."""
    s = r.spec
    lines = [
        f"scene {r.key}  {s.label}",
        f"  status      : {r.status}" + (f" (stage {r.stage}, {r.failure_class or 'unclassified'}, {r.error_type}: "
                                         f"{r.message})" if not r.ok else ""),
        *_linkage_lines(s),
        f"  mass model  : {s.mass_model.name} (lumps {s.mass_model.lumps}, payload {s.mass_model.payload:.4g} kg)",
        f"  speed       : {s.speed.label()} -> {r.rpm:.4g} rpm; omega1_min {r.omega1_min:.4g} rad/s; "
        f"Omega/omega1_min = {speed_ratio(r):.4g}",
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
                     f"(vector (dx, dy) history error {m.verdict_error:.1%}, tolerance {m.tolerance:.1%})")
        lines.append("    component  units  max|err|     rms err      history  peak err  phase[deg]  amplif.")
        for c in m.components:
            lines.append(f"    {c.component:<9}  {c.units:<5}  {c.max_abs_error:<11.4g}  {c.rms_error:<11.4g}  "
                         f"{c.history_error:>7.1%}  {c.peak_error:>8.1%}  {math.degrees(c.phase_shift):>10.2f}  "
                         f"{c.amplification:>7.3f}")
    return "\n".join(lines)


def sort_key(r: SceneResult) -> tuple:
    """Grid-like display order: mechanism, mass model, stiffness, damping, direction, speed."""
    s = r.spec
    return (s.mechanism, s.mass_model.name, s.stiffness_scale, s.damping_ratio, s.direction,
            s.speed.kind, s.speed.value, r.key)


def find_scene(results: Sequence[SceneResult], ident: str) -> SceneResult:
    """Scene whose key starts with ``ident`` or whose label equals it; ValueError if none/ambiguous."""
    hits = [r for r in results if r.key.startswith(ident) or r.spec.label == ident]
    if not hits:
        raise ValueError(f"no scene matches {ident!r}")
    if len(hits) > 1:
        raise ValueError(f"{ident!r} is ambiguous: {', '.join(r.key for r in hits)}")
    return hits[0]
