"""The scenes of a results file <-> :class:`~compare.results.SceneResult` (layout in
``docs/hdf5_schema.md``).  Schema version 4 (written): per-file tables of scenes, solutions and metrics
(:mod:`compare.tables`) and one group of arrays per scene (:class:`TableFile` reads it); versions 1-3
(one group per scene holding everything) are read by :func:`read_scene` for the upgrade.

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
from compare.solvers import STRESS as STRESS_OUTPUT
from ked_quasi.linkage import LINKS, direction_sign
from ked_quasi.rules import steps_per_turn
from ked_quasi.units import rad_s_to_rpm, rpm_to_rad_s

CAMPAIGN_SCHEMA = "ked-harness/campaign"
"""The ``schema`` attribute of a campaign results file (and of a study file)."""
SOLUTIONS = "solutions"
STRESS = "stress"
METRICS = "metrics"
_RUN_STAT_FIELDS = ("frequencies_wall_s", "total_wall_s", "worker", "finished_utc")
SCENE_ATTRS = ("key", "label", "status", "stage", "error_type", "message", "rpm", "omega1_min_rad_s", "run")
_METRIC_ATTRS = ("history_error", "peak_error", "max_abs_error", "rms_error", "amplification", "solver_peak",
                 "reference_peak")


def text(v: Any) -> str:
    return v.decode("utf-8") if isinstance(v, bytes) else str(v)


def is_campaign(f: h5py.File) -> bool:
    """Whether ``f`` is a campaign results file (its tables and scene arrays carry dimension scales)."""
    return text(f.attrs.get("schema", "")) == CAMPAIGN_SCHEMA


def complete(g: h5py.Group) -> bool:
    return isinstance(g, h5py.Group) and int(g.attrs.get("complete", 0)) == 1


# The metric columns: one row per (solver pair, component); version 4 in ``/metric_table`` (with the scene's
# key), version 3 in one compound dataset ``metrics`` per scene.  name, version-3 HDF5 type, units ("row" =
# the row's ``units`` column; "1" dimensionless, "" text), description.
METRIC_FIELDS: tuple[tuple[str, str, str, str], ...] = (
    ("solver", "S32", "", "solver measured"),
    ("reference", "S32", "", "reference solver (the higher fidelity)"),
    ("component", "S16", "", "dx, dy, rotation, vector (the deflection vector (dx, dy)), or stress_<link> (the "
                             "link's extreme-fibre normal stresses, both fibres; holds = the link's stress verdict)"),
    ("units", "S8", "", "units of the component"),
    ("history_error", "f8", "1", "max|a - b| / max|b| over the cycle"),
    ("peak_error", "f8", "1", "|max|a| - max|b|| / max|b|"),
    ("max_abs_error", "f8", "row", "max|a - b|"),
    ("rms_error", "f8", "row", "root mean square of |a - b|"),
    ("phase_shift_rad", "f8", "rad", "time lag of the reference's peak behind the solver's, (-pi, pi]"),
    ("amplification", "f8", "1", "max|b| / max|a|"),
    ("solver_peak", "f8", "row", "max|a|"),
    ("reference_peak", "f8", "row", "max|b|"),
    ("holds", "u1", "1", "1 if this component's history_error < tolerance"),
    ("pair_holds", "u1", "1", "1 if the pair holds (the verdict): verdict_error < tolerance; the rotation never "
                              "enters it"),
    ("verdict_error", "f8", "1", "the verdict's measure: history error of the deflection vector (dx, dy), "
                                 "max_k |a_k - b_k| / max_k |b_k| (the pair's vector row's history_error; of dx "
                                 "or dy alone where only one is stored)"),
    ("omega_rad_s", "f8", "rad/s", "crank speed"),
    ("omega1_min_rad_s", "f8", "rad/s", "lowest first natural circular frequency over the cycle"),
    ("speed_ratio", "f8", "1", "omega / omega1_min"),
    ("tolerance", "f8", "1", "campaign tolerance of the verdict"),
)
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
        out += _verify_stress(name, s, spec, theta.size)
        for c in (c for c in spec.outputs if c in COMPONENTS):
            h = s.deflection.get(c)
            if h is None:
                out.append(f"history {name}/{c} missing")
            elif h.shape != theta.shape or not np.all(np.isfinite(h)):
                out.append(f"history {name}/{c} has shape {h.shape} or non-finite values")
    return out


def read_scene(g: h5py.Group, version: int) -> SceneResult:
    """The scene of a complete group of a version-1..3 file (``version``: the file's schema version)."""
    spec = SceneSpec.from_dict(json.loads(text(g["parameters"].attrs["json"])))
    if version >= 2:
        solutions = {name: read_solution(name, sg) for name, sg in g[SOLUTIONS].items()}
    else:
        solutions = _solutions_v1(g)
    return assemble(spec, g.attrs, solutions, _array(g, "crank_angle"), _array(g, "coupler_point"),
                    _array(g, "natural_frequencies"), _run_stats(g))


def assemble(spec: SceneSpec, a: Any, solutions: dict[str, Solution], theta: np.ndarray | None,
             coupler: np.ndarray | None, freqs: np.ndarray | None, stats: RunStats) -> SceneResult:
    """A :class:`SceneResult` from what a file stores: ``a`` maps the scene's attributes (status, stage,
    error_type, message, warnings, failure_class, rpm, omega1_min_rad_s); an ok scene whose data are
    incomplete is marked damaged; the metrics are recomputed from the histories."""
    rpm, omega1_min = float(a["rpm"]), float(a["omega1_min_rad_s"])
    status, stage = text(a["status"]), text(a["stage"])
    failure_class = text(a.get("failure_class", ""))
    error_type, message = text(a["error_type"]), text(a["message"])
    damage = _damage(spec, solutions, theta, rpm) if status == STATUS_OK else []
    if damage:  # never shown as a valid answer: the scene is marked damaged, its verdict withheld
        status, stage, failure_class, error_type = STATUS_FAILED, "file", DAMAGED, "DamagedFile"
        message = f"the results file is damaged: {'; '.join(damage)} (check it with `ked inspect FILE --verify`)"
    metrics: dict[str, PairMetrics] = {}
    ok = {n: s for n, s in solutions.items() if s.ok and s.deflection and not damage}
    if theta is not None and ok:
        try:
            metrics = all_pairs(theta, {n: s.histories for n, s in ok.items()}, {n: s.fidelity for n, s in ok.items()},
                                omega=rpm_to_rad_s(rpm), omega1_min=omega1_min, tolerance=spec.tolerance,
                                direction_sign=direction_sign(spec.direction))
        except ValueError:
            metrics = {}
    return SceneResult(
        spec=spec, status=status, stage=stage, error_type=error_type, message=message,
        warnings=text(a.get("warnings", "")), failure_class=failure_class,
        rpm=rpm, omega1_min=omega1_min, crank_angle=theta, coupler_point=coupler,
        natural_frequencies=freqs, solutions=solutions, metrics=metrics, stats=stats,
    )


# -- verification ---------------------------------------------------------------------------------


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


def _verify_stress(solver: str, s: Solution, spec: SceneSpec, n: int) -> list[str]:
    """A solution's stored link stresses: (n, 2) and finite each; the quasi-static ones present wherever the
    scene asks for stresses (the other tiers may have none, saying why in their warnings)."""
    if STRESS_OUTPUT not in spec.outputs:
        return [f"{solver} has stresses the scene did not ask for"] if s.stress else []
    p = [] if s.stress or solver != "quasi_static" else [f"missing stresses of {solver}"]
    for lk, v in s.stress.items():
        if v.shape != (n, 2):
            p.append(f"stress {solver}/{lk} shape {v.shape} != ({n}, 2)")
        elif s.ok and not np.all(np.isfinite(v)):
            p.append(f"stress {solver}/{lk} has non-finite values")
    return p


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


# -- schema version 4: per-file tables, one group of arrays per scene --------------------------------

SCENES = "scenes"
RUNS = "runs"
SCENE_TABLE = "scene_table"
SOLUTION_TABLE = "solution_table"
METRIC_TABLE = "metric_table"
TABLES = (RUNS, SCENE_TABLE, SOLUTION_TABLE, METRIC_TABLE)

ARRAYS: dict[str, tuple[str, str]] = {
    "crank_angle": ("rad", "crank angle grid, CCW from M->Q, 0 .. 360 deg - step (n,)"),
    "coupler_point": ("m", "rigid coupler point P (x, y), global frame (n, 2)"),
    "natural_frequencies": ("Hz", "first n_modes natural frequencies of the frozen structure at each crank angle "
                                  "(n, n_modes)"),
}
"""Per-scene arrays besides the solutions: name -> (units, description)."""

SCENE_COLUMNS: dict[str, tuple[str, str]] = {
    "key": ("", "content key: first 16 hex digits of SHA-256 of json without solvers"),
    "label": ("", "readable label of the scene"),
    "status": ("", "ok or failed"),
    "stage": ("", "first failing stage: '', setup, a solver's name, metrics, worker"),
    "error_type": ("", "exception type of the failure"),
    "message": ("", "message of the failure"),
    "warnings": ("", "solver warnings, '; '-joined"),
    "failure_class": ("", "'', numerical, physical, undecided, input"),
    "rpm": ("rev/min", "resolved crank speed"),
    "omega1_min_rad_s": ("rad/s", "lowest first natural circular frequency over the cycle"),
    "run": ("1", "row of /runs of the run that stored the scene"),
    "json": ("", "canonical JSON of the scene's parameters (the key is hashed from it without solvers)"),
    "mechanism": ("", "source or cognate"),
    "mass_model": ("", "mass model name"),
    "mass_lumps": ("1", "lumps per link"),
    "payload_kg": ("kg", "payload mass"),
    "joint_split": ("1", "share of a link's mass lumped at its first joint"),
    "lump_placement": ("", "midpoint or end"),
    "speed_kind": ("", "rpm or ratio: how the speed was given"),
    "speed_rpm": ("rev/min", "crank speed as given (NaN when given as a ratio)"),
    "speed_ratio_requested": ("1", "Omega / omega1_min as given (NaN when given in rpm)"),
    "stiffness_scale": ("1", "Young's modulus multiplier"),
    "damping_ratio": ("1", "modal damping ratio"),
    "direction": ("", "ccw or cw"),
    "step_deg": ("deg", "crank-angle step"),
    "n_modes": ("1", "natural frequencies stored per crank angle"),
    "outputs": ("", "stored components, comma-separated"),
    "solvers": ("", "solvers the scene runs, comma-separated"),
    "tolerance": ("1", "verdict tolerance"),
    "kind": ("", "linkage kind: four-bar or slider-crank"),
    "offset_m": ("m", "slider-crank: offset of the slider line from the crank pivot"),
    "coupler_point_fraction": ("1", "slider-crank: coupler point P as a fraction of the coupler from A"),
    "slider_mass_kg": ("kg", "slider-crank: lumped slider mass"),
    "rigid": ("", "slider-crank: rigid flag per link (links order), comma-separated"),
    "crank_m": ("m", "crank length"),
    "coupler_m": ("m", "coupler length"),
    "follower_m": ("m", "follower length"),
    "extender_m": ("m", "extender length (B to P)"),
    "coupler_angle_rad": ("rad", "angle from AB to AP, CCW"),
    "crank_pivot_m": ("m", "crank pivot M (x, y)"),
    "follower_pivot_m": ("m", "follower pivot Q (x, y)"),
    "branch": ("", "assembly branch"),
    "links": ("", "order of the per-link columns"),
    "youngs_modulus_Pa": ("Pa", "Young's modulus per link (links order)"),
    "area_m2": ("m^2", "cross-section area per link"),
    "second_moment_m4": ("m^4", "second moment of area per link"),
    "density_kg_m3": ("kg/m^3", "density per link"),
    "frequencies_wall_s": ("s", "wall time of the natural frequencies"),
    "total_wall_s": ("s", "wall time of the scene"),
    "worker": ("", "host:pid that computed the scene"),
    "finished_utc": ("", "ISO 8601 time the scene finished"),
    "complete": ("1", "1: the scene is complete (its row is written after its arrays and its other rows)"),
}
SOLUTION_COLUMNS: dict[str, tuple[str, str]] = {
    "key": ("", "scene key"),
    "solver": ("", "solver name; histories in /scenes/<key>/solutions/<solver>"),
    "status": ("", "ok or failed"),
    "message": ("", "message of the failure"),
    "error_type": ("", "exception type of the failure"),
    "failure_class": ("", "'', numerical, physical, undecided, input"),
    "flags": ("", "validity flags, comma-separated: the answer is outside the range where the model holds"),
    "warnings": ("", "solver warnings"),
    "fidelity": ("1", "fidelity rank of the solver (higher = reference)"),
    "settings_json": ("", "resolved settings (JSON)"),
    "stats_json": ("", "wall_s [s] and the solver's own statistics (JSON)"),
}
METRIC_COLUMNS: dict[str, tuple[str, str]] = {
    "key": ("", "scene key"), **{name: (units, description) for name, _, units, description in METRIC_FIELDS}}
RUN_COLUMNS: dict[str, tuple[str, str]] = {
    "run": ("1", "run number (the scenes' run column)"),
    "started_utc": ("", "ISO 8601 start time"),
    "campaign_name": ("", "campaign name"),
    "campaign_config": ("", "TOML text of the campaign"),
    "n_scenes": ("1", "scenes the run planned"),
    "harness_version": ("", "version of ked-harness that ran"),
    "exudyn_version": ("", "version of Exudyn"),
    "numpy_version": ("", "version of numpy"),
    "h5py_version": ("", "version of h5py"),
    "hdf5_version": ("", "version of the HDF5 library"),
    "python_version": ("", "version of Python"),
    "git_commit": ("", "commit of the harness source ('' outside a git checkout)"),
    "host": ("", "machine that ran"),
}
_CARRIED = "carried over verbatim from an older layout of the file"
_INT = ("run", "mass_lumps", "n_modes", "fidelity", "n_scenes")
_FLAG = ("complete", "holds", "pair_holds")


def _kinds(columns: dict[str, tuple[str, str]], stored: dict[str, str]) -> dict[str, str]:
    """Column kinds: the stored ones, the declared integers and flags, numbers where a unit is declared."""
    out = dict(stored)
    for name, (units, _) in columns.items():
        if name in _INT:
            out[name] = "int"
        elif name in _FLAG:
            out[name] = "flag"
        elif units:
            out[name] = "float"
    return out


def _units(columns: dict[str, tuple[str, str]]) -> tuple[dict[str, str], dict[str, str]]:
    return {k: u for k, (u, _) in columns.items()}, {k: d for k, (_, d) in columns.items()}


def parameter_row(spec: SceneSpec) -> dict[str, Any]:
    """The scene's parameters as table columns: the JSON the key is hashed from, plus readable values."""
    mm, lk = spec.mass_model, spec.linkage
    a: dict[str, Any] = {"json": canonical_json(spec.to_dict()), "label": spec.label, "mechanism": spec.mechanism,
                         "mass_model": mm.name, "mass_lumps": int(mm.lumps), "payload_kg": float(mm.payload),
                         "joint_split": float(mm.joint_split), "lump_placement": mm.placement,
                         "speed_kind": spec.speed.kind}
    a["speed_rpm" if spec.speed.kind == "rpm" else "speed_ratio_requested"] = float(spec.speed.value)
    for name in ("stiffness_scale", "damping_ratio", "direction", "step_deg", "n_modes", "tolerance"):
        a[name] = getattr(spec, name)
    a["outputs"], a["solvers"] = ",".join(spec.outputs), ",".join(spec.solvers)
    a["kind"] = spec.kind
    if spec.kind != "four-bar":
        return {**a, **_slider_columns(lk)}
    for name in ("crank", "coupler", "follower", "extender"):
        a[f"{name}_m"] = float(getattr(lk, name))
    a["coupler_angle_rad"] = float(lk.coupler_angle)
    a["crank_pivot_m"] = np.asarray(lk.crank_pivot, dtype=np.float64)
    a["follower_pivot_m"] = np.asarray(lk.follower_pivot, dtype=np.float64)
    a["branch"], a["links"] = lk.branch, ",".join(LINKS)
    for field, attr in (("youngs_modulus", "youngs_modulus_Pa"), ("area", "area_m2"),
                        ("second_moment", "second_moment_m4"), ("density", "density_kg_m3")):
        a[attr] = np.array([getattr(s, field) for s in lk.sections], dtype=np.float64)
    return a


def _slider_columns(lk: Any) -> dict[str, Any]:
    """A slider-crank's linkage columns; its per-link columns (crank, coupler) padded with NaN to the
    four-bar's four links so that one table holds both kinds."""
    a: dict[str, Any] = {f"{name}_m": float(getattr(lk, name)) for name in ("crank", "coupler", "offset")}
    a["coupler_point_fraction"], a["slider_mass_kg"] = float(lk.coupler_point), float(lk.slider_mass)
    a["links"] = "crank,coupler"
    a["rigid"] = ",".join(str(r).lower() for r in lk.rigid)
    pad = [np.nan] * (len(LINKS) - len(lk.sections))
    for field, attr in (("youngs_modulus", "youngs_modulus_Pa"), ("area", "area_m2"),
                        ("second_moment", "second_moment_m4"), ("density", "density_kg_m3")):
        a[attr] = np.array([getattr(s, field) for s in lk.sections] + pad, dtype=np.float64)
    return a


def scene_row(r: SceneResult, run: int, parameters: dict[str, Any] | None = None,
              attrs: dict[str, Any] | None = None) -> dict[str, Any]:
    """The scene's row of ``/scene_table`` (``parameters`` / ``attrs``: what an older layout stored, carried
    over verbatim)."""
    row: dict[str, Any] = {"key": r.key, "label": r.spec.label, "status": r.status, "stage": r.stage,
                           "error_type": r.error_type, "message": r.message, "warnings": r.warnings,
                           "failure_class": r.failure_class, "rpm": float(r.rpm),
                           "omega1_min_rad_s": float(r.omega1_min), "run": int(run)}
    row.update(attrs or {})
    row.update(parameter_row(r.spec) if parameters is None else parameters)
    row.update({name: getattr(r.stats, name) for name in _RUN_STAT_FIELDS})
    row["complete"] = True
    return row


def solution_row(key: str, s: Solution, attrs: dict[str, Any] | None = None) -> dict[str, Any]:
    """A solution's row of ``/solution_table`` (``attrs``: an older layout's, carried over verbatim)."""
    row = {"key": key, "solver": s.solver, "status": s.status, "message": s.message, "error_type": s.error_type,
           "failure_class": s.failure_class, "flags": ",".join(s.flags), "warnings": s.warnings,
           "fidelity": int(s.fidelity), "settings_json": canonical_json(s.settings),
           "stats_json": json.dumps(s.stats, sort_keys=True, allow_nan=True)}
    row.update(attrs or {})
    return row


def write_arrays(scenes: h5py.Group, r: SceneResult) -> None:
    """``/scenes/<key>``: the scene's arrays (``units`` attribute each) and ``solutions/<solver>``, one
    (n, c) dataset of a solver's histories (``components`` and ``units`` attributes); nothing (no
    empty group) for a scene without arrays."""
    arrays = {name: getattr(r, attr) for name, attr in (("crank_angle", "crank_angle"),
                                                        ("coupler_point", "coupler_point"),
                                                        ("natural_frequencies", "natural_frequencies"))}
    arrays = {k: v for k, v in arrays.items() if v is not None}
    sols = {n: s for n, s in r.solutions.items() if any(c in s.deflection for c in COMPONENTS)}
    stressed = {n: s.stress for n, s in r.solutions.items() if s.stress}
    if not arrays and not sols and not stressed:
        return
    g = scenes.create_group(r.key)
    for name, data in arrays.items():
        ds = g.create_dataset(name, data=np.asarray(data, dtype=np.float64))
        ds.attrs["units"], ds.attrs["description"] = ARRAYS[name]
    if sols:
        sg = g.create_group(SOLUTIONS)
        for name, s in sols.items():
            comps = [c for c in COMPONENTS if c in s.deflection]
            ds = sg.create_dataset(name, data=np.column_stack([np.asarray(s.deflection[c], dtype=np.float64)
                                                               for c in comps]))
            ds.attrs["components"], ds.attrs["units"] = ",".join(comps), ",".join(COMPONENT_UNITS[c] for c in comps)
            ds.attrs["description"] = (f"{name}'s deflection histories of the coupler point P over the crank angle, "
                                       "one column per component (attribute components; units: attribute units)")
    if stressed:
        tg = g.create_group(STRESS)
        for name, stress in stressed.items():
            write_stress(tg, name, stress)


def write_stress(group: h5py.Group, solver: str, stress: dict[str, np.ndarray]) -> None:
    """``stress/<solver>``: (n, 2 L) [Pa], per link (attribute ``links``) its largest and smallest extreme-fibre
    normal stress over the link at each crank angle (columns ``<link>.max``, ``<link>.min``)."""
    links = list(stress)
    ds = group.create_dataset(solver, data=np.concatenate([np.asarray(stress[lk], dtype=np.float64)
                                                           for lk in links], axis=1))
    ds.attrs["links"] = ",".join(links)
    ds.attrs["columns"] = ",".join(f"{lk}.{f}" for lk in links for f in ("max", "min"))
    ds.attrs["units"] = "Pa"
    ds.attrs["description"] = (f"{solver}'s link stresses over the crank angle: per link (attribute links) the "
                               "largest and the smallest extreme-fibre normal stress N/A +- M c/I over its length "
                               "[Pa] (tension > 0)")


def read_stress(ds: h5py.Dataset | None) -> dict[str, np.ndarray]:
    """Link -> (n, 2) [Pa] of a ``stress/<solver>`` dataset ({} for None)."""
    if ds is None:
        return {}
    data = np.asarray(ds[()], dtype=np.float64)
    links = [x for x in text(ds.attrs["links"]).split(",") if x]
    if data.ndim != 2 or data.shape[1] != 2 * len(links):
        raise ValueError(f"{ds.name}: shape {data.shape} does not hold two columns for each of {len(links)} links")
    return {lk: data[:, 2 * i:2 * i + 2].copy() for i, lk in enumerate(links)}


def metric_table_rows(key: str, rows: MetricRows) -> list[dict[str, Any]]:
    return [{"key": key, **dict(zip(_ROW_KEY, k)), **row} for k, row in rows.items()]


_COLUMNS = {SCENE_TABLE: SCENE_COLUMNS, SOLUTION_TABLE: SOLUTION_COLUMNS, METRIC_TABLE: METRIC_COLUMNS,
            RUNS: RUN_COLUMNS}


def encode_rows(f: h5py.File, name: str, rows: list[dict[str, Any]]) -> dict[str, np.ndarray]:
    """Rows of table ``name`` as encoded columns (declared kinds, else those stored, else inferred)."""
    from compare import tables

    kinds = _kinds(_COLUMNS[name], tables.kinds_of(f[name]) if name in f else {})
    return {c: tables.encode(v, True, kinds.get(c)) for c, v in tables.columns(rows).items()}


def _write(f: h5py.File, name: str, data: dict[str, np.ndarray]) -> None:
    from compare import tables

    units, descriptions = _units(_COLUMNS[name])
    older = _older_verdict_rows(data) if name == METRIC_TABLE else 0
    if older:  # rows an upgrade carried over verbatim from a file written before the vector verdict
        note = (f"; {older} of {len(data['key'])} rows, carried over from a file written before the vector "
                "verdict, hold the worst history error of dx, dy and rotation instead")
        descriptions = {**descriptions, **{c: descriptions[c] + note for c in ("pair_holds", "verdict_error")}}
    tables.write_table(f, name, data, units=units, descriptions={c: _CARRIED for c in data} | descriptions)


def _older_verdict_rows(data: dict[str, np.ndarray]) -> int:
    """Rows of metric-table columns whose ``verdict_error`` is not the vector verdict of their pair (the
    pair's ``vector`` history error, or the larger of dx and dy where only those are stored)."""
    need = ("key", "solver", "reference", "component", "history_error", "verdict_error")
    if any(c not in data for c in need) or not len(data["key"]):
        return 0
    pair = [(bytes(k), bytes(s), bytes(r)) for k, s, r in zip(data["key"], data["solver"], data["reference"])]
    comp = [bytes(c).decode("utf-8") for c in data["component"]]
    expected: dict[tuple[bytes, bytes, bytes], dict[str, float]] = {}
    for p, c, h in zip(pair, comp, data["history_error"]):
        expected.setdefault(p, {})[c] = float(h)
    n = 0
    for p, v in zip(pair, data["verdict_error"]):
        e = expected[p]
        want = e["vector"] if "vector" in e else max((e[c] for c in ("dx", "dy") if c in e), default=math.nan)
        n += not (float(v) == want or (math.isnan(float(v)) and math.isnan(want)))
    return n


def write_tables(f: h5py.File, scenes: list[dict[str, Any]], solutions: list[dict[str, Any]],
                 metrics: list[dict[str, Any]]) -> None:
    """The three scene tables from rows, ``/scene_table`` (with ``complete``) last."""
    for name, rows in ((SOLUTION_TABLE, solutions), (METRIC_TABLE, metrics), (SCENE_TABLE, scenes)):
        _write(f, name, encode_rows(f, name, rows))


def replace_scenes(f: h5py.File, rows: dict[str, list[dict[str, Any]]]) -> None:
    """Replace in the three scene tables every row of the scenes in ``rows[SCENE_TABLE]`` by ``rows``
    (table -> new rows), column-wise (the kept rows are not decoded); ``/scene_table`` last."""
    from compare import tables

    keys = np.array([r["key"].encode("utf-8") for r in rows[SCENE_TABLE]], dtype=bytes)
    for name in (SOLUTION_TABLE, METRIC_TABLE, SCENE_TABLE):
        old = tables.read_raw(f[name]) if name in f else {}
        if old:
            keep = ~np.isin(old["key"], keys)
            old = {c: v[keep] for c, v in old.items()}
        _write(f, name, tables.concat(old, encode_rows(f, name, rows[name])))


def write_runs(f: h5py.File, runs: list[dict[str, Any]]) -> None:
    _write(f, RUNS, encode_rows(f, RUNS, runs))


def table_rows(f: h5py.File, name: str) -> list[dict[str, Any]]:
    """Rows of a version-4 table (empty if absent)."""
    from compare import tables

    return tables.rows(tables.read_table(f[name])) if name in f else []


def _value(v: Any) -> Any:
    """A stored cell as a Python value: text decoded, numpy scalars as Python numbers, rows of a 2-D column
    as arrays."""
    if isinstance(v, (bytes, np.bytes_)):
        return v.decode("utf-8")
    return v.item() if isinstance(v, np.generic) else v


class TableFile:
    """The scenes of a version-4 file (its tables read once)."""

    def __init__(self, f: h5py.File) -> None:
        from compare import tables

        self.f = f
        self._cols = {name: (tables.read_raw(f[name]) if name in f else {}) for name in
                      (SCENE_TABLE, SOLUTION_TABLE, METRIC_TABLE)}
        for name, cols in self._cols.items():
            n = tables.n_rows(f[name]) if name in f else 0
            bad = [c for c, v in cols.items() if len(v) != n]
            if bad:
                raise ValueError(f"/{name}: column {bad[0]} has {len(cols[bad[0]])} rows, the table {n}")
        keys = tables.decode(self._cols[SCENE_TABLE].get("key", np.array([], dtype=bytes)))
        self.index: dict[str, int] = {}
        for i, k in enumerate(keys):
            if k in self.index:
                raise ValueError(f"/{SCENE_TABLE}: scene {k} appears twice")
            self.index[k] = i
        self._by_key: dict[str, dict[str, list[int]]] = {}
        for name in (SOLUTION_TABLE, METRIC_TABLE):
            d: dict[str, list[int]] = {}
            for i, k in enumerate(tables.decode(self._cols[name].get("key", np.array([], dtype=bytes)))):
                d.setdefault(k, []).append(i)
            self._by_key[name] = d
        scenes = f.get(SCENES)
        self.groups = list(scenes) if isinstance(scenes, h5py.Group) else []

    def _row(self, name: str, i: int) -> dict[str, Any]:
        return {c: _value(v[i]) for c, v in self._cols[name].items()}

    def row(self, key: str) -> dict[str, Any]:
        return self._row(SCENE_TABLE, self.index[key])

    def complete(self, key: str) -> bool:
        c = self._cols[SCENE_TABLE].get("complete")
        return c is not None and int(c[self.index[key]]) == 1

    def keys(self) -> list[str]:
        """Keys of the complete scenes, in table order."""
        return [k for k in self.index if self.complete(k)]

    def orphans(self) -> list[str]:
        """Scene groups without a row in the scene table (never written by the harness)."""
        return [g for g in self.groups if g not in self.index]

    def status(self, key: str) -> str:
        return text(self._cols[SCENE_TABLE]["status"][self.index[key]])

    def solution_rows(self, key: str) -> list[dict[str, Any]]:
        return [self._row(SOLUTION_TABLE, i) for i in self._by_key[SOLUTION_TABLE].get(key, [])]

    def metric_rows(self, key: str) -> MetricRows:
        out: MetricRows = {}
        for i in self._by_key[METRIC_TABLE].get(key, []):
            row = self._row(METRIC_TABLE, i)
            row.pop("key")
            vals = {n: (text(row[n]) if kind.startswith("S") else bool(row[n]) if kind == "u1" else float(row[n]))
                    for n, kind, _, _ in METRIC_FIELDS if n in row}
            out[tuple(vals.pop(k) for k in _ROW_KEY)] = vals
        return out

    def arrays(self, key: str) -> h5py.Group | dict[str, Any]:
        g = self.f[SCENES].get(key) if self.groups else None
        return g if g is not None else {}

    def read_scene(self, key: str) -> SceneResult:
        row = self.row(key)
        spec = SceneSpec.from_dict(json.loads(text(row["json"])))
        g = self.arrays(key)
        sg = g.get(SOLUTIONS) if g else None
        tg = g.get(STRESS) if g else None
        solutions = {}
        for srow in self.solution_rows(key):
            name = text(srow["solver"])
            ds = sg.get(name) if sg is not None else None
            flags = text(srow.get("flags", ""))
            solutions[name] = Solution(
                solver=name, status=text(srow["status"]), deflection=_histories(ds) if ds is not None else {},
                stress=read_stress(tg.get(name) if tg is not None else None),
                settings=json.loads(text(srow["settings_json"])), stats=json.loads(text(srow["stats_json"])),
                message=text(srow.get("message", "")), error_type=text(srow.get("error_type", "")),
                failure_class=text(srow.get("failure_class", "")), flags=tuple(flags.split(",")) if flags else (),
                warnings=text(srow.get("warnings", "")), fidelity=int(srow.get("fidelity", 0)))
        stats = RunStats(frequencies_wall_s=float(row["frequencies_wall_s"]), total_wall_s=float(row["total_wall_s"]),
                         worker=text(row["worker"]), finished_utc=text(row["finished_utc"]))
        return assemble(spec, row, solutions, _array(g, "crank_angle") if g else None,
                        _array(g, "coupler_point") if g else None, _array(g, "natural_frequencies") if g else None,
                        stats)

    def verify_scene(self, key: str) -> list[str]:
        """Problems of one scene of the scene table (empty = valid)."""
        if not self.complete(key):
            return [f"incomplete (no complete=1 in /{SCENE_TABLE})"]
        row = self.row(key)
        missing = [a for a in (*SCENE_ATTRS, "json", *_ROW_FIELDS) if a not in row]
        if missing:
            return [f"missing column(s) {', '.join(missing)} of /{SCENE_TABLE}"]
        p = _verify_read(key, text(row["key"]), text(row["status"]), lambda: self.read_scene(key),
                         self.arrays(key), lambda: self.metric_rows(key), 4)
        return p + _verify_parameter_columns(row) + _verify_solution_rows(self.solution_rows(key))


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


# -- dimension scales: the file's dimensions named for netCDF/xarray readers --------------------------

TABLE_DIMENSIONS = {RUNS: "run", SCENE_TABLE: "scene", SOLUTION_TABLE: "solution", METRIC_TABLE: "metric"}
"""Table -> name of its row dimension (the ``run`` column of ``/runs`` is its own scale; the other tables
get a dataset of row numbers)."""
INNER_DIMENSIONS: dict[str, tuple[tuple[str, ...], str]] = {
    "link": (LINKS, "link of a per-link column (four-bar order; a slider-crank's crank and coupler first)"),
    "xy": (("x", "y"), "coordinate of a point (x, y) in the global frame"),
}
"""Dimension -> (labels, description) of the inner dimension of a table's (rows, k) columns."""
INNER_COLUMNS = {"crank_pivot_m": "xy", "follower_pivot_m": "xy", "youngs_modulus_Pa": "link", "area_m2": "link",
                  "second_moment_m4": "link", "density_kg_m3": "link"}
_DIMENSION_ATTRS = ("DIMENSION_LIST", "REFERENCE_LIST")


def _label_scale(g: h5py.Group, name: str, labels: Any, units: str | None = None, description: str = ""
                 ) -> h5py.Dataset:
    """Dataset ``name`` of ``g`` holding ``labels`` (replaced if it holds other values), made a dimension scale
    (one made before is kept: a table or scene group is written anew whenever its content changes); with
    ``units`` and ``description`` attributes unless ``units`` is None (a scene's labels: the schema states
    them, and a scene's bytes count)."""
    data = np.asarray(labels)
    ds = g.get(name)
    if isinstance(ds, h5py.Dataset) and ds.shape == data.shape and "CLASS" in ds.attrs:
        return _detach(ds)
    if not isinstance(ds, h5py.Dataset) or ds.shape != data.shape or (
            data.dtype.kind in "fiu" and not np.array_equal(ds[()], data)) or (
            data.dtype.kind == "U" and [text(x) for x in ds[()]] != list(data)):
        if name in g:
            del g[name]
        if data.dtype.kind == "U":
            ds = g.create_dataset(name, data=list(data), dtype=h5py.string_dtype())
        else:
            ds = g.create_dataset(name, data=data)
    if units is not None:
        ds.attrs["units"], ds.attrs["description"] = units, description
    _scale(ds, name)
    return ds


def _detach(ds: h5py.Dataset) -> h5py.Dataset:
    """``ds`` without scale attachments (an HDF5 copy into another file leaves them dangling)."""
    for a in _DIMENSION_ATTRS:
        if a in ds.attrs:
            del ds.attrs[a]
    return ds


def _scale(ds: h5py.Dataset, name: str) -> None:
    if "CLASS" not in _detach(ds).attrs:
        ds.make_scale(name)


def _table_dimensions(g: h5py.Group, dim: str) -> None:
    from compare import tables

    n = tables.n_rows(g)
    before, own = tables.dimension_names(g), []
    if dim == TABLE_DIMENSIONS[RUNS] and dim in g:  # the runs' column run numbers the rows
        row = g[dim]
        _scale(row, dim)
    else:
        if dim in g and dim not in before:  # a row-number dataset an older writer took for a column
            del g[dim]
        row = _label_scale(g, dim, np.arange(n, dtype=np.int64), "1", "row number of the table")
        own.append(dim)
    cols = [(c, _detach(ds)) for c, ds in tables.column_items(g) if c not in own and c != dim]
    for inner, (labels, description) in INNER_DIMENSIONS.items():
        users = [ds for c, ds in cols if INNER_COLUMNS.get(c) == inner and ds.ndim == 2 and ds.shape[1] == len(labels)]
        if users:  # at the file's root: every dataset of a table is as long as its rows (older readers' rule)
            scale = _label_scale(g.file, inner, labels, "", description)
            for ds in users:
                ds.dims[1].attach_scale(scale)
    g.attrs[tables.DIMENSIONS] = ",".join(own)
    for name in before:
        if name not in own and name in g:
            del g[name]
    for _, ds in cols:
        if ds.ndim and ds.shape[0] == n:
            ds.dims[0].attach_scale(row)


def _scene_dimensions(g: h5py.Group) -> None:
    """A scene group's crank angle as the scale of its arrays' and histories' first dimension, with the
    point coordinates (xy), modes and components as the second."""
    theta = g.get("crank_angle")
    if not isinstance(theta, h5py.Dataset) or theta.ndim != 1:
        return
    _scale(theta, "crank_angle")
    n = theta.shape[0]
    cp, nf = g.get("coupler_point"), g.get("natural_frequencies")
    for ds, dim, labels in ((cp, "xy", ("x", "y")), (nf, "mode", None)):
        if isinstance(ds, h5py.Dataset) and ds.ndim == 2 and ds.shape[0] == n:
            _detach(ds).dims[0].attach_scale(theta)
            labels = np.arange(1, ds.shape[1] + 1, dtype=np.int64) if labels is None else labels
            if len(labels) == ds.shape[1]:
                ds.dims[1].attach_scale(_label_scale(g, dim, labels))
    for sub, attr, dim in ((SOLUTIONS, "components", "component"), (STRESS, "columns", "stress_column")):
        _columns_dimension(g, g.get(sub), theta, attr, dim)


def _columns_dimension(g: h5py.Group, sg: Any, theta: h5py.Dataset, attr: str, dim: str) -> None:
    """The datasets of ``sg`` (the solvers' histories or stresses): the crank angle as their first dimension and
    the column names of attribute ``attr`` as a label scale ``dim`` in the scene group, where all agree."""
    if not isinstance(sg, h5py.Group):
        return
    n = theta.shape[0]
    sols = [ds for ds in sg.values() if isinstance(ds, h5py.Dataset) and ds.ndim == 2 and ds.shape[0] == n]
    if not sols:
        return
    comps = {text(ds.attrs.get(attr, "")) for ds in sols}
    scale = None
    if len(comps) == 1:
        labels = [c for c in comps.pop().split(",") if c]
        if labels and all(ds.shape[1] == len(labels) for ds in sols):
            scale = _label_scale(g, dim, np.array(labels))
    for ds in sols:
        _detach(ds).dims[0].attach_scale(theta)
        if scale is not None:
            ds.dims[1].attach_scale(scale)


def _dimensioned(f: h5py.File) -> list[h5py.Dataset]:
    """Every dataset :func:`attach_dimensions` attaches a scale to or makes one."""
    out = [ds for n in TABLE_DIMENSIONS if isinstance(f.get(n), h5py.Group) for ds in f[n].values()]
    out += [f[n] for n in INNER_DIMENSIONS if isinstance(f.get(n), h5py.Dataset)]
    scenes = f.get(SCENES)
    for g in (scenes.values() if isinstance(scenes, h5py.Group) else ()):
        if isinstance(g, h5py.Group):
            out += [ds for ds in g.values() if isinstance(ds, h5py.Dataset)]
            for sg in (g.get(SOLUTIONS), g.get(STRESS)):
                out += [ds for ds in sg.values() if isinstance(ds, h5py.Dataset)] if isinstance(sg, h5py.Group) else []
    return [ds for ds in out if isinstance(ds, h5py.Dataset)]


def detach_dimensions(f: h5py.File) -> None:
    """Drop every scale attachment of a campaign file (before an HDF5 copy into another file, which would
    leave them dangling and their stale data in the copy)."""
    for ds in _dimensioned(f):
        _detach(ds)


def attach_dimensions(f: h5py.File) -> None:
    """Name every dimension of a version-4 file's tables and scene arrays with HDF5 dimension scales
    (netCDF-4 and xarray read them as named dimensions with coordinates): a table's rows (``scene``,
    ``solution``, ``metric``, ``run``) and its per-link / (x, y) columns (``link``, ``xy``: datasets at the
    file's root); a scene's
    ``crank_angle`` [rad], ``component`` (of ``solutions/<solver>``), ``xy`` and ``mode`` (scales in the
    scene's group: ``solutions/`` holds only the solvers' datasets).  Stale
    attachments (an HDF5 copy into another file leaves them dangling) are dropped and made anew."""
    groups = [f[n] for n in TABLE_DIMENSIONS if isinstance(f.get(n), h5py.Group) and "rows" in f[n].attrs]
    scenes = f.get(SCENES)
    for g in groups:
        _table_dimensions(g, TABLE_DIMENSIONS[g.name.lstrip("/")])
    for g in (scenes.values() if isinstance(scenes, h5py.Group) else ()):
        if isinstance(g, h5py.Group):
            _scene_dimensions(g)
