"""Readers of the group-per-scene layouts of schema versions 1-3 (one group per scene holding everything), for
the upgrade and for reading such files as they are (:mod:`compare.upgrade`, :mod:`compare.reader`).
"""

from __future__ import annotations

import json

import h5py

from compare.h5layout import (
    _METRIC_ATTRS,
    _ROW_KEY,
    METRICS,
    SOLUTIONS,
    MetricRows,
    _array,
    _histories,
    assemble,
    text,
)
from compare.h5schema import (
    METRIC_FIELDS,
)
from compare.results import STATUS_OK, RunStats, SceneResult
from compare.scenes import SceneSpec
from compare.solvers import STATUS_FAILED, Solution


def stored_metric_rows(g: h5py.Group, version: int) -> MetricRows:
    """Every stored metric number of a scene group, whatever its layout (version 3 table, version 2
    groups per pair and component, version 1 quasi-static vs Exudyn group)."""
    mg = g.get(METRICS)
    if mg is None:
        return {}
    if isinstance(mg, h5py.Dataset):
        rows: MetricRows = {}
        for rec in mg[()]:
            vals = {n: (text(rec[n]) if kind.startswith("S") else bool(rec[n]) if kind == "u1" else float(rec[n]))
                    for n, kind, _, _ in METRIC_FIELDS}
            rows[tuple(vals.pop(k) for k in _ROW_KEY)] = vals
        return rows
    if version < 2:
        return _metric_rows_v1(mg)
    rows = {}
    for pg in mg.values():
        pa = pg.attrs
        pair = {"pair_holds": bool(pa["holds"]), "verdict_error": float(pa["verdict_error"]),
                **{n: float(pa[n]) for n in ("omega_rad_s", "omega1_min_rad_s", "speed_ratio", "tolerance")}}
        for comp, cg in pg.items():
            ca = cg.attrs
            row = {"units": text(ca["units"]), **{n: float(ca[n]) for n in (*_METRIC_ATTRS, "phase_shift_rad")},
                   "holds": bool(ca["holds"]), **pair}
            rows[(text(pa["solver"]), text(pa["reference"]), comp)] = row
    return rows


def _metric_rows_v1(mg: h5py.Group) -> MetricRows:
    """Version 1: ``metrics/`` of quasi-static vs Exudyn, ``relative_error`` = history error,
    ``quasi_static_peak`` / ``dynamic_peak`` = solver / reference peak."""
    pa = mg.attrs
    pair = {"pair_holds": bool(pa["holds"]), "verdict_error": float(pa["max_relative_error"]),
            **{n: float(pa[n]) for n in ("omega_rad_s", "omega1_min_rad_s", "speed_ratio", "tolerance")}}
    names = {"history_error": "relative_error", "solver_peak": "quasi_static_peak", "reference_peak": "dynamic_peak"}
    rows: MetricRows = {}
    for comp, cg in mg.items():
        ca = cg.attrs
        row = {"units": text(ca["units"]),
               **{n: float(ca[names.get(n, n)]) for n in (*_METRIC_ATTRS, "phase_shift_rad") if names.get(n, n) in ca},
               "holds": bool(ca["holds"]), **pair}
        rows[("quasi_static", "dynamic", comp)] = row
    return rows


def read_solution(name: str, g: h5py.Group | h5py.Dataset) -> Solution:
    a = g.attrs
    flags = text(a.get("flags", ""))
    return Solution(solver=name, status=text(a["status"]), deflection=_histories(g),
                    settings=json.loads(text(a["settings_json"])), stats=json.loads(text(a["stats_json"])),
                    message=text(a.get("message", "")), error_type=text(a.get("error_type", "")),
                    failure_class=text(a.get("failure_class", "")), flags=tuple(flags.split(",")) if flags else (),
                    warnings=text(a.get("warnings", "")), fidelity=int(a.get("fidelity", 0)))


def _solutions_v1(g: h5py.Group) -> dict[str, Solution]:
    """Version 1 kept the quasi-static and Exudyn histories at the scene level, Exudyn's settings in
    ``dynamic_settings/`` and both solvers' statistics in ``run_stats/``."""
    st = {k: (text(v) if isinstance(v, (str, bytes)) else v.item()) for k, v in g["run_stats"].attrs.items()}
    stage, status = text(g.attrs["stage"]), text(g.attrs["status"])
    out: dict[str, Solution] = {}
    qs_failed = status != STATUS_OK and stage == "quasi_static"
    if "quasi_static" in g or qs_failed:
        out["quasi_static"] = Solution(
            "quasi_static", STATUS_FAILED if qs_failed else STATUS_OK, _histories(g["quasi_static"]) if "quasi_static"
            in g else {}, stats={"wall_s": float(st["quasi_static_wall_s"])}, fidelity=0,
            message=text(g.attrs["message"]) if qs_failed else "", error_type=text(g.attrs["error_type"]) if qs_failed
            else "")
    dyn_failed = status != STATUS_OK and stage == "dynamic"
    if "dynamic" in g or dyn_failed:
        stats = {"wall_s": float(st["dynamic_wall_s"]), "steps": int(st["steps"]),
                 "newton_iterations": int(st["newton_iterations"]), "cycles": int(st["cycles"]),
                 "converged": bool(st["converged"]), "dynamic_message": str(st["dynamic_message"])}
        out["dynamic"] = Solution(
            "dynamic", STATUS_FAILED if dyn_failed else STATUS_OK, _histories(g["dynamic"]) if "dynamic" in g else {},
            settings=json.loads(text(g["dynamic_settings"].attrs["json"])), stats=stats, fidelity=10,
            message=text(g.attrs["message"]) if dyn_failed else "",
            error_type=text(g.attrs["error_type"]) if dyn_failed else "")
    return out


def _run_stats(g: h5py.Group) -> RunStats:
    a = g["run_stats"].attrs
    return RunStats(frequencies_wall_s=float(a["frequencies_wall_s"]), total_wall_s=float(a["total_wall_s"]),
                    worker=text(a["worker"]), finished_utc=text(a["finished_utc"]))


def read_scene(g: h5py.Group, version: int) -> SceneResult:
    """The scene of a complete group of a version-1..3 file (``version``: the file's schema version)."""
    spec = SceneSpec.from_dict(json.loads(text(g["parameters"].attrs["json"])))
    if version >= 2:
        solutions = {name: read_solution(name, sg) for name, sg in g[SOLUTIONS].items()}
    else:
        solutions = _solutions_v1(g)
    return assemble(spec, g.attrs, solutions, _array(g, "crank_angle"), _array(g, "coupler_point"),
                    _array(g, "natural_frequencies"), _run_stats(g))
