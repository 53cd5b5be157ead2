"""Upgrade of a results file of an older schema version: read everything, write the new layout beside it, compare
every stored number, then replace it atomically (versions 1-3); a version-4 file is relabelled only.
"""

from __future__ import annotations

import io
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from compare import h5dims, h5layout, h5legacy
from compare.h5file import (
    CommitError,
    _discard,
    _hdf5_errors,
    _install,
    _open_memory,
    _short,
    _tmp_beside,
    _write_image,
    target,
    transaction,
)
from compare.reader import (
    READABLE_VERSIONS,
    RUNS,
    SCENES,
    SCHEMA_VERSION,
    TABLE_LAYOUT,
    StoreError,
    _foreign_members,
    _open,
    layout_contradiction,
    schema_version,
)
from compare.results import SceneResult


def upgrade(path: str | Path) -> bool:
    """Rewrite a results file of an older schema version in the current layout; True if it did.

    Everything is read first; a scene group holding anything its version's layout does not have (say
    a file whose ``schema_version`` understates its layout) or that cannot be read is refused with a
    :class:`StoreError` naming it, and nothing changes.  The new file is written beside the old one,
    every stored number of the old file (histories, attributes, stored metrics, runs, study tables) is
    compared with the new file, and only then is the new file renamed onto the old one (atomically,
    as commits are).  Call with the writer lock held (or no other writer)."""
    path = target(path)
    if not path.exists():
        return False
    with _open(path) as old:
        version = schema_version(old)
        if version is None or version == SCHEMA_VERSION:
            return False
        if version not in READABLE_VERSIONS:
            raise StoreError(f"{path}: schema version {version} is not supported by this harness "
                             f"(it reads {READABLE_VERSIONS}); use the harness that wrote it or another file")
        if version >= TABLE_LAYOUT:
            contradiction = layout_contradiction(old, version)
        else:
            scenes = _read_for_upgrade(old, version, path)
    if version >= TABLE_LAYOUT:
        return _relabel(path, version, contradiction)
    tmp = _tmp_beside(path)
    try:
        try:
            buf = io.BytesIO()  # built in memory: HDF5 never writes to a disk that may fill
            with _open(path) as old, _open_memory(buf, new=True) as new:
                _write_upgraded(old, new, scenes)
            image = buf.getvalue()
            with _open(path) as old, h5py.File(io.BytesIO(image), "r") as new:
                problems = _compare_upgraded(old, new, version)
        except (OSError, RuntimeError) as exc:
            raise CommitError(f"{path}: cannot be upgraded to schema version {SCHEMA_VERSION} "
                              f"({_short(exc)}; is the disk full or the file damaged?); the file is unchanged") from exc
        except Exception as exc:  # damage the readers did not notice
            raise StoreError(f"{path}: cannot be upgraded to schema version {SCHEMA_VERSION} "
                             f"({type(exc).__name__}: {_short(exc)}); the file is unchanged; "
                             "check it with `ked inspect FILE --verify`") from exc
        if problems:
            raise StoreError(f"{path}: upgrade to schema version {SCHEMA_VERSION} would not keep every stored "
                             f"number ({problems[0]}{f' and {len(problems) - 1} more' if len(problems) > 1 else ''}"
                             "); the file is unchanged")
        _write_image(image, tmp, path)
        _install(tmp, path)
    finally:
        _discard(tmp)
    return True


def _relabel(path: Path, version: int, contradiction: str) -> bool:
    """Upgrade a file of the table layout whose layout is today's (nothing to rewrite): its label only, in one
    atomic commit; refused, unchanged, where its layout contradicts its label."""
    if contradiction:
        raise StoreError(f"{path}: refusing to upgrade schema version {version} to {SCHEMA_VERSION}: "
                         f"{contradiction}; the file is unchanged (check it with `ked inspect FILE --verify`)")
    with transaction(path) as f, _hdf5_errors(path):
        f.attrs["schema_version"] = SCHEMA_VERSION
    return True


def _read_for_upgrade(old: h5py.File, version: int, path: Path) -> dict[str, tuple[SceneResult, int, Any]]:
    """key -> (scene, run, stored metric rows) of every complete scene; StoreError for what the
    upgrade cannot carry over."""
    problems, out = [], {}
    group = old.get(SCENES)
    for key, g in (group.items() if isinstance(group, h5py.Group) else ()):
        if not h5layout.complete(g):
            problems.append(f"/{SCENES}/{key} is incomplete")
            continue
        foreign = _foreign_members(g, version)
        if foreign:
            problems.append(f"/{SCENES}/{key} holds {', '.join(foreign[:4])}, which a version-{version} file "
                            "cannot have")
            continue
        try:
            out[key] = (h5legacy.read_scene(g, version), int(g.attrs["run"]), h5legacy.stored_metric_rows(g, version))
        except (KeyError, ValueError, TypeError, OSError) as exc:
            problems.append(f"/{SCENES}/{key} is unreadable ({_short(exc)})")
    if problems:
        more = f" and {len(problems) - 1} more" if len(problems) > 1 else ""
        raise StoreError(f"{path}: refusing to upgrade schema version {version} to {SCHEMA_VERSION}: {problems[0]}"
                         f"{more}; the file is unchanged (check it with `ked inspect FILE --verify`)")
    return out


_V1_MOVED = {"quasi_static_wall_s": ("quasi_static", "wall_s"), "dynamic_wall_s": ("dynamic", "wall_s"),
             "steps": ("dynamic", "steps"), "newton_iterations": ("dynamic", "newton_iterations"),
             "cycles": ("dynamic", "cycles"), "converged": ("dynamic", "converged"),
             "dynamic_message": ("dynamic", "dynamic_message")}
"""Version 1 kept these solver statistics in ``run_stats/``; now in a solution's ``stats_json``."""


_ARRAY_ATTRS_DROPPED = ("description",)
"""Attributes of older layouts' arrays that were generated text (the schema states them) and are not
carried over."""


def _attrs(obj: Any, drop: tuple[str, ...] = ()) -> dict[str, Any]:
    return {k: v for k, v in obj.attrs.items() if k not in drop}


def _write_upgraded(old: h5py.File, new: h5py.File, scenes: dict[str, tuple[SceneResult, int, Any]]) -> None:
    """The new file: root attributes and every group but the scenes and runs copied as they are, the runs
    and scenes in the current layout (every attribute an older layout stored carried into the tables
    verbatim: the content key is hashed from the parameters' JSON)."""
    for k, v in old.attrs.items():
        new.attrs[k] = v
    new.attrs["schema_version"] = SCHEMA_VERSION
    for name in old:
        if name not in (SCENES, RUNS):
            old.copy(old[name], new, name)
    if RUNS in old:
        h5layout.write_runs(new, [{"run": int(n), **_attrs(g)} for n, g in sorted(old[RUNS].items())])
    rows: dict[str, list[dict[str, Any]]] = {"scene": [], "solution": [], "metric": []}
    if scenes:
        sg = new.create_group(SCENES)
    for key in sorted(scenes):
        r, run, metric_rows = scenes[key]
        g = old[SCENES][key]
        version = schema_version(old)
        h5layout.write_arrays(sg, r)
        stats = _attrs(g["run_stats"], tuple(_V1_MOVED) if version == 1 else ())
        rows["scene"].append({**h5layout.scene_row(r, run, parameters=_attrs(g["parameters"]),
                                                   attrs=_attrs(g, ("complete",))), **stats, "complete": True})
        for name, s in r.solutions.items():
            carried = _attrs(g["solutions"][name], ("components", "units")) if version >= 2 else {}
            rows["solution"].append(h5layout.solution_row(key, s, carried))
        computed = h5layout.metric_rows(r.metrics)
        for k, row in metric_rows.items():
            computed[k] = {**computed.get(k, {}), **row}
        rows["metric"] += h5layout.metric_table_rows(key, computed)
    if not len(new.get(SCENES, ())) and SCENES in new:
        del new[SCENES]
    h5layout.write_tables(new, rows["scene"], rows["solution"], rows["metric"])
    h5dims.attach_dimensions(new)


def _same(a: Any, b: Any) -> bool:
    if isinstance(a, (bytes, str)) or isinstance(b, (bytes, str)):
        return h5layout.text(a) == h5layout.text(b)
    a, b = np.asarray(a), np.asarray(b)
    if a.dtype.kind in "fc" or b.dtype.kind in "fc":
        return a.shape == b.shape and bool(np.array_equal(a, b, equal_nan=True))
    if a.dtype.kind == "O" or b.dtype.kind == "O":
        return a.shape == b.shape and all(_same(x, y) for x, y in zip(a.ravel(), b.ravel()))
    return a.shape == b.shape and bool(np.array_equal(a, b))


def _compare_tree(a: Any, b: Any, where: str) -> list[str]:
    """Every attribute and dataset of ``a`` equal in ``b`` (recursively)."""
    if b is None:
        return [f"{where} missing"]
    p = [f"{where} attribute {k}" for k, v in a.attrs.items() if k not in b.attrs or not _same(v, b.attrs[k])]
    if isinstance(a, h5py.Dataset):
        return p + ([] if isinstance(b, h5py.Dataset) and _same(a[()], b[()]) else [f"{where} values"])
    for name, obj in a.items():
        p += _compare_tree(obj, b.get(name), f"{where}/{name}")
    return p


def _compare_attrs(old: dict[str, Any], new: dict[str, Any], where: str) -> list[str]:
    return [f"{where} {k}" for k, v in old.items() if k not in new or not _same(v, new[k])]


def _compare_upgraded(old: h5py.File, new: h5py.File, version: int) -> list[str]:
    """Where the new file does not hold a number (or string) the old one stored."""
    p = [f"/ attribute {k}" for k, v in old.attrs.items() if k != "schema_version" and not _same(v, new.attrs.get(k))]
    for name in old:
        if name not in (SCENES, RUNS):
            p += _compare_tree(old[name], new.get(name), f"/{name}")
    runs = {int(r["run"]): r for r in h5layout.table_rows(new, RUNS)}
    for n, g in (old[RUNS].items() if RUNS in old else ()):
        p += _compare_attrs(_attrs(g), runs.get(int(n), {}), f"/{RUNS}/{n} attribute")
    view = h5layout.TableFile(new)
    for key, g in (old[SCENES].items() if SCENES in old else ()):
        if key not in view.index or not view.complete(key):
            p.append(f"/{SCENES}/{key} missing")
            continue
        p += [f"/{SCENES}/{key}: {x}" for x in _compare_scene(g, view, key, version)]
    return p


def _compare_scene(g: h5py.Group, view: Any, key: str, version: int) -> list[str]:
    row, arrays = view.row(key), view.arrays(key)
    p = _compare_attrs(_attrs(g, ("complete",)), row, "attribute")
    p += _compare_attrs(_attrs(g["parameters"]), row, "parameters attribute")
    for name in ("crank_angle", "coupler_point", "natural_frequencies"):
        if name in g:
            if name not in arrays or not _same(g[name][()], arrays[name][()]):
                p.append(f"{name} values")
            else:
                p += _compare_attrs(_attrs(g[name], _ARRAY_ATTRS_DROPPED), _attrs(arrays[name]), f"{name} attribute")
    sols = {h5layout.text(r["solver"]): r for r in view.solution_rows(key)}
    new_sols = arrays.get(h5layout.SOLUTIONS) if arrays else None
    old_sols = (g["solutions"].items() if version >= 2 else
                [(n, g[n]) for n in ("quasi_static", "dynamic") if n in g])
    for solver, sg in old_sols:
        ds = new_sols.get(solver) if new_sols is not None else None
        if version >= 2:
            p += _compare_attrs(_attrs(sg, ("components", "units")), sols.get(solver, {}),
                                f"solutions/{solver} attribute")
        p += _compare_histories(sg, ds, f"solutions/{solver}")
    if version == 1:
        p += _compare_v1(g, sols, row)
    else:
        p += _compare_attrs(_attrs(g["run_stats"]), row, "run_stats attribute")
    old_rows, new_rows = h5legacy.stored_metric_rows(g, version), view.metric_rows(key)
    for k, r in old_rows.items():
        new = new_rows.get(k, {})
        p += [f"metrics {'/'.join(k)} {n}" for n, v in r.items() if not _same(v, new.get(n))]
    return p


def _compare_histories(old: Any, new: Any, where: str) -> list[str]:
    """A solution's histories: a version-3 (n, c) dataset or a version-1/2 group of one dataset per
    component, against the new (n, c) dataset (same columns and units)."""
    if isinstance(old, h5py.Dataset):
        comps = [c for c in h5layout.text(old.attrs.get("components", "")).split(",") if c]
        units = h5layout.text(old.attrs.get("units", "")).split(",")
        cols = {c: (old[()][:, i], units[i] if i < len(units) else "") for i, c in enumerate(comps)}
    else:
        cols = {c: (ds[()], h5layout.text(ds.attrs.get("units", ""))) for c, ds in old.items()}
    if not cols:
        return []
    if not isinstance(new, h5py.Dataset):
        return [f"{where} missing"]
    comps = h5layout.text(new.attrs.get("components", "")).split(",")
    units = h5layout.text(new.attrs.get("units", "")).split(",")
    data = new[()]
    p = []
    for c, (values, unit) in cols.items():
        if c not in comps:
            p.append(f"{where}/{c} missing")
            continue
        i = comps.index(c)
        if not _same(values, data[:, i]):
            p.append(f"{where}/{c} values")
        if unit and not _same(unit, units[i]):
            p.append(f"{where}/{c} units")
    return p


def _compare_v1(g: h5py.Group, sols: dict[str, dict[str, Any]], row: dict[str, Any]) -> list[str]:
    """Version 1: statistics in run_stats/ (some now in a solution's stats_json), Exudyn settings in
    dynamic_settings/ (now the solution's settings_json)."""
    import json

    def stats(solver: str) -> dict[str, Any]:
        return json.loads(h5layout.text(sols[solver]["stats_json"])) if solver in sols else {}

    p = []
    for k, v in g["run_stats"].attrs.items():
        if k in _V1_MOVED:
            solver, name = _V1_MOVED[k]
            d = stats(solver)
            ok = not d or (name in d and _same(v, d[name]))
        else:
            ok = k in row and _same(v, row[k])
        if not ok:
            p.append(f"run_stats attribute {k}")
    if "dynamic_settings" in g and "dynamic" in sols:
        if json.loads(h5layout.text(g["dynamic_settings"].attrs["json"])) != json.loads(
                h5layout.text(sols["dynamic"]["settings_json"])):
            p.append("dynamic_settings")
    return p
