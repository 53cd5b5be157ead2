"""The reader of campaign results files (layout: ``docs/hdf5_schema.md``): whose file it is, its schema version,
and its scenes as :class:`~compare.results.SceneResult` (version 4-5 tables through
:class:`compare.h5layout.TableFile`, the group-per-scene versions 1-3 through :func:`compare.h5legacy.read_scene`).
Readers ignore scenes without their ``complete`` mark; nothing here writes.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from compare import h5layout, h5legacy
from compare.h5file import _short, target
from compare.results import SceneResult
from compare.solvers import Solution

SCHEMA = h5layout.CAMPAIGN_SCHEMA


SCHEMA_VERSION = 5


READABLE_VERSIONS = (1, 2, 3, 4, 5)
"""Schema versions this harness reads; it writes :data:`SCHEMA_VERSION` and upgrades an older file it
writes into (:func:`upgrade`: same scenes, same numbers, new layout, verified before it replaces the
old file).  Version 5 is version 4 plus the optional link stresses (``/scenes/<key>/stress/<solver>`` and
``stress_<link>`` metric rows): a version-4 file is a version-5 file without stresses, upgraded by its label
alone (a harness that reads only version 4 would take the stress rows for damage, hence the new number)."""


TABLE_LAYOUT = 4
"""The first schema version with the per-file tables (versions 1-3: one group per scene)."""


SCENES = h5layout.SCENES


RUNS = h5layout.RUNS


class StoreError(ValueError):
    """A results file that does not follow the schema (or is damaged)."""


def schema_version(f: h5py.File) -> int | None:
    """The file's schema version if it is a harness campaign file, else None."""
    if h5layout.text(f.attrs.get("schema", "")) != SCHEMA:
        return None
    try:
        return int(f.attrs.get("schema_version", -1))
    except (TypeError, ValueError):
        return None


def check_ours(path: str | Path) -> None:
    """Refuse a file the harness did not create: it must be HDF5 with our schema attribute and a
    readable schema version.  A missing file is fine (it will be created)."""
    path = target(path)
    if not path.exists():
        return
    try:
        with h5py.File(path, "r") as f:
            try:
                list(f.attrs.keys())
            except (RuntimeError, KeyError) as exc:  # HDF5 reports damaged metadata so
                raise StoreError(f"{path}: damaged: its file attributes cannot be read ({_short(exc)}); refusing to "
                                 f"use it; `ked inspect {path.name} --verify` lists the damage") from None
            version = schema_version(f)
            if version is None:
                raise StoreError(f"{path}: not a ked-harness results file (no schema attribute {SCHEMA!r}); "
                                 "refusing to use it; give another --out file")
            if version not in READABLE_VERSIONS:
                raise StoreError(f"{path}: schema version {version} is not supported by this harness "
                                 f"(it reads {READABLE_VERSIONS}); use the harness that wrote it or another file")
    except OSError as exc:
        raise StoreError(f"{path}: cannot be read as HDF5 ({_short(exc)}); refusing to use it; "
                         "give another --out file") from exc


def _scenes(f: h5py.File, path: Path) -> tuple[h5py.Group | None, int]:
    try:
        version = schema_version(f)
        scenes = f.get(SCENES)
    except Exception as exc:  # damage
        raise StoreError(f"{path}: unreadable ({type(exc).__name__}: {_short(exc)}); "
                         "check the file with `ked inspect FILE --verify`") from exc
    if version is None or version not in READABLE_VERSIONS:
        raise StoreError(f"{path}: not a ked-harness results file of a supported schema version "
                         f"({SCHEMA!r}, versions {READABLE_VERSIONS})")
    contradiction = layout_contradiction(f, version)
    if contradiction:
        raise StoreError(f"{path}: {contradiction}; refusing to read it (check it with `ked inspect FILE --verify`)")
    return scenes, version


def layout_contradiction(f: h5py.File, version: int) -> str:
    """What in the file contradicts its ``schema_version`` label ("" if nothing): tables that only
    version 4 has in an older file, a scene group of another version's layout."""
    try:
        if version < 4:
            tables = [f"/{t}" for t in h5layout.TABLES if t != RUNS and t in f]
            if isinstance(f.get(RUNS), h5py.Group) and "rows" in f[RUNS].attrs:
                tables.append(f"/{RUNS} as a table")
            if tables:
                return (f"schema version label {version} contradicts the layout (it holds {', '.join(tables)}, "
                        f"which only version {SCHEMA_VERSION} has)")
        scenes = f.get(SCENES)
        for key, g in (scenes.items() if isinstance(scenes, h5py.Group) else ()):
            if not isinstance(g, h5py.Group):
                continue
            if version >= 4 and ("parameters" in g or "complete" in g.attrs):
                return (f"schema version label {version} contradicts the layout (/{SCENES}/{key} is a scene group "
                        "of an older version, with its parameters inside)")
            if version == TABLE_LAYOUT and h5layout.STRESS in g:
                return (f"schema version label {version} contradicts the layout (/{SCENES}/{key} holds link "
                        f"stresses, which only version {SCHEMA_VERSION} has)")
            foreign = _foreign_members(g, version) if version < 4 else []
            if foreign:
                return (f"schema version label {version} contradicts the layout (/{SCENES}/{key} holds "
                        f"{', '.join(foreign[:3])}, which a version-{version} file cannot have)")
    except Exception as exc:  # damage: reported by the readers
        return f"unreadable layout ({type(exc).__name__}: {_short(exc)})"
    return ""


def _open(path: Path) -> h5py.File:
    try:
        return h5py.File(path, "r")
    except OSError as exc:
        raise StoreError(f"{path}: cannot be read as HDF5 ({_short(exc)})") from exc


class _GroupFile:
    """The scenes of a version-1..3 file: one group per scene holding everything."""

    def __init__(self, scenes: h5py.Group | None, version: int) -> None:
        self.scenes, self.version = scenes, version
        self.names = list(scenes) if scenes is not None else []

    def keys(self) -> list[str]:
        return [k for k in self.names if h5layout.complete(self.scenes[k])]

    def orphans(self) -> list[str]:
        return []

    def status(self, key: str) -> str:
        return h5layout.text(self.scenes[key].attrs["status"])

    def read_scene(self, key: str) -> SceneResult:
        return h5legacy.read_scene(self.scenes[key], self.version)

    def metric_rows(self, key: str) -> h5layout.MetricRows:
        return h5legacy.stored_metric_rows(self.scenes[key], self.version)


def _view(f: h5py.File, scenes: h5py.Group | None, version: int) -> Any:
    return h5layout.TableFile(f) if version >= 4 else _GroupFile(scenes, version)


def _map_complete(path: str | Path, read: Callable[[Any, str], Any],
                  keep: Callable[[str], bool] = lambda key: True) -> dict[str, Any]:
    """key -> read(view, key) for every complete scene whose key ``keep`` accepts (empty if the file
    does not exist); ``view`` is the file's scenes (:class:`compare.h5layout.TableFile` or the
    group-per-scene reader of older versions)."""
    path = Path(path)
    if not path.exists():
        return {}
    with _open(path) as f:
        scenes, version = _scenes(f, path)
        try:
            view = _view(f, scenes, version)
            names = [k for k in view.keys() if keep(k)]
            orphans = view.orphans()
        except Exception as exc:  # HDF5 reports damage as OSError, KeyError, ValueError, RuntimeError
            raise StoreError(f"{path}: the scenes are unreadable ({type(exc).__name__}: {_short(exc)}); "
                             "check the file with `ked inspect FILE --verify`") from exc
        if orphans:
            raise StoreError(f"{path}: /{SCENES}/{orphans[0]} has no row in /{h5layout.SCENE_TABLE} (the harness "
                             "did not write it); check the file with `ked inspect FILE --verify`")
        out = {}
        for k in names:
            try:
                out[k] = read(view, k)
            except Exception as exc:
                raise StoreError(f"{path}: /{SCENES}/{k} is unreadable ({type(exc).__name__}: {_short(exc)}); "
                                 "check the file with `ked inspect FILE --verify`") from exc
        return out


def stored_status(path: str | Path) -> dict[str, str]:
    """key -> status of every complete scene group (empty if the file does not exist)."""
    return _map_complete(path, lambda view, key: view.status(key))


def stored_solutions(path: str | Path) -> dict[str, dict[str, Solution]]:
    """key -> solver name -> stored :class:`~compare.solvers.Solution` of every complete scene."""
    return _map_complete(path, lambda view, key: view.read_scene(key).solutions)


def file_info(path: str | Path) -> dict[str, Any]:
    """File attributes (strings/numbers) plus ``n_runs``."""
    path = Path(path)
    with _open(path) as f:
        _scenes(f, path)
        try:
            info = {k: (h5layout.text(v) if isinstance(v, (str, bytes)) else v.item() if hasattr(v, "item") else v)
                    for k, v in f.attrs.items()}
            info["n_runs"] = len(_runs(f))
        except Exception as exc:  # damage
            raise StoreError(f"{path}: file attributes unreadable ({type(exc).__name__}: {_short(exc)})") from exc
    return info


def _runs(f: h5py.File) -> list[dict[str, Any]]:
    """The run records (version 4: rows of the ``/runs`` table; older: one group per run)."""
    runs = f.get(RUNS)
    if runs is None:
        return []
    if schema_version(f) and schema_version(f) >= 4:
        return h5layout.table_rows(f, RUNS)
    return [{k: (h5layout.text(v) if isinstance(v, (str, bytes)) else v) for k, v in g.attrs.items()}
            for _, g in sorted(runs.items())]


def run_records(path: str | Path) -> list[dict[str, Any]]:
    """One dict per ``ked run`` / ``ked merge`` into the file, oldest first (started_utc, campaign_name,
    campaign_config, n_scenes, provenance)."""
    path = Path(path)
    with _open(path) as f:
        _scenes(f, path)
        try:
            return _runs(f)
        except Exception as exc:  # damage
            raise StoreError(f"{path}: /{RUNS} unreadable ({type(exc).__name__}: {_short(exc)})") from exc


def read_scenes(path: str | Path, keys: Iterable[str] | None = None) -> list[SceneResult]:
    """Complete scenes of the file (all, or those whose key starts with one of ``keys``), in key order."""
    wanted = None if keys is None else tuple(keys)
    found = _map_complete(path, lambda view, key: view.read_scene(key),
                          lambda k: wanted is None or k.startswith(wanted))
    return [found[k] for k in sorted(found)]


def file_kind(path: str | Path) -> str:
    """"campaign" (results and study files), "atlas", or "" (not HDF5, or not a harness file)."""
    from compare import h5atlas as atlas_layout

    try:
        with h5py.File(Path(path), "r") as f:
            schema = h5layout.text(f.attrs.get("schema", ""))
    except Exception:  # not HDF5, or damaged: the readers say which
        return ""
    return {SCHEMA: "campaign", atlas_layout.SCHEMA: "atlas"}.get(schema, "")


_LAYOUT: dict[int, dict[str, type]] = {
    1: {"parameters": h5py.Group, "crank_angle": h5py.Dataset, "coupler_point": h5py.Dataset,
        "natural_frequencies": h5py.Dataset, "quasi_static": h5py.Group, "dynamic": h5py.Group,
        "dynamic_settings": h5py.Group, "metrics": h5py.Group, "run_stats": h5py.Group},
    2: {"parameters": h5py.Group, "crank_angle": h5py.Dataset, "coupler_point": h5py.Dataset,
        "natural_frequencies": h5py.Dataset, "solutions": h5py.Group, "metrics": h5py.Group,
        "run_stats": h5py.Group},
    3: {"parameters": h5py.Group, "crank_angle": h5py.Dataset, "coupler_point": h5py.Dataset,
        "natural_frequencies": h5py.Dataset, "solutions": h5py.Group, "metrics": h5py.Dataset,
        "run_stats": h5py.Group},
}
"""The members a scene group of an older schema version may have (anything else cannot be carried over)."""


def _foreign_members(g: h5py.Group, version: int) -> list[str]:
    """Members of a scene group that its version's layout does not have (or of another kind)."""
    layout = _LAYOUT[version]
    out = [name for name, obj in g.items() if not isinstance(obj, layout.get(name, ()))]
    for sub in (("quasi_static", "dynamic") if version == 1 else ()):
        if isinstance(g.get(sub), h5py.Group):
            out += [f"{sub}/{n}" for n, o in g[sub].items() if n not in h5layout.COMPONENTS
                    or not isinstance(o, h5py.Dataset)]
    if version == 2 and isinstance(g.get("solutions"), h5py.Group):
        for solver, sg in g["solutions"].items():
            if not isinstance(sg, h5py.Group):
                out.append(f"solutions/{solver}")
                continue
            out += [f"solutions/{solver}/{n}" for n, o in sg.items() if n not in h5layout.COMPONENTS
                    or not isinstance(o, h5py.Dataset)]
    return out


def array_bytes(path: str | Path) -> int:
    """Bytes of every array (dataset) the file holds, uncompressed: numbers as ``nbytes``, text as the
    length of its UTF-8 strings (not the padding of a fixed width)."""
    total = 0

    def visit(_name: str, obj: Any) -> None:
        nonlocal total
        if isinstance(obj, h5py.Dataset):
            if obj.dtype.kind in "OS":
                total += sum(len(x) if isinstance(x, bytes) else len(str(x).encode("utf-8"))
                             for x in np.ravel(obj[()]))
            elif obj.dtype.fields:
                data = obj[()]
                total += sum(sum(len(x) for x in np.ravel(data[n])) if data.dtype[n].kind in "OS" else data[n].nbytes
                             for n in data.dtype.names)
            else:
                total += obj.nbytes

    with _open(Path(path)) as f:
        f.visititems(visit)
    return total


def size_ratio(path: str | Path) -> float:
    """File size over :func:`array_bytes` [1]: what the layout costs beyond the numbers and text it holds
    (compression can make it less than 1)."""
    return os.path.getsize(path) / max(1, array_bytes(path))
