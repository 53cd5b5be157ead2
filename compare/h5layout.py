"""One scene group of a results file <-> a :class:`~compare.results.SceneResult` (layout in
``docs/hdf5_schema.md``).  Schema version 2 writes one group per solver under ``solutions/`` and one
per solver pair under ``metrics/``; version 1 files (quasi-static and Exudyn only) are read too.

Metrics are stored for readers without the harness; the harness itself recomputes them from the
stored histories when it reads a scene (:func:`compare.metrics.all_pairs`), so there is one
definition of every number it shows.
"""

from __future__ import annotations

import json
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


def write_solution(g: h5py.Group, s: Solution) -> None:
    """``solutions/<solver>/``: the history datasets and the solver's status, settings and statistics."""
    a = g.attrs
    a["status"], a["message"], a["error_type"] = s.status, s.message, s.error_type
    a["failure_class"], a["flags"], a["warnings"] = s.failure_class, ",".join(s.flags), s.warnings
    a["fidelity"] = int(s.fidelity)
    a["settings_json"] = canonical_json(s.settings)
    a["stats_json"] = json.dumps(s.stats, sort_keys=True, allow_nan=True)
    for comp in COMPONENTS:
        if comp in s.deflection:
            _dataset(g, comp, s.deflection[comp], COMPONENT_UNITS[comp], f"{s.solver} {comp} of P")


def write_metrics(g: h5py.Group, m: PairMetrics) -> None:
    """``metrics/<solver>_vs_<reference>/``: pair attributes and one subgroup per component."""
    a = g.attrs
    a["solver"], a["reference"] = m.solver, m.reference
    a["omega_rad_s"], a["omega1_min_rad_s"], a["speed_ratio"] = m.omega, m.omega1_min, m.speed_ratio
    a["tolerance"], a["holds"], a["verdict_error"] = m.tolerance, flag(m.holds), m.verdict_error
    for c in m.components:
        cg = g.create_group(c.component)
        cg.attrs["units"] = c.units
        for name in _METRIC_ATTRS:
            cg.attrs[name] = float(getattr(c, name))
        cg.attrs["phase_shift_rad"] = float(c.phase_shift)
        cg.attrs["holds"] = flag(c.holds)


def write_scene(g: h5py.Group, r: SceneResult, run: int) -> None:
    """A complete scene group (``complete`` written last)."""
    for name, value in (("key", r.key), ("label", r.spec.label), ("status", r.status), ("stage", r.stage),
                        ("error_type", r.error_type), ("message", r.message), ("warnings", r.warnings),
                        ("failure_class", r.failure_class)):
        g.attrs[name] = value
    g.attrs["rpm"] = float(r.rpm)
    g.attrs["omega1_min_rad_s"] = float(r.omega1_min)
    g.attrs["run"] = int(run)
    write_parameters(g.create_group("parameters"), r.spec)
    if r.crank_angle is not None:
        _dataset(g, "crank_angle", r.crank_angle, "rad", "crank angle grid, CCW from M->Q")
    if r.coupler_point is not None:
        _dataset(g, "coupler_point", r.coupler_point, "m", "rigid coupler point P (x, y), global frame")
    if r.natural_frequencies is not None:
        _dataset(g, "natural_frequencies", r.natural_frequencies, "Hz",
                 "natural frequencies of the frozen structure at each crank angle (n, n_modes)")
    sols = g.create_group(SOLUTIONS)
    for name, s in r.solutions.items():
        write_solution(sols.create_group(name), s)
    mg = g.create_group(METRICS)
    for name, m in r.metrics.items():
        write_metrics(mg.create_group(name), m)
    st = g.create_group("run_stats")
    for name in _RUN_STAT_FIELDS:
        st.attrs[name] = getattr(r.stats, name)
    g.attrs["complete"] = np.uint8(1)  # written last


# -- reading --------------------------------------------------------------------------------------


def _array(g: h5py.Group, name: str) -> np.ndarray | None:
    return np.asarray(g[name][()]) if name in g else None


def _histories(g: h5py.Group) -> dict[str, np.ndarray]:
    return {c: np.asarray(g[c][()]) for c in COMPONENTS if c in g}


def read_solution(name: str, g: h5py.Group) -> Solution:
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
    """The scene of a complete group (``version``: the file's schema version)."""
    spec = SceneSpec.from_dict(json.loads(text(g["parameters"].attrs["json"])))
    if version >= 2:
        solutions = {name: read_solution(name, sg) for name, sg in g[SOLUTIONS].items()}
    else:
        solutions = _solutions_v1(g)
    rpm, omega1_min = float(g.attrs["rpm"]), float(g.attrs["omega1_min_rad_s"])
    theta = _array(g, "crank_angle")
    metrics: dict[str, PairMetrics] = {}
    ok = {n: s for n, s in solutions.items() if s.ok and s.deflection}
    if theta is not None and ok:
        try:
            metrics = all_pairs(theta, {n: s.deflection for n, s in ok.items()}, {n: s.fidelity for n, s in ok.items()},
                                omega=rpm_to_rad_s(rpm), omega1_min=omega1_min, tolerance=spec.tolerance,
                                direction_sign=direction_sign(spec.direction))
        except ValueError:
            metrics = {}
    return SceneResult(
        spec=spec, status=text(g.attrs["status"]), stage=text(g.attrs["stage"]),
        error_type=text(g.attrs["error_type"]), message=text(g.attrs["message"]),
        warnings=text(g.attrs.get("warnings", "")), failure_class=text(g.attrs.get("failure_class", "")),
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
    if r.status != STATUS_OK:
        return p + ([] if r.message else ["failed scene without message"])
    return p + _verify_ok_scene(g, r)


def _verify_ok_scene(g: h5py.Group, r: SceneResult) -> list[str]:
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
    return p + (_verify_stored_metrics(g[METRICS], r) if METRICS in g and SOLUTIONS in g else [])


def _verify_stored_metrics(mg: h5py.Group, r: SceneResult) -> list[str]:
    """The stored metrics (for readers without the harness) must be those of the stored histories."""
    p = []
    for name, m in r.metrics.items():
        if name not in mg:
            p.append(f"missing metrics/{name}")
            continue
        for c in m.components:
            a = mg[name][c.component].attrs if c.component in mg[name] else {}
            same = (bool(a.get("holds", not c.holds)) == c.holds
                    and np.isclose(float(a.get("history_error", np.nan)), c.history_error, rtol=1e-12))
            if not same:
                p.append(f"metrics/{name}/{c.component}: stored values differ from the histories")
    return p
