"""The scenes of a results file <-> :class:`~compare.results.SceneResult` (layout in
``docs/hdf5_schema.md``).  Schema versions 4-5 (5 written): per-file tables of scenes, solutions and metrics
(:mod:`compare.tables`, their columns in :mod:`compare.h5schema`) and one group of arrays per scene
(:class:`TableFile` reads it); versions 1-3 (one group per scene holding everything) are read by
:mod:`compare.h5legacy` for the upgrade.  The checks of a stored scene: :mod:`compare.h5checks`; the dimension
scales: :mod:`compare.h5dims`.

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

from compare.h5schema import (  # noqa: F401 (h5layout.<name>: the readers' name)
    ARRAYS,
    METRIC_COLUMNS,
    METRIC_FIELDS,
    METRIC_TABLE,
    RUN_COLUMNS,
    RUNS,
    SCENE_COLUMNS,
    SCENE_TABLE,
    SCENES,
    SOLUTION_COLUMNS,
    SOLUTION_TABLE,
    TABLES,
)
from compare.metrics import PairMetrics, all_pairs
from compare.results import STATUS_OK, RunStats, SceneResult
from compare.scenes import FOUR_BAR, SLIDER_KIND, SceneSpec, canonical_json
from compare.solvers import COMPONENT_UNITS, COMPONENTS, STATUS_FAILED, Solution
from compare.solvers import STRESS as STRESS_OUTPUT
from ked_quasi.linkage import LINKS, direction_sign
from ked_quasi.units import rpm_to_rad_s

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
    return {**a, **_LINKAGE_COLUMNS[spec.kind](lk)}


def _four_bar_columns(lk: Any) -> dict[str, Any]:
    """A four-bar's linkage columns."""
    a: dict[str, Any] = {}
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


_LINKAGE_COLUMNS = {FOUR_BAR: _four_bar_columns, SLIDER_KIND: _slider_columns}
"""Linkage kind -> its linkage columns of the scenes table (a new kind adds its entry)."""


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
