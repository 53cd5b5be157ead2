"""``ked inspect --verify`` of a campaign file: the file's attributes and tables, every scene as a reader sees it
(:func:`compare.h5checks.verify_scene`), and a trial write into an in-memory copy (damage only a writer meets).
"""

from __future__ import annotations

import dataclasses
import io
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from compare import h5checks, h5layout
from compare.h5file import _open_memory, _short
from compare.reader import (
    READABLE_VERSIONS,
    RUNS,
    SCENES,
    SCHEMA,
    SCHEMA_VERSION,
    TABLE_LAYOUT,
    file_kind,
    layout_contradiction,
    schema_version,
)
from compare.results import SceneResult
from compare.writer import _commit, _record_run

_FILE_ATTRS = ("schema", "schema_version", "created_utc", "modified_utc", "harness_version", "exudyn_version",
               "numpy_version", "campaign_config", "campaign_name")


def verify(path: str | Path) -> list[str]:
    """Integrity and schema check; returns a list of problems (empty = valid).  A campaign file's
    scenes are checked one by one (:func:`verify_scenes`); an atlas file by its own checks
    (:func:`compare.h5atlas.verify`)."""
    kind = file_kind(path)
    if kind == "atlas":
        from compare import h5atlas as atlas_layout

        return atlas_layout.verify(Path(path))
    problems, scenes = verify_scenes(path, trial_write=True)
    return problems + [f"/{SCENES}/{key}: {p}" for key, ps in scenes.items() for p in ps]


def verify_scenes(path: str | Path, trial_write: bool = False) -> tuple[list[str], dict[str, list[str]]]:
    """The checks of ``ked inspect --verify`` of a campaign file: (problems of the file, key -> problems
    of that scene; a key with an empty list verified).  ``ked merge`` carries only the scenes that
    verify.  ``trial_write``: also commit a probe scene into an in-memory copy (damage only a write hits;
    :func:`verify` does, the callers that want the scenes' problems only need not)."""
    path = Path(path)
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        return [f"{path}: cannot open as HDF5: {_short(exc)}"], {}
    with f:
        try:
            problems = [f"/: missing file attribute {a!r}" for a in _FILE_ATTRS if a not in f.attrs]
            version = schema_version(f)
        except Exception as exc:  # damage
            return [f"{path}: file attributes unreadable ({type(exc).__name__}: {_short(exc)})"], {}
        if version is None:
            return problems + [f"/: schema attribute is not {SCHEMA!r}: not a ked-harness results file"], {}
        if version not in READABLE_VERSIONS:
            return problems + [f"/: schema version {version} is not one of {READABLE_VERSIONS}"], {}
        contradiction = layout_contradiction(f, version)
        if contradiction:
            return problems + [f"{path}: {contradiction}"], {}
        if version >= 4:
            more, scenes = _verify_v4(f, path, trial_write)
            return problems + more, scenes
        try:
            if SCENES not in f:
                return problems + [f"/: missing group /{SCENES}"], {}
            names = list(f[SCENES])
        except Exception as exc:  # HDF5 reports damage as OSError, KeyError, ValueError or RuntimeError
            return problems + [f"{path}: /{SCENES} is unreadable ({type(exc).__name__}: {_short(exc)})"], {}
        runs = {int(n) for n in f[RUNS]} if isinstance(f.get(RUNS), h5py.Group) else None
        if runs is None:
            problems.append(f"/: missing group /{RUNS} (the record of the runs that wrote the scenes)")
        scenes: dict[str, list[str]] = {}
        for name in names:
            try:
                g = f[SCENES][name]
                scenes[name] = h5checks.verify_scene(name, g, version)
                run = g.attrs.get("run") if isinstance(g, h5py.Group) and h5layout.complete(g) else None
                if run is not None and (runs is None or int(run) not in runs):
                    scenes[name].append(f"run {run} is not in /{RUNS}")
            except Exception as exc:
                scenes[name] = [f"unreadable ({type(exc).__name__}: {_short(exc)}) in {path}"]
    return problems, scenes


def _verify_v4(f: h5py.File, path: Path, trial_write: bool = False) -> tuple[list[str], dict[str, list[str]]]:
    try:
        problems = h5checks.verify_tables(f)
        view = h5layout.TableFile(f)
        names = list(view.index)
        problems += [f"/{SCENES}/{g}: no row in /{h5layout.SCENE_TABLE}" for g in view.orphans()]
        runs = _run_numbers(f)
    except Exception as exc:  # HDF5 reports damage as OSError, KeyError, ValueError, RuntimeError
        return [f"{path}: the scene tables are unreadable ({type(exc).__name__}: {_short(exc)})"], {}
    if runs is None:
        problems.append(f"/: missing table /{RUNS} (the record of the runs that wrote the scenes)")
    scenes: dict[str, list[str]] = {}
    for name in names:
        try:
            scenes[name] = h5checks.verify_table_scene(view, name) + _verify_run_of(view, name, runs)
        except Exception as exc:
            scenes[name] = [f"unreadable ({type(exc).__name__}: {_short(exc)}) in {path}"]
    if trial_write and names and not problems and not any(scenes.values()):
        problems += _verify_writable(f, path, view.read_scene(names[0]))
    return problems, scenes


def _run_numbers(f: h5py.File) -> set[int] | None:
    """The run numbers of ``/runs`` (None: no such table)."""
    if RUNS not in f:
        return None
    return {int(r["run"]) for r in h5layout.table_rows(f, RUNS)}


def _verify_run_of(view: Any, key: str, runs: set[int] | None) -> list[str]:
    if not view.complete(key) or "run" not in view.row(key):
        return []
    run = view.row(key)["run"]
    if runs is None or int(run) not in runs:
        return [f"run {run} of /{h5layout.SCENE_TABLE} is not in /{RUNS}"]
    return []


def _verify_writable(f: h5py.File, path: Path, probe: SceneResult) -> list[str]:
    """A write into the file (a run record and a new scene, as `ked run` and `ked merge` do) tried on a
    copy in memory: a damage of the tables that only a writer trips over is a problem now."""
    from compare.scenes import SpeedSpec

    spec = dataclasses.replace(probe.spec, speed=SpeedSpec("rpm", float(np.nextafter(probe.rpm, np.inf))))
    fresh = dataclasses.replace(probe, spec=spec)
    try:
        buf = io.BytesIO(path.read_bytes())
        with _open_memory(buf, new=False) as copy:
            if schema_version(copy) == TABLE_LAYOUT:  # the writer upgrades it first: by its label alone
                copy.attrs["schema_version"] = SCHEMA_VERSION
            _commit(copy, [fresh], _record_run(copy, "", "verify", 1))
    except Exception as exc:  # whatever a writer would meet
        return [f"{path}: a write into this file fails ({type(exc).__name__}: {_short(exc)}): `ked run` and "
                "`ked merge` cannot add scenes to it"]
    return []
