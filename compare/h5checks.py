"""The checks of one stored scene (``ked inspect --verify``, ``ked merge``): read as a reader reads it, its arrays
and histories of the right shapes and finite, its stored metrics equal to those its histories give, its
parameter columns equal to its ``json``; and the table-level checks of a version-4/5 file.
"""

from __future__ import annotations

import json
import math
from typing import Any

import h5py
import numpy as np

from compare.h5layout import (
    _RUN_STAT_FIELDS,
    DAMAGED,
    METRICS,
    SCENE_ATTRS,
    TableFile,
    _verify_stress,
    complete,
    metric_rows,
    parameter_row,
    text,
)
from compare.h5legacy import (
    read_scene,
    stored_metric_rows,
)
from compare.h5schema import (
    METRIC_COLUMNS,
    METRIC_TABLE,
    RUN_COLUMNS,
    RUNS,
    SCENE_TABLE,
    SOLUTION_COLUMNS,
    SOLUTION_TABLE,
    TABLES,
)
from compare.metrics import PairMetrics
from compare.results import STATUS_OK, SceneResult
from compare.scenes import SceneSpec
from compare.solvers import COMPONENTS, STATUS_FAILED
from ked_quasi.rules import steps_per_turn
from ked_quasi.units import rad_s_to_rpm


def verify_scene(name: str, g: Any, version: int) -> list[str]:
    """Problems of one scene group of a version-1..3 file (empty = valid)."""
    if not isinstance(g, h5py.Group):
        return ["not a group"]
    if not complete(g):
        return ["incomplete (no complete=1 attribute)"]
    p = [f"missing attribute {a!r}" for a in SCENE_ATTRS if a not in g.attrs]
    if p:
        return p
    return _verify_read(name, text(g.attrs["key"]), text(g.attrs["status"]), lambda: read_scene(g, version),
                        g, lambda: stored_metric_rows(g, version) if METRICS in g else None, version)


def _verify_read(name: str, key: str, stored_status: str, read: Any, arrays: Any, stored_rows: Any,
                 version: int) -> list[str]:
    """The checks of one complete scene (any version): ``read()`` gives the scene, ``arrays`` maps
    array names to datasets, ``stored_rows()`` its stored metric rows (None: none stored)."""
    p = [] if key == name else [f"key attribute {key!r} differs from group name"]
    try:
        r = read()
    except (KeyError, ValueError, TypeError) as exc:
        return p + [f"unreadable: {exc}"]
    if r.key != name:
        p.append(f"content key of parameters ({r.key}) differs from group name")
    if r.status not in (STATUS_OK, STATUS_FAILED):
        p.append(f"unknown status {r.status!r}")
    if r.failure_class == DAMAGED and stored_status == STATUS_OK:
        return p + [r.message.split(" (check it")[0]] + _verify_ok_scene(arrays, r, stored_rows, version)
    if r.status != STATUS_OK:
        return p + ([] if r.message else ["failed scene without message"])
    return p + _verify_ok_scene(arrays, r, stored_rows, version)


def _verify_ok_scene(arrays: Any, r: SceneResult, stored_rows: Any, version: int) -> list[str]:
    p = [f"missing dataset {ds}" for ds in ("crank_angle", "coupler_point", "natural_frequencies") if ds not in arrays]
    if p:
        return p
    p += [f"dataset {ds} has no units attribute" for ds in ("crank_angle", "coupler_point", "natural_frequencies")
          if "units" not in arrays[ds].attrs]
    spec = r.spec
    n = steps_per_turn(spec.step_deg)
    shapes = {"crank_angle": (n,), "coupler_point": (n, 2), "natural_frequencies": (n, spec.n_modes)}
    p += [f"{ds} shape {arrays[ds].shape} != {shape}" for ds, shape in shapes.items() if arrays[ds].shape != shape]
    if not p:
        p += _verify_frame(r, n)
    for solver in spec.solvers:
        s = r.solutions.get(solver)
        if s is None:
            p.append(f"missing solution of solver {solver!r}")
            continue
        p += _verify_stress(solver, s, spec, n)
        for c in (c for c in spec.outputs if c in COMPONENTS):
            h = s.deflection.get(c)
            if h is None:
                p.append(f"missing history {solver}/{c}")
            elif h.shape != (n,):
                p.append(f"{solver}/{c} shape {h.shape} != ({n},)")
            elif not np.all(np.isfinite(h)):
                p.append(f"{solver}/{c} has non-finite values")
    if len(spec.solvers) > 1 and r.verdict is None:
        p.append("no verdict: the quasi-static solution or a reference is missing")
    return p + _verify_stored_metrics(r, stored_rows, version)


def _verify_frame(r: SceneResult, n: int) -> list[str]:
    """What the stored arrays give, recomputed: the crank-angle grid of the step, omega1_min = 2 pi
    times the lowest first natural frequency, the crank speed resolved from the scene's speed."""
    p = []
    grid = np.deg2rad(np.arange(n) * r.spec.step_deg)
    if not np.allclose(r.crank_angle, grid, rtol=1e-12, atol=1e-12):
        p.append(f"crank_angle is not the grid of step {r.spec.step_deg} deg")
    f1 = np.asarray(r.natural_frequencies)[:, 0]
    omega1_min = 2.0 * math.pi * float(np.nanmin(f1)) if np.any(np.isfinite(f1)) else math.nan
    if not _close(r.omega1_min, omega1_min):
        p.append(f"omega1_min_rad_s {r.omega1_min} is not 2 pi x the lowest stored first natural frequency "
                 f"({omega1_min})")
        return p
    speed = r.spec.speed
    rpm = speed.value if speed.kind == "rpm" else rad_s_to_rpm(speed.value * r.omega1_min)
    if not _close(r.rpm, rpm):
        p.append(f"rpm {r.rpm} is not the scene's speed ({rpm} rev/min)")
    return p


def _verify_stored_metrics(r: SceneResult, stored_rows: Any, version: int) -> list[str]:
    """The stored metrics (for readers without the harness) must be those of the stored histories: every
    stored field recomputed from them (the verdict error and ``pair_holds`` by today's measure or, in a
    file an older layout wrote, the worst component's), and no row of a pair the histories do not give."""
    try:
        rows = stored_rows()
    except (KeyError, ValueError, TypeError) as exc:
        return [f"{METRICS} unreadable: {exc}"]
    if not rows:
        where = {4: f" rows in /{METRIC_TABLE}", 3: " table"}.get(version, " group")
        return [f"missing {METRICS}{where}"] if r.metrics else []
    p = []
    computed = {(m.solver, m.reference, c.component): (m, c) for m in r.metrics.values() for c in m.components}
    for k, (m, c) in computed.items():
        row = rows.get(k)
        if row is None:
            if version >= 2 or c.component in ("dx", "dy", "rotation"):
                p.append(f"missing {METRICS} of {m.name}/{c.component}")
            continue
        bad = _metric_fields_differ(row, metric_rows({m.name: m})[k], m)
        if bad:
            p.append(f"{METRICS} of {m.name}/{c.component}: stored values differ from the histories "
                     f"({', '.join(bad)})")
    p += [f"{METRICS} of {'/'.join(k)}: stored, but the stored histories give no such pair" for k in rows
          if k not in computed]
    return p


def _metric_fields_differ(row: dict[str, Any], want: dict[str, Any], m: PairMetrics) -> list[str]:
    """The stored fields of one metric row that differ from those recomputed (``want``); a field not
    stored (older layouts stored fewer) is not compared."""
    bad = []
    for n, v in want.items():
        if n not in row:
            continue
        s = row[n]
        if n == "verdict_error":  # today's measure, or the worst component's that older layouts stored
            ok = any(_close(s, x) for x in (m.verdict_error, m.worst_component_error))
        elif n == "pair_holds":  # the verdict of the stored verdict error (checked above)
            measure = float(row.get("verdict_error", m.verdict_error))
            ok = bool(s) == bool(measure < m.tolerance)
        elif isinstance(v, (bool, str)):
            ok = (bool(s) if isinstance(v, bool) else text(s)) == v
        else:
            ok = _close(s, v, atol=1e-9 if n == "phase_shift_rad" else 0.0)
        if not ok:
            bad.append(n)
    return bad


def _close(a: Any, b: float, atol: float = 0.0) -> bool:
    try:
        a = float(a)
    except (TypeError, ValueError):
        return False
    return bool(np.isclose(a, b, rtol=1e-9, atol=atol, equal_nan=True))


def verify_table_scene(view: TableFile, key: str) -> list[str]:
    """Problems of one scene of a version-4/5 file's scene table (``view``: its :class:`TableFile`; empty = valid)."""
    if not view.complete(key):
        return [f"incomplete (no complete=1 in /{SCENE_TABLE})"]
    row = view.row(key)
    missing = [a for a in (*SCENE_ATTRS, "json", *_ROW_FIELDS) if a not in row]
    if missing:
        return [f"missing column(s) {', '.join(missing)} of /{SCENE_TABLE}"]
    p = _verify_read(key, text(row["key"]), text(row["status"]), lambda: view.read_scene(key),
                     view.arrays(key), lambda: view.metric_rows(key), 4)
    return p + _verify_parameter_columns(row) + _verify_solution_rows(view.solution_rows(key))


_ROW_FIELDS = ("warnings", "failure_class", *_RUN_STAT_FIELDS)
"""Columns of /scene_table every layout's scenes have besides :data:`SCENE_ATTRS` and ``json``."""


_NEWER_PARAMETERS = ("kind", "solvers", "json")
"""Parameter columns an older layout did not store (carried over without them), or stored otherwise."""


def _verify_parameter_columns(row: dict[str, Any]) -> list[str]:
    """The readable parameter columns of a scene row: each present and equal to what its ``json`` gives."""
    try:
        want = parameter_row(SceneSpec.from_dict(json.loads(text(row["json"]))))
    except (KeyError, ValueError, TypeError):
        return []  # reported by the read of the scene
    missing = [c for c in want if c not in row and c not in _NEWER_PARAMETERS]
    if missing:
        return [f"missing column(s) {', '.join(missing)} of /{SCENE_TABLE}"]
    differ = [c for c, v in want.items() if c in row and c != "json" and not _same_cell(row[c], v)
              and not (c in _NEWER_PARAMETERS and text(row[c]) == "")]  # filled in for an older layout's rows
    if not differ:
        return []
    return [f"column(s) {', '.join(differ)} of /{SCENE_TABLE} differ from the scene's parameters (json)"]


def _same_cell(stored: Any, want: Any) -> bool:
    if isinstance(want, str) or isinstance(stored, (str, bytes)):
        return text(stored) == str(want)
    try:
        a, b = np.asarray(stored, dtype=np.float64), np.asarray(want, dtype=np.float64)
    except (TypeError, ValueError):
        return False
    return a.shape == b.shape and bool(np.allclose(a, b, rtol=1e-12, atol=0.0, equal_nan=True))


def _verify_solution_rows(rows: list[dict[str, Any]]) -> list[str]:
    """Every solution row of a scene with the columns a reader needs and a known status."""
    p = []
    for r in rows:
        missing = [c for c in ("solver", "status", "settings_json", "stats_json", "fidelity") if c not in r]
        if missing:
            return [f"missing column(s) {', '.join(missing)} of /{SOLUTION_TABLE}"]
        if text(r["status"]) not in (STATUS_OK, STATUS_FAILED):
            p.append(f"solution {text(r['solver'])}: unknown status {text(r['status'])!r}")
    return p


_REQUIRED = {METRIC_TABLE: tuple(METRIC_COLUMNS), SOLUTION_TABLE: tuple(SOLUTION_COLUMNS), RUNS: tuple(RUN_COLUMNS)}
"""The columns every non-empty table of a version-4 file has (an upgrade writes them too); the scene
table's are checked per row (:func:`_verify_parameter_columns`)."""


def verify_tables(f: h5py.File) -> list[str]:
    """Table-level problems of a version-4 file: every column of every table (and of the study tables
    under ``/study``) as long as its ``rows``, and with a ``units`` attribute (study tables of older
    files have none)."""
    from compare import tables

    p = []
    for name in TABLES:
        if name in f:
            p += tables.verify_table(f[name], f"/{name}")
            g = f[name]
            filled = isinstance(g, h5py.Group) and tables.n_rows(g) > 0  # an empty table has no columns
            missing = [c for c in _REQUIRED.get(name, ()) if c not in g] if filled else []
            if missing:
                p.append(f"/{name}: missing column(s) {', '.join(missing)}")
    study = f.get("study")
    for name, g in (study.items() if isinstance(study, h5py.Group) else ()):
        p += tables.verify_table(g, f"/study/{name}", units=False)
    return p
