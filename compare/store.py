"""HDF5 backend of campaign results (layout: ``docs/hdf5_schema.md``).

Crash safety: HDF5 is not journaled, so the results file is never modified in place.  Every change
(:func:`commit`, :func:`record_run`) copies the current file to a temporary file in the same
directory, modifies the copy, closes and fsyncs it and atomically renames it onto the results file
(``os.replace``), then fsyncs the directory.  A SIGKILL at any moment therefore leaves either the old
or the new complete file (plus, at worst, a stale ``*.h5.tmp-*`` file that is ignored and cleaned up
on the next run).  Each scene group additionally gets its ``complete`` attribute last, and readers
ignore groups without it.  Only one process (the campaign's parent) writes.

Everything is plain HDF5 (groups, numeric datasets, string/number attributes, no pickles).
"""

from __future__ import annotations

import datetime as _dt
import json
import math
import os
import platform
import shutil
import socket
import subprocess
import uuid
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from importlib import metadata
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from compare.metrics import ComponentMetrics, SceneMetrics
from compare.results import STATUS_OK, STATUSES, RunStats, SceneResult
from compare.scenes import COMPONENT_UNITS, COMPONENTS, LINKS, SceneSpec, canonical_json

SCHEMA = "ked-harness/campaign"
SCHEMA_VERSION = 1
SCENES = "scenes"
RUNS = "runs"
TMP_MARK = ".tmp-"

_METRIC_FIELDS = (
    "max_abs_error",
    "rms_error",
    "relative_error",
    "phase_shift",
    "amplification",
    "dynamic_peak",
    "quasi_static_peak",
)
# dataclass field -> HDF5 attribute name (unit suffix where the unit is fixed)
_METRIC_ATTR = {name: ("phase_shift_rad" if name == "phase_shift" else name) for name in _METRIC_FIELDS}
_RUN_STAT_FIELDS = (
    "frequencies_wall_s",
    "quasi_static_wall_s",
    "dynamic_wall_s",
    "total_wall_s",
    "steps",
    "newton_iterations",
    "cycles",
    "converged",
    "dynamic_message",
    "worker",
    "finished_utc",
)


class StoreError(ValueError):
    """A results file that does not follow the schema (or is damaged)."""


# --------------------------------------------------------------------------------------------------
# provenance


def utc_now() -> str:
    """Current UTC time, ISO 8601 with seconds."""
    return _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")


def _version(dist: str) -> str:
    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return "unknown"


def git_commit() -> str:
    """Commit hash of the harness source tree, or "" when not in a git checkout."""
    here = Path(__file__).resolve().parent
    try:
        out = subprocess.run(
            ["git", "-C", str(here), "rev-parse", "HEAD"],
            capture_output=True, text=True, timeout=5, check=False,
        )
    except (OSError, subprocess.SubprocessError):
        return ""
    return out.stdout.strip() if out.returncode == 0 else ""


def provenance() -> dict[str, str]:
    """Versions of the software that produce a file (all strings)."""
    return {
        "harness_version": _version("ked-harness"),
        "exudyn_version": _version("exudyn"),
        "numpy_version": np.__version__,
        "h5py_version": h5py.__version__,
        "hdf5_version": h5py.version.hdf5_version,
        "python_version": platform.python_version(),
        "git_commit": git_commit(),
        "host": socket.gethostname(),
    }


# --------------------------------------------------------------------------------------------------
# atomic transactions


def _fsync_path(path: Path, directory: bool = False) -> None:
    flags = os.O_RDONLY | (getattr(os, "O_DIRECTORY", 0) if directory else 0)
    try:
        fd = os.open(path, flags)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


@contextmanager
def transaction(path: str | Path) -> Iterator[h5py.File]:
    """Open a private copy of ``path`` for writing; on success atomically replace ``path`` by it.

    On any exception (or kill) the results file is untouched and the copy is removed (or left as a
    stale temp file that nothing reads).
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f"{path.name}{TMP_MARK}{os.getpid()}-{uuid.uuid4().hex[:8]}")
    try:
        if path.exists():
            shutil.copyfile(path, tmp)
        with h5py.File(tmp, "a") as f:
            yield f
            f.flush()
        _fsync_path(tmp)
        os.replace(tmp, path)
        _fsync_path(path.parent, directory=True)
    finally:
        if tmp.exists():
            tmp.unlink()


class LockedError(RuntimeError):
    """Another process is writing the same results file."""


@contextmanager
def writer_lock(path: str | Path) -> Iterator[None]:
    """Exclusive, non-blocking lock on ``<path>.lock`` for one writer (campaign) at a time; released by
    the kernel if the process dies.  Raises :class:`LockedError` if another process holds it."""
    import fcntl

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    lock = path.with_name(path.name + ".lock")
    fd = os.open(lock, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            raise LockedError(f"{path} is being written by another process (lock {lock})") from exc
        try:
            yield
        finally:
            try:
                lock.unlink()
            except OSError:
                pass
    finally:
        os.close(fd)


def stale_temp_files(path: str | Path) -> list[Path]:
    """Temporary files left next to ``path`` by killed writers."""
    path = Path(path)
    if not path.parent.exists():
        return []
    return sorted(path.parent.glob(f"{path.name}{TMP_MARK}*"))


def remove_stale_temp_files(path: str | Path) -> int:
    """Delete :func:`stale_temp_files`; returns how many were removed.  Call only when no other
    writer runs on the same results file."""
    n = 0
    for p in stale_temp_files(path):
        try:
            p.unlink()
            n += 1
        except OSError:
            pass
    return n


# --------------------------------------------------------------------------------------------------
# writing


def record_run(path: str | Path, config_text: str, campaign_name: str, n_scenes: int) -> int:
    """Create the file if needed, set/refresh the file attributes and add a ``/runs/<n>`` record.
    Returns the run number (0 for the first run into this file)."""
    prov = provenance()
    now = utc_now()
    with transaction(path) as f:
        if "schema" not in f.attrs:
            f.attrs["schema"] = SCHEMA
            f.attrs["schema_version"] = SCHEMA_VERSION
            f.attrs["created_utc"] = now
        for k, v in prov.items():
            f.attrs[k] = v
        f.attrs["modified_utc"] = now
        f.attrs["campaign_name"] = campaign_name
        f.attrs["campaign_config"] = config_text
        f.require_group(SCENES)
        runs = f.require_group(RUNS)
        number = len(runs)
        g = runs.create_group(f"{number:04d}")
        g.attrs["started_utc"] = now
        g.attrs["campaign_name"] = campaign_name
        g.attrs["campaign_config"] = config_text
        g.attrs["n_scenes"] = int(n_scenes)
        for k, v in prov.items():
            g.attrs[k] = v
    return number


def commit(path: str | Path, results: Iterable[SceneResult], run: int = -1) -> None:
    """Atomically add (or replace) the scene groups of ``results`` in the results file."""
    results = list(results)
    if not results:
        return
    with transaction(path) as f:
        scenes = f.require_group(SCENES)
        for r in results:
            if r.key in scenes:
                del scenes[r.key]
            _write_scene(scenes.create_group(r.key), r, run)
        f.attrs["modified_utc"] = utc_now()


def _flag(b: bool) -> np.uint8:
    return np.uint8(1 if b else 0)


def _dataset(g: h5py.Group, name: str, data: np.ndarray, units: str, description: str) -> None:
    ds = g.create_dataset(name, data=np.asarray(data, dtype=np.float64))
    ds.attrs["units"] = units
    ds.attrs["description"] = description


def _write_parameters(g: h5py.Group, spec: SceneSpec) -> None:
    lk = spec.linkage
    a = g.attrs
    a["json"] = spec.canonical_json()
    a["label"] = spec.label
    a["mechanism"] = spec.mechanism
    a["mass_model"] = spec.mass_model.name
    a["mass_lumps"] = spec.mass_model.lumps
    a["payload_kg"] = spec.mass_model.payload
    a["joint_split"] = spec.mass_model.joint_split
    a["lump_placement"] = spec.mass_model.placement
    a["speed_kind"] = spec.speed.kind
    if spec.speed.kind == "rpm":
        a["speed_rpm"] = spec.speed.value
    else:
        a["speed_ratio_requested"] = spec.speed.value
    a["stiffness_scale"] = spec.stiffness_scale
    a["damping_ratio"] = spec.damping_ratio
    a["direction"] = spec.direction
    a["step_deg"] = spec.step_deg
    a["n_modes"] = spec.n_modes
    a["outputs"] = ",".join(spec.outputs)
    a["tolerance"] = spec.tolerance
    a["crank_m"] = lk.crank
    a["coupler_m"] = lk.coupler
    a["follower_m"] = lk.follower
    a["extender_m"] = lk.extender
    a["coupler_angle_rad"] = lk.coupler_angle
    a["crank_pivot_m"] = np.asarray(lk.crank_pivot, dtype=np.float64)
    a["follower_pivot_m"] = np.asarray(lk.follower_pivot, dtype=np.float64)
    a["branch"] = lk.branch
    a["links"] = ",".join(LINKS)
    a["youngs_modulus_Pa"] = np.array([s.youngs_modulus for s in lk.sections])
    a["area_m2"] = np.array([s.area for s in lk.sections])
    a["second_moment_m4"] = np.array([s.second_moment for s in lk.sections])
    a["density_kg_m3"] = np.array([s.density for s in lk.sections])


def _write_scene(g: h5py.Group, r: SceneResult, run: int) -> None:
    spec = r.spec
    g.attrs["key"] = r.key
    g.attrs["label"] = spec.label
    g.attrs["status"] = r.status
    g.attrs["stage"] = r.stage
    g.attrs["error_type"] = r.error_type
    g.attrs["message"] = r.message
    g.attrs["warnings"] = r.warnings
    g.attrs["rpm"] = float(r.rpm)
    g.attrs["omega1_min_rad_s"] = float(r.omega1_min)
    g.attrs["run"] = int(run)
    _write_parameters(g.create_group("parameters"), spec)

    dyn = g.create_group("dynamic_settings")
    dyn.attrs["json"] = canonical_json(r.dynamic_settings)
    for k, v in r.dynamic_settings.items():
        if v is not None:
            dyn.attrs[k] = _flag(v) if isinstance(v, bool) else v

    if r.crank_angle is not None:
        _dataset(g, "crank_angle", r.crank_angle, "rad", "crank angle grid, CCW from M->Q")
    if r.coupler_point is not None:
        _dataset(g, "coupler_point", r.coupler_point, "m", "rigid coupler point P (x, y), global frame")
    if r.natural_frequencies is not None:
        _dataset(g, "natural_frequencies", r.natural_frequencies, "Hz",
                 "natural frequencies of the frozen structure at each crank angle (n, n_modes)")
    for side, data in (("quasi_static", r.quasi_static), ("dynamic", r.dynamic)):
        if data:
            sg = g.create_group(side)
            for comp in COMPONENTS:
                if comp in data:
                    _dataset(sg, comp, data[comp], COMPONENT_UNITS[comp], f"{side} {comp} of P")

    if r.metrics is not None:
        m = r.metrics
        mg = g.create_group("metrics")
        mg.attrs["omega_rad_s"] = m.omega
        mg.attrs["omega1_min_rad_s"] = m.omega1_min
        mg.attrs["speed_ratio"] = m.speed_ratio
        mg.attrs["tolerance"] = m.tolerance
        mg.attrs["holds"] = _flag(m.holds)
        mg.attrs["max_relative_error"] = m.max_relative_error
        for c in m.components:
            cg = mg.create_group(c.component)
            cg.attrs["units"] = c.units
            for name in _METRIC_FIELDS:
                cg.attrs[_METRIC_ATTR[name]] = float(getattr(c, name))
            cg.attrs["holds"] = _flag(c.holds)

    st = g.create_group("run_stats")
    for name in _RUN_STAT_FIELDS:
        v = getattr(r.stats, name)
        st.attrs[name] = _flag(v) if isinstance(v, bool) else v
    g.attrs["complete"] = np.uint8(1)  # written last


# --------------------------------------------------------------------------------------------------
# reading


def _s(v: Any) -> str:
    return v.decode("utf-8") if isinstance(v, bytes) else str(v)


def _complete(g: h5py.Group) -> bool:
    return int(g.attrs.get("complete", 0)) == 1


def _map_complete(path: str | Path, read: Callable[[h5py.Group], Any]) -> dict[str, Any]:
    """key -> read(group) for every complete scene group (empty if the file does not exist)."""
    path = Path(path)
    if not path.exists():
        return {}
    with h5py.File(path, "r") as f:
        scenes = f.get(SCENES)
        if scenes is None:
            return {}
        return {k: read(g) for k, g in scenes.items() if _complete(g)}


def stored_status(path: str | Path) -> dict[str, str]:
    """key -> status of every complete scene group (empty if the file does not exist)."""
    return _map_complete(path, lambda g: _s(g.attrs["status"]))


def stored_dynamic_settings(path: str | Path) -> dict[str, dict[str, Any]]:
    """key -> resolved Exudyn settings (``dynamic_settings/json``) of every complete scene group."""
    found = _map_complete(path, lambda g: _s(g["dynamic_settings"].attrs["json"]) if "dynamic_settings" in g
                          else None)
    return {k: json.loads(v) for k, v in found.items() if v is not None}


def file_info(path: str | Path) -> dict[str, Any]:
    """File attributes (strings/numbers) plus ``n_runs``."""
    with h5py.File(path, "r") as f:
        info = {k: (_s(v) if isinstance(v, (str, bytes)) else v.item() if hasattr(v, "item") else v)
                for k, v in f.attrs.items()}
        info["n_runs"] = len(f[RUNS]) if RUNS in f else 0
    return info


def _read_scene(g: h5py.Group) -> SceneResult:
    spec = SceneSpec.from_dict(json.loads(_s(g["parameters"].attrs["json"])))

    def arr(name: str) -> np.ndarray | None:
        return np.asarray(g[name][()]) if name in g else None

    sides = {}
    for side in ("quasi_static", "dynamic"):
        sides[side] = {c: np.asarray(g[side][c][()]) for c in COMPONENTS if side in g and c in g[side]}
    metrics = None
    if "metrics" in g:
        mg = g["metrics"]
        comps = tuple(
            ComponentMetrics(
                component=c,
                units=_s(mg[c].attrs["units"]),
                holds=bool(mg[c].attrs["holds"]),
                **{name: float(mg[c].attrs[_METRIC_ATTR[name]]) for name in _METRIC_FIELDS},
            )
            for c in COMPONENTS
            if c in mg
        )
        metrics = SceneMetrics(
            omega=float(mg.attrs["omega_rad_s"]),
            omega1_min=float(mg.attrs["omega1_min_rad_s"]),
            speed_ratio=float(mg.attrs["speed_ratio"]),
            tolerance=float(mg.attrs["tolerance"]),
            components=comps,
        )
    st = g["run_stats"].attrs
    stats = RunStats(
        frequencies_wall_s=float(st["frequencies_wall_s"]),
        quasi_static_wall_s=float(st["quasi_static_wall_s"]),
        dynamic_wall_s=float(st["dynamic_wall_s"]),
        total_wall_s=float(st["total_wall_s"]),
        steps=int(st["steps"]),
        newton_iterations=int(st["newton_iterations"]),
        cycles=int(st["cycles"]),
        converged=bool(st["converged"]),
        dynamic_message=_s(st["dynamic_message"]),
        worker=_s(st["worker"]),
        finished_utc=_s(st["finished_utc"]),
    )
    return SceneResult(
        spec=spec,
        status=_s(g.attrs["status"]),
        stage=_s(g.attrs["stage"]),
        error_type=_s(g.attrs["error_type"]),
        message=_s(g.attrs["message"]),
        warnings=_s(g.attrs.get("warnings", "")),
        rpm=float(g.attrs["rpm"]),
        omega1_min=float(g.attrs["omega1_min_rad_s"]),
        crank_angle=arr("crank_angle"),
        coupler_point=arr("coupler_point"),
        natural_frequencies=arr("natural_frequencies"),
        quasi_static=sides["quasi_static"],
        dynamic=sides["dynamic"],
        dynamic_settings=json.loads(_s(g["dynamic_settings"].attrs["json"])),
        metrics=metrics,
        stats=stats,
    )


def read_scenes(path: str | Path, keys: Iterable[str] | None = None) -> list[SceneResult]:
    """Complete scenes of the file (all, or those whose key starts with one of ``keys``), in key order."""
    wanted = None if keys is None else list(keys)
    out = []
    with h5py.File(path, "r") as f:
        scenes = f.get(SCENES)
        if scenes is None:
            return []
        for k in sorted(scenes):
            g = scenes[k]
            if not _complete(g):
                continue
            if wanted is not None and not any(k.startswith(w) for w in wanted):
                continue
            try:
                out.append(_read_scene(g))
            except (KeyError, ValueError, TypeError) as exc:
                raise StoreError(f"{path}: /{SCENES}/{k} is unreadable ({exc}); "
                                 "check the file with `ked inspect FILE --verify`") from exc
    return out


# --------------------------------------------------------------------------------------------------
# verification


_SCENE_ATTRS = ("key", "label", "status", "stage", "error_type", "message", "rpm", "omega1_min_rad_s", "run")
_FILE_ATTRS = ("schema", "schema_version", "created_utc", "modified_utc", "harness_version", "exudyn_version",
               "numpy_version", "campaign_config", "campaign_name")


def verify(path: str | Path) -> list[str]:
    """Integrity and schema check; returns a list of problems (empty = valid)."""
    path = Path(path)
    problems: list[str] = []
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        return [f"{path}: cannot open as HDF5: {exc}"]
    with f:
        for a in _FILE_ATTRS:
            if a not in f.attrs:
                problems.append(f"/: missing file attribute {a!r}")
        if _s(f.attrs.get("schema", "")) != SCHEMA:
            problems.append(f"/: schema attribute is not {SCHEMA!r}")
        if SCENES not in f:
            problems.append(f"/: missing group /{SCENES}")
            return problems
        for name, g in f[SCENES].items():
            problems += [f"/{SCENES}/{name}: {p}" for p in _verify_scene(name, g)]
    return problems


def _verify_scene(name: str, g: Any) -> list[str]:
    p: list[str] = []
    if not isinstance(g, h5py.Group):
        return ["not a group"]
    if not _complete(g):
        return ["incomplete (no complete=1 attribute)"]
    for a in _SCENE_ATTRS:
        if a not in g.attrs:
            p.append(f"missing attribute {a!r}")
    if p:
        return p
    if _s(g.attrs["key"]) != name:
        p.append(f"key attribute {_s(g.attrs['key'])!r} differs from group name")
    try:
        spec = SceneSpec.from_dict(json.loads(_s(g["parameters"].attrs["json"])))
    except (KeyError, ValueError, TypeError) as exc:
        return p + [f"unreadable parameters/json: {exc}"]
    if spec.key != name:
        p.append(f"content key of parameters ({spec.key}) differs from group name")
    status = _s(g.attrs["status"])
    if status not in STATUSES:
        p.append(f"unknown status {status!r}")
    if "run_stats" not in g:
        p.append("missing group run_stats")
    else:
        missing = [a for a in _RUN_STAT_FIELDS if a not in g["run_stats"].attrs]
        if missing:
            p.append(f"run_stats missing attributes {missing}")
    if "dynamic_settings" not in g or "json" not in g["dynamic_settings"].attrs:
        p.append("missing dynamic_settings/json")
    for ds in ("crank_angle", "coupler_point", "natural_frequencies"):
        if ds in g and "units" not in g[ds].attrs:
            p.append(f"dataset {ds} has no units attribute")
    if status != STATUS_OK:
        if not _s(g.attrs["message"]):
            p.append("failed scene without message")
        return p
    for ds in ("crank_angle", "coupler_point", "natural_frequencies"):
        if ds not in g:
            p.append(f"missing dataset {ds}")
    if p:
        return p
    n = g["crank_angle"].shape[0]
    expected_n = round(360.0 / spec.step_deg)
    if g["crank_angle"].shape != (expected_n,):
        p.append(f"crank_angle shape {g['crank_angle'].shape} != ({expected_n},)")
    if g["coupler_point"].shape != (n, 2):
        p.append(f"coupler_point shape {g['coupler_point'].shape} != ({n}, 2)")
    if g["natural_frequencies"].shape != (n, spec.n_modes):
        p.append(f"natural_frequencies shape {g['natural_frequencies'].shape} != ({n}, {spec.n_modes})")
    for side in ("quasi_static", "dynamic"):
        for c in spec.outputs:
            if side not in g or c not in g[side]:
                p.append(f"missing dataset {side}/{c}")
            elif g[side][c].shape != (n,):
                p.append(f"{side}/{c} shape {g[side][c].shape} != ({n},)")
            elif not np.all(np.isfinite(g[side][c][()])):
                p.append(f"{side}/{c} has non-finite values")
            elif _s(g[side][c].attrs.get("units", "")) != COMPONENT_UNITS[c]:
                p.append(f"{side}/{c} units attribute is not {COMPONENT_UNITS[c]!r}")
    if "metrics" not in g:
        p.append("missing group metrics")
        return p
    mg = g["metrics"]
    for a in ("omega_rad_s", "omega1_min_rad_s", "speed_ratio", "tolerance", "holds", "max_relative_error"):
        if a not in mg.attrs:
            p.append(f"metrics missing attribute {a!r}")
    for c in spec.outputs:
        if c not in mg:
            p.append(f"metrics missing component {c}")
            continue
        for a in (*_METRIC_ATTR.values(), "holds", "units"):
            if a not in mg[c].attrs:
                p.append(f"metrics/{c} missing attribute {a!r}")
        if "relative_error" in mg[c].attrs and "holds" in mg[c].attrs:
            rel = float(mg[c].attrs["relative_error"])
            if bool(mg[c].attrs["holds"]) != (rel < spec.tolerance) and not math.isnan(rel):
                p.append(f"metrics/{c} verdict inconsistent with relative_error and tolerance")
    return p
