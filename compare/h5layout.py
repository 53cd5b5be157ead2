"""One scene group of a results file <-> a :class:`~compare.results.SceneResult` (layout in
``docs/hdf5_schema.md``).  Schema version 2 writes one group per solver under ``solutions/`` and one
per solver pair under ``metrics/``; version 1 files (quasi-static and Exudyn only) are read too.

Metrics are stored for readers without the harness; the harness itself recomputes them from the
stored histories when it reads a scene (:func:`compare.metrics.all_pairs`), so there is one
definition of every number it shows.
"""

from __future__ import annotations

import json
import math
from typing import Any

import h5py
import numpy as np

from compare.metrics import PairMetrics, all_pairs
from compare.results import STATUS_OK, RunStats, SceneResult
from compare.scenes import SceneSpec, canonical_json
from compare.solvers import COMPONENT_UNITS, COMPONENTS, STATUS_FAILED, Solution
from ked_quasi.linkage import LINKS, direction_sign
from ked_quasi.rules import steps_per_turn
from ked_quasi.units import rpm_to_rad_s

SOLUTIONS = "solutions"
METRICS = "metrics"
_RUN_STAT_FIELDS = ("frequencies_wall_s", "total_wall_s", "worker", "finished_utc")
SCENE_ATTRS = ("key", "label", "status", "stage", "error_type", "message", "rpm", "omega1_min_rad_s", "run")
_METRIC_ATTRS = ("history_error", "peak_error", "max_abs_error", "rms_error", "amplification", "solver_peak",
                 "reference_peak")


def text(v: Any) -> str:
    return v.decode("utf-8") if isinstance(v, bytes) else str(v)


def flag(b: bool) -> np.uint8:
    return np.uint8(1 if b else 0)


def complete(g: h5py.Group) -> bool:
    return isinstance(g, h5py.Group) and int(g.attrs.get("complete", 0)) == 1


MAX_COMPACT_ATTRIBUTES = 64
"""Groups keep up to this many attributes in their object header (HDF5's default of 8 moves more into
a separately allocated dense store of about 1.5 kB per group)."""


def _compact_attributes(kind: Any) -> Any:
    plist = h5py.h5p.create(kind)
    plist.set_attr_phase_change(MAX_COMPACT_ATTRIBUTES, MAX_COMPACT_ATTRIBUTES - 2)
    return plist


def new_group(parent: h5py.Group, name: str) -> h5py.Group:
    """A new group whose attributes stay compact (see :data:`MAX_COMPACT_ATTRIBUTES`)."""
    return h5py.Group(h5py.h5g.create(parent.id, name.encode("utf-8"),
                                      gcpl=_compact_attributes(h5py.h5p.GROUP_CREATE)))


def _dataset(g: h5py.Group, name: str, data: np.ndarray, units: str, description: str) -> None:
    ds = g.create_dataset(name, data=np.asarray(data, dtype=np.float64))
    ds.attrs["units"] = units
    ds.attrs["description"] = description


# -- writing --------------------------------------------------------------------------------------


def write_parameters(g: h5py.Group, spec: SceneSpec) -> None:
    """``parameters/``: the JSON the key is hashed from, plus readable attributes with units."""
    a = g.attrs
    a["json"] = canonical_json(spec.to_dict())
    a["label"] = spec.label
    a["mechanism"] = spec.mechanism
    mm = spec.mass_model
    a["mass_model"], a["mass_lumps"], a["payload_kg"] = mm.name, mm.lumps, mm.payload
    a["joint_split"], a["lump_placement"] = mm.joint_split, mm.placement
    a["speed_kind"] = spec.speed.kind
    a["speed_rpm" if spec.speed.kind == "rpm" else "speed_ratio_requested"] = spec.speed.value
    for name in ("stiffness_scale", "damping_ratio", "direction", "step_deg", "n_modes", "tolerance"):
        a[name] = getattr(spec, name)
    a["outputs"] = ",".join(spec.outputs)
    a["solvers"] = ",".join(spec.solvers)
    lk = spec.linkage
    a["kind"] = spec.kind
    if spec.kind != "four-bar":  # a slider-crank
        for name in ("crank", "coupler", "offset"):
            a[f"{name}_m"] = getattr(lk, name)
        a["coupler_point"], a["slider_mass_kg"] = lk.coupler_point, lk.slider_mass
        a["links"] = ",".join(("crank", "coupler"))
        a["rigid"] = ",".join(str(r).lower() for r in lk.rigid)
        for field, attr in (("youngs_modulus", "youngs_modulus_Pa"), ("area", "area_m2"),
                            ("second_moment", "second_moment_m4"), ("density", "density_kg_m3")):
            a[attr] = np.array([getattr(s, field) for s in lk.sections])
        return
    for name in ("crank", "coupler", "follower", "extender"):
        a[f"{name}_m"] = getattr(lk, name)
    a["coupler_angle_rad"] = lk.coupler_angle
    a["crank_pivot_m"] = np.asarray(lk.crank_pivot, dtype=np.float64)
    a["follower_pivot_m"] = np.asarray(lk.follower_pivot, dtype=np.float64)
    a["branch"] = lk.branch
    a["links"] = ",".join(LINKS)
    for field, attr in (("youngs_modulus", "youngs_modulus_Pa"), ("area", "area_m2"),
                        ("second_moment", "second_moment_m4"), ("density", "density_kg_m3")):
        a[attr] = np.array([getattr(s, field) for s in lk.sections])


def write_solution(parent: h5py.Group, s: Solution) -> None:
    """``solutions/<solver>``: one (n, k) dataset of the requested output histories (columns named by
    its ``components`` attribute, units by ``units``; (0, 0) when the solver produced none) carrying the
    solver's status, settings and statistics as attributes."""
    comps = [c for c in COMPONENTS if c in s.deflection]
    data = (np.column_stack([np.asarray(s.deflection[c], dtype=np.float64) for c in comps]) if comps
            else np.zeros((0, 0)))
    ds = parent.create_dataset(s.solver, data=data, dcpl=_compact_attributes(h5py.h5p.DATASET_CREATE))
    a = ds.attrs
    a["components"], a["units"] = ",".join(comps), ",".join(COMPONENT_UNITS[c] for c in comps)
    a["status"], a["message"], a["error_type"] = s.status, s.message, s.error_type
    a["failure_class"], a["flags"], a["warnings"] = s.failure_class, ",".join(s.flags), s.warnings
    a["fidelity"] = int(s.fidelity)
    a["settings_json"] = canonical_json(s.settings)
    a["stats_json"] = json.dumps(s.stats, sort_keys=True, allow_nan=True)


# The metrics table (schema version 3): one row per (solver pair, component) in one compound dataset
# ``metrics`` per scene.  name, HDF5 type, units ("row" = the row's ``units`` column), description.
METRIC_FIELDS: tuple[tuple[str, str, str, str], ...] = (
    ("solver", "S32", "", "solver measured"),
    ("reference", "S32", "", "reference solver (the higher fidelity)"),
    ("component", "S16", "", "dx, dy, rotation, or vector (the deflection vector (dx, dy))"),
    ("units", "S8", "", "units of the component"),
    ("history_error", "f8", "1", "max|a - b| / max|b| over the cycle"),
    ("peak_error", "f8", "1", "|max|a| - max|b|| / max|b|"),
    ("max_abs_error", "f8", "row", "max|a - b|"),
    ("rms_error", "f8", "row", "root mean square of |a - b|"),
    ("phase_shift_rad", "f8", "rad", "time lag of the reference's peak behind the solver's, (-pi, pi]"),
    ("amplification", "f8", "1", "max|b| / max|a|"),
    ("solver_peak", "f8", "row", "max|a|"),
    ("reference_peak", "f8", "row", "max|b|"),
    ("holds", "u1", "", "1 if history_error < tolerance"),
    ("pair_holds", "u1", "", "1 if the pair holds: every scalar component holds"),
    ("verdict_error", "f8", "1", "worst history_error of dx, dy, rotation of the pair"),
    ("omega_rad_s", "f8", "rad/s", "crank speed"),
    ("omega1_min_rad_s", "f8", "rad/s", "lowest first natural circular frequency over the cycle"),
    ("speed_ratio", "f8", "1", "omega / omega1_min"),
    ("tolerance", "f8", "1", "campaign tolerance of the verdict"),
)
METRIC_DTYPE = np.dtype([(name, kind) for name, kind, _, _ in METRIC_FIELDS])
_ROW_KEY = ("solver", "reference", "component")
MetricRows = dict[tuple[str, str, str], dict[str, Any]]
"""(solver, reference, component) -> field -> value: the stored metric numbers of a scene."""


def metric_rows(metrics: dict[str, PairMetrics]) -> MetricRows:
    """The table rows of computed metrics."""
    rows: MetricRows = {}
    for m in metrics.values():
        pair = {"pair_holds": bool(m.holds), "verdict_error": float(m.verdict_error), "omega_rad_s": float(m.omega),
                "omega1_min_rad_s": float(m.omega1_min), "speed_ratio": float(m.speed_ratio),
                "tolerance": float(m.tolerance)}
        for c in m.components:
            row = {"units": c.units, **{n: float(getattr(c, n)) for n in _METRIC_ATTRS},
                   "phase_shift_rad": float(c.phase_shift), "holds": bool(c.holds), **pair}
            rows[(m.solver, m.reference, c.component)] = row
    return rows


def write_metrics_table(g: h5py.Group, rows: MetricRows) -> None:
    """``metrics``: the compound dataset of ``rows`` with per-field ``units`` and ``descriptions``
    attributes (string arrays in field order)."""
    data = np.zeros(len(rows), dtype=METRIC_DTYPE)
    for i, (key, row) in enumerate(rows.items()):
        for name, value in (*zip(_ROW_KEY, key), *row.items()):
            data[i][name] = value.encode("utf-8") if isinstance(value, str) else value
    ds = g.create_dataset(METRICS, data=data)
    ds.attrs["units"] = np.array([u.encode() for _, _, u, _ in METRIC_FIELDS])
    ds.attrs["descriptions"] = np.array([d.encode() for _, _, _, d in METRIC_FIELDS])


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


def write_scene(g: h5py.Group, r: SceneResult, run: int, stored_metrics: MetricRows | None = None,
                parameters: h5py.Group | None = None) -> None:
    """A complete scene group (``complete`` written last).  An upgrade carries over verbatim what an
    older layout stored: ``stored_metrics`` (they replace the computed ones where both exist) and the
    ``parameters`` group (copied as it is)."""
    for name, value in (("key", r.key), ("label", r.spec.label), ("status", r.status), ("stage", r.stage),
                        ("error_type", r.error_type), ("message", r.message), ("warnings", r.warnings),
                        ("failure_class", r.failure_class)):
        g.attrs[name] = value
    g.attrs["rpm"] = float(r.rpm)
    g.attrs["omega1_min_rad_s"] = float(r.omega1_min)
    g.attrs["run"] = int(run)
    if parameters is not None:
        parameters.parent.copy(parameters, g, "parameters")
    else:
        write_parameters(new_group(g, "parameters"), r.spec)
    if r.crank_angle is not None:
        _dataset(g, "crank_angle", r.crank_angle, "rad", "crank angle grid, CCW from M->Q")
    if r.coupler_point is not None:
        _dataset(g, "coupler_point", r.coupler_point, "m", "rigid coupler point P (x, y), global frame")
    if r.natural_frequencies is not None:
        _dataset(g, "natural_frequencies", r.natural_frequencies, "Hz",
                 "natural frequencies of the frozen structure at each crank angle (n, n_modes)")
    sols = new_group(g, SOLUTIONS)
    for s in r.solutions.values():
        write_solution(sols, s)
    rows = metric_rows(r.metrics)
    for key, row in (stored_metrics or {}).items():
        rows[key] = {**rows.get(key, {}), **row}
    write_metrics_table(g, rows)
    st = new_group(g, "run_stats")
    for name in _RUN_STAT_FIELDS:
        st.attrs[name] = getattr(r.stats, name)
    g.attrs["complete"] = np.uint8(1)  # written last


# -- reading --------------------------------------------------------------------------------------


def _array(g: h5py.Group, name: str) -> np.ndarray | None:
    return np.asarray(g[name][()]) if name in g else None


def _histories(g: h5py.Group | h5py.Dataset) -> dict[str, np.ndarray]:
    """Component -> history of a solution: the columns of a version-3 dataset, the datasets of a
    version-1/2 group."""
    if isinstance(g, h5py.Dataset):
        comps = [c for c in text(g.attrs.get("components", "")).split(",") if c]
        data = np.asarray(g[()])
        if data.ndim != 2 or data.shape[1] != len(comps):
            raise ValueError(f"solution {g.name}: shape {data.shape} does not match components {comps}")
        return {c: data[:, i].copy() for i, c in enumerate(comps)}
    return {c: np.asarray(g[c][()]) for c in COMPONENTS if c in g}


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


DAMAGED = "damaged"
"""Failure class of a scene stored as ok whose stored data are incomplete or impossible (a damaged
file): shown as failed, never with a verdict."""


def _damage(spec: SceneSpec, solutions: dict[str, Solution], theta: np.ndarray | None, rpm: float) -> list[str]:
    """What an ok scene's stored data lack or get wrong."""
    out = [] if math.isfinite(rpm) and rpm > 0 else [f"rpm {rpm} is not a positive finite speed"]
    if theta is None:
        return out + ["crank_angle missing"]
    for name, s in solutions.items():
        if not s.ok:
            continue
        for c in spec.outputs:
            h = s.deflection.get(c)
            if h is None:
                out.append(f"history {name}/{c} missing")
            elif h.shape != theta.shape or not np.all(np.isfinite(h)):
                out.append(f"history {name}/{c} has shape {h.shape} or non-finite values")
    return out


def read_scene(g: h5py.Group, version: int) -> SceneResult:
    """The scene of a complete group (``version``: the file's schema version)."""
    spec = SceneSpec.from_dict(json.loads(text(g["parameters"].attrs["json"])))
    if version >= 2:
        solutions = {name: read_solution(name, sg) for name, sg in g[SOLUTIONS].items()}
    else:
        solutions = _solutions_v1(g)
    rpm, omega1_min = float(g.attrs["rpm"]), float(g.attrs["omega1_min_rad_s"])
    theta = _array(g, "crank_angle")
    status, stage = text(g.attrs["status"]), text(g.attrs["stage"])
    failure_class = text(g.attrs.get("failure_class", ""))
    error_type, message = text(g.attrs["error_type"]), text(g.attrs["message"])
    damage = _damage(spec, solutions, theta, rpm) if status == STATUS_OK else []
    if damage:  # never shown as a valid answer: the scene is marked damaged, its verdict withheld
        status, stage, failure_class, error_type = STATUS_FAILED, "file", DAMAGED, "DamagedFile"
        message = f"the results file is damaged: {'; '.join(damage)} (check it with `ked inspect FILE --verify`)"
    metrics: dict[str, PairMetrics] = {}
    ok = {n: s for n, s in solutions.items() if s.ok and s.deflection and not damage}
    if theta is not None and ok:
        try:
            metrics = all_pairs(theta, {n: s.deflection for n, s in ok.items()}, {n: s.fidelity for n, s in ok.items()},
                                omega=rpm_to_rad_s(rpm), omega1_min=omega1_min, tolerance=spec.tolerance,
                                direction_sign=direction_sign(spec.direction))
        except ValueError:
            metrics = {}
    return SceneResult(
        spec=spec, status=status, stage=stage, error_type=error_type, message=message,
        warnings=text(g.attrs.get("warnings", "")), failure_class=failure_class,
        rpm=rpm, omega1_min=omega1_min, crank_angle=theta, coupler_point=_array(g, "coupler_point"),
        natural_frequencies=_array(g, "natural_frequencies"), solutions=solutions, metrics=metrics,
        stats=_run_stats(g),
    )


# -- verification ---------------------------------------------------------------------------------


def verify_scene(name: str, g: Any, version: int) -> list[str]:
    """Problems of one scene group (empty = valid)."""
    if not isinstance(g, h5py.Group):
        return ["not a group"]
    if not complete(g):
        return ["incomplete (no complete=1 attribute)"]
    p = [f"missing attribute {a!r}" for a in SCENE_ATTRS if a not in g.attrs]
    if p:
        return p
    if text(g.attrs["key"]) != name:
        p.append(f"key attribute {text(g.attrs['key'])!r} differs from group name")
    try:
        r = read_scene(g, version)
    except (KeyError, ValueError, TypeError) as exc:
        return p + [f"unreadable: {exc}"]
    if r.key != name:
        p.append(f"content key of parameters ({r.key}) differs from group name")
    if r.status not in (STATUS_OK, STATUS_FAILED):
        p.append(f"unknown status {r.status!r}")
    if r.failure_class == DAMAGED and text(g.attrs["status"]) == STATUS_OK:
        return p + [r.message.split(" (check it")[0]] + _verify_ok_scene(g, r, version)
    if r.status != STATUS_OK:
        return p + ([] if r.message else ["failed scene without message"])
    return p + _verify_ok_scene(g, r, version)


def _verify_ok_scene(g: h5py.Group, r: SceneResult, version: int) -> list[str]:
    p = [f"missing dataset {ds}" for ds in ("crank_angle", "coupler_point", "natural_frequencies") if ds not in g]
    if p:
        return p
    p += [f"dataset {ds} has no units attribute" for ds in ("crank_angle", "coupler_point", "natural_frequencies")
          if "units" not in g[ds].attrs]
    spec = r.spec
    n = steps_per_turn(spec.step_deg)
    shapes = {"crank_angle": (n,), "coupler_point": (n, 2), "natural_frequencies": (n, spec.n_modes)}
    p += [f"{ds} shape {g[ds].shape} != {shape}" for ds, shape in shapes.items() if g[ds].shape != shape]
    for solver in spec.solvers:
        s = r.solutions.get(solver)
        if s is None:
            p.append(f"missing solution of solver {solver!r}")
            continue
        for c in spec.outputs:
            h = s.deflection.get(c)
            if h is None:
                p.append(f"missing history {solver}/{c}")
            elif h.shape != (n,):
                p.append(f"{solver}/{c} shape {h.shape} != ({n},)")
            elif not np.all(np.isfinite(h)):
                p.append(f"{solver}/{c} has non-finite values")
    if len(spec.solvers) > 1 and r.verdict is None:
        p.append("no verdict: the quasi-static solution or a reference is missing")
    return p + _verify_stored_metrics(g, r, version)


def _verify_stored_metrics(g: h5py.Group, r: SceneResult, version: int) -> list[str]:
    """The stored metrics (for readers without the harness) must be those of the stored histories."""
    if METRICS not in g:
        return [f"missing {METRICS}" + (" table" if version >= 3 else " group")] if r.metrics else []
    try:
        rows = stored_metric_rows(g, version)
    except (KeyError, ValueError, TypeError) as exc:
        return [f"{METRICS} unreadable: {exc}"]
    p = []
    for name, m in r.metrics.items():
        for c in m.components:
            row = rows.get((m.solver, m.reference, c.component))
            if row is None:
                if version >= 2 or c.component in ("dx", "dy", "rotation"):
                    p.append(f"missing {METRICS} of {name}/{c.component}")
                continue
            same = (bool(row.get("holds", not c.holds)) == c.holds
                    and np.isclose(float(row.get("history_error", np.nan)), c.history_error, rtol=1e-12))
            if not same:
                p.append(f"{METRICS} of {name}/{c.component}: stored values differ from the histories")
    return p
