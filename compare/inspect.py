"""Summaries of stored scenes: table rows, detail records and their text rendering (pure functions).

Column units: rpm [rev/min], Omega/w1 [1] (crank speed over the lowest first natural circular
frequency), errors relative to the dynamic peak [%], amplification [1], wall time [s].
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from compare.results import SceneResult


def _num(x: float) -> float | None:
    return None if x is None or (isinstance(x, float) and not math.isfinite(x)) else float(x)


def summary_row(r: SceneResult) -> dict[str, Any]:
    """One summary record (JSON-serialisable; non-finite numbers become ``None``)."""
    m = r.metrics
    row: dict[str, Any] = {
        "key": r.key,
        "label": r.spec.label,
        "mechanism": r.spec.mechanism,
        "mass_model": r.spec.mass_model.name,
        "rpm": _num(r.rpm),
        "speed_ratio": _num(m.speed_ratio) if m else _num(_ratio(r)),
        "status": r.status,
        "stage": r.stage,
        "message": r.message,
        "max_relative_error": _num(m.max_relative_error) if m else None,
        "max_amplification": _num(m.max_amplification) if m else None,
        "holds": m.holds if m else None,
        "wall_s": _num(r.stats.total_wall_s),
    }
    if m:
        for c in m.components:
            row[f"relative_error_{c.component}"] = _num(c.relative_error)
            row[f"amplification_{c.component}"] = _num(c.amplification)
    return row


def _ratio(r: SceneResult) -> float:
    if not (math.isfinite(r.rpm) and math.isfinite(r.omega1_min) and r.omega1_min > 0):
        return float("nan")
    return r.rpm * 2.0 * math.pi / 60.0 / r.omega1_min


def verdict_text(holds: bool | None) -> str:
    return "-" if holds is None else ("holds" if holds else "FAILS")


def format_table(rows: Sequence[dict[str, Any]]) -> str:
    """Fixed-width text table of summary rows."""
    cols = [
        ("key", "key", "{}", 16),
        ("label", "scene", "{}", 0),
        ("rpm", "rpm", "{:.1f}", 0),
        ("speed_ratio", "Omega/w1", "{:.3f}", 0),
        ("status", "status", "{}", 0),
        ("max_relative_error", "rel.err %", "{:.1%}", 0),
        ("max_amplification", "amplif.", "{:.3f}", 0),
        ("holds", "verdict", "", 0),
        ("wall_s", "wall s", "{:.1f}", 0),
    ]

    def cell(row: dict[str, Any], key: str, fmt: str) -> str:
        v = row.get(key)
        if key == "holds":
            return verdict_text(v)
        if v is None:
            return "-"
        if fmt == "{:.1%}":
            return f"{100.0 * v:.1f}"
        return fmt.format(v)

    table = [[title for _, title, _, _ in cols]]
    for row in rows:
        table.append([cell(row, key, fmt) for key, _, fmt, _ in cols])
    widths = [max(len(r[i]) for r in table) for i in range(len(cols))]
    right = {"rpm", "speed_ratio", "max_relative_error", "max_amplification", "wall_s"}
    lines = []
    for n, r in enumerate(table):
        parts = [
            r[i].rjust(widths[i]) if cols[i][0] in right else r[i].ljust(widths[i]) for i in range(len(cols))
        ]
        lines.append("  ".join(parts).rstrip())
        if n == 0:
            lines.append("  ".join("-" * w for w in widths))
    return "\n".join(lines)


def format_counts(results: Sequence[SceneResult]) -> str:
    """One line: how many scenes, ok, failed, verdicts."""
    ok = [r for r in results if r.ok]
    holds = sum(1 for r in ok if r.metrics is not None and r.metrics.holds)
    return (
        f"{len(results)} scenes: {len(ok)} ok, {len(results) - len(ok)} failed; "
        f"quasi-static holds in {holds} of {len(ok)} ok scenes"
    )


def scene_detail(r: SceneResult) -> dict[str, Any]:
    """Everything about one scene as a JSON-serialisable dict (arrays as lists)."""

    def arr(a: Any) -> Any:
        return None if a is None else [[_num(float(x)) for x in row] if hasattr(row, "__len__") else
                                       _num(float(row)) for row in a]

    m = r.metrics
    return {
        "key": r.key,
        "label": r.spec.label,
        "status": r.status,
        "stage": r.stage,
        "error_type": r.error_type,
        "message": r.message,
        "warnings": r.warnings,
        "rpm": _num(r.rpm),
        "omega1_min_rad_s": _num(r.omega1_min),
        "parameters": r.spec.to_dict(),
        "dynamic_settings": r.dynamic_settings,
        "metrics": None if m is None else {
            "omega_rad_s": m.omega,
            "omega1_min_rad_s": m.omega1_min,
            "speed_ratio": m.speed_ratio,
            "tolerance": m.tolerance,
            "holds": m.holds,
            "components": {
                c.component: {
                    "units": c.units,
                    "max_abs_error": _num(c.max_abs_error),
                    "rms_error": _num(c.rms_error),
                    "relative_error": _num(c.relative_error),
                    "phase_shift_rad": _num(c.phase_shift),
                    "amplification": _num(c.amplification),
                    "dynamic_peak": _num(c.dynamic_peak),
                    "quasi_static_peak": _num(c.quasi_static_peak),
                    "holds": c.holds,
                }
                for c in m.components
            },
        },
        "run_stats": {k: getattr(r.stats, k) for k in r.stats.__dataclass_fields__},
        "crank_angle_rad": arr(r.crank_angle),
        "natural_frequencies_hz": arr(r.natural_frequencies),
        "quasi_static": {c: arr(v) for c, v in r.quasi_static.items()},
        "dynamic": {c: arr(v) for c, v in r.dynamic.items()},
    }


def format_detail(r: SceneResult) -> str:
    """Human-readable description of one scene (no arrays)."""
    s = r.spec
    lk = s.linkage
    lines = [
        f"scene {r.key}  {s.label}",
        f"  status      : {r.status}" + (f" (stage {r.stage}, {r.error_type}: {r.message})" if not r.ok else ""),
        f"  mechanism   : {s.mechanism}, branch {lk.branch}, direction {s.direction}",
        f"  linkage [m] : crank {lk.crank:.4g}, coupler {lk.coupler:.4g}, follower {lk.follower:.4g}, "
        f"extender {lk.extender:.4g}, coupler angle {math.degrees(lk.coupler_angle):.4g} deg",
        f"  mass model  : {s.mass_model.name} (lumps {s.mass_model.lumps}, payload {s.mass_model.payload:.4g} kg)",
        f"  speed       : {s.speed.label()} -> {r.rpm:.4g} rpm; omega1_min {r.omega1_min:.4g} rad/s",
        f"  stiffness x : {s.stiffness_scale:g}; damping ratio {s.damping_ratio:g}; grid step {s.step_deg:g} deg",
        f"  dynamic     : {', '.join(f'{k}={v}' for k, v in sorted(r.dynamic_settings.items()))}",
    ]
    st = r.stats
    lines.append(
        f"  run stats   : total {st.total_wall_s:.2f} s (freq {st.frequencies_wall_s:.2f}, quasi-static "
        f"{st.quasi_static_wall_s:.2f}, dynamic {st.dynamic_wall_s:.2f}); steps {st.steps}, Newton "
        f"iterations {st.newton_iterations}, cycles {st.cycles}, converged {st.converged}; worker {st.worker}"
    )
    if r.warnings:
        lines.append(f"  warnings    : {r.warnings}")
    m = r.metrics
    if m is not None:
        lines.append(
            f"  verdict     : quasi-static {verdict_text(m.holds)} (tolerance {m.tolerance:.1%}); "
            f"Omega/omega1_min = {m.speed_ratio:.4g}"
        )
        lines.append("  component  units  max|err|     rms err      rel.err  phase[deg]  amplif.  verdict")
        for c in m.components:
            lines.append(
                f"  {c.component:<9}  {c.units:<5}  {c.max_abs_error:<11.4g}  {c.rms_error:<11.4g}  "
                f"{c.relative_error:>6.1%}  {math.degrees(c.phase_shift):>10.2f}  {c.amplification:>7.3f}  "
                f"{verdict_text(c.holds)}"
            )
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
