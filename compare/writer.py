"""The writer of campaign results files: it owns the commit protocol (refuse a file that is not ours, upgrade an
older layout, record the run, write the scenes and their table rows with the ``complete`` mark last, in one atomic
:func:`compare.h5file.transaction`).  Only one process (the campaign's parent) writes.
"""

from __future__ import annotations

import dataclasses
import platform
import socket
import subprocess
from collections.abc import Iterable
from importlib import metadata
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from compare import h5layout
from compare.h5file import CommitError, _hdf5_errors, target, transaction
from compare.metrics import all_pairs
from compare.reader import RUNS, SCENES, SCHEMA, SCHEMA_VERSION, StoreError, check_ours, schema_version
from compare.results import SceneResult, utc_now
from compare.upgrade import upgrade
from ked_quasi.linkage import direction_sign
from ked_quasi.units import rpm_to_rad_s


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


def _require_current(f: h5py.File) -> None:
    if "schema_version" in f.attrs and schema_version(f) != SCHEMA_VERSION:
        raise StoreError(f"{f.filename}: schema version {schema_version(f)} must be upgraded "
                         "(compare.store.upgrade) before scenes are written into it")


def record_run(path: str | Path, config_text: str, campaign_name: str, n_scenes: int) -> int:
    """Create the file if needed (refusing a file that is not ours), set/refresh the file attributes,
    upgrade an older layout, and add a ``/runs/<n>`` record.  Returns the run number."""
    check_ours(path)
    upgrade(path)
    with transaction(path, repack=True) as f, _hdf5_errors(target(path)):
        return _record_run(f, config_text, campaign_name, n_scenes)


def _record_run(f: h5py.File, config_text: str, campaign_name: str, n_scenes: int) -> int:
    prov = provenance()
    now = utc_now()
    if "schema" not in f.attrs:
        f.attrs["schema"] = SCHEMA
        f.attrs["schema_version"] = SCHEMA_VERSION
        f.attrs["created_utc"] = now
    _require_current(f)
    for k, v in prov.items():
        f.attrs[k] = v
    f.attrs["modified_utc"] = now
    f.attrs["campaign_name"] = campaign_name
    f.attrs["campaign_config"] = config_text
    runs = h5layout.table_rows(f, RUNS)
    number = len(runs)
    runs.append({"run": number, "started_utc": now, "campaign_name": campaign_name, "campaign_config": config_text,
                 "n_scenes": int(n_scenes), **prov})
    h5layout.write_runs(f, runs)
    return number


def commit_first(path: str | Path, results: Iterable[SceneResult], config_text: str, campaign_name: str,
                 n_scenes: int) -> int:
    """:func:`record_run` and :func:`commit` in one atomic transaction: a run's record exists only together
    with its first scenes (a commit that fails leaves no run record behind).  Returns the run number."""
    try:
        check_ours(path)
        upgrade(path)
    except StoreError as exc:  # a commit that cannot happen: the caller saves the scenes elsewhere
        raise CommitError(str(exc)) from exc
    with transaction(path, repack=True) as f, _hdf5_errors(target(path)):
        run = _record_run(f, config_text, campaign_name, n_scenes)
        _commit(f, list(results), run)
    return run


def commit(path: str | Path, results: Iterable[SceneResult], run: int = -1) -> None:
    """Atomically add (or replace) the scene groups of ``results`` in the results file; a replaced
    scene keeps the stored solutions of solvers the new result did not run.  ``run``: the run record
    the scenes belong to (default: the file's last one, see :func:`record_run`)."""
    results = list(results)
    if not results:
        return
    if not target(path).exists():  # a later commit of a run: its file was there (its first commit made it)
        raise CommitError(f"{target(path)}: the results file is gone (deleted while the run wrote into it); not "
                          "made again without its run record")
    try:
        upgrade(path)
    except StoreError as exc:  # a commit that cannot happen: the caller saves the scenes elsewhere
        raise CommitError(str(exc)) from exc
    with transaction(path, repack=True) as f, _hdf5_errors(target(path)):
        _commit(f, results, run)


def _commit(f: h5py.File, results: list[SceneResult], run: int) -> None:
    _require_current(f)
    if run < 0:  # no run given: the scenes belong to the file's last run record
        run = max((int(r["run"]) for r in h5layout.table_rows(f, RUNS)), default=run)
    view = h5layout.TableFile(f)
    scenes = f.require_group(SCENES)
    new: dict[str, SceneResult] = {}
    for r in results:  # the last result of a key wins
        if r.key in view.index and view.complete(r.key):
            r = with_kept_solutions(r, view.read_scene(r.key))
        new[r.key] = r
    rows: dict[str, list[dict[str, Any]]] = {h5layout.SCENE_TABLE: [], h5layout.SOLUTION_TABLE: [],
                                             h5layout.METRIC_TABLE: []}
    for key, r in new.items():
        if key in scenes:
            del scenes[key]
        h5layout.write_arrays(scenes, r)
        rows[h5layout.SCENE_TABLE].append(h5layout.scene_row(r, run))
        rows[h5layout.SOLUTION_TABLE] += [h5layout.solution_row(key, s) for s in r.solutions.values()]
        rows[h5layout.METRIC_TABLE] += h5layout.metric_table_rows(key, h5layout.metric_rows(r.metrics))
    if not len(scenes):
        del f[SCENES]  # no empty groups
    h5layout.replace_scenes(f, rows)
    f.attrs["modified_utc"] = utc_now()


def with_kept_solutions(new: SceneResult, old: SceneResult) -> SceneResult:
    """``new`` plus every solution of ``old`` whose solver ``new`` did not run (a rerun with another
    solver list must not drop what is stored), with the metrics of every pair recomputed over all of
    them (one definition: :func:`compare.metrics.all_pairs`)."""
    kept = {n: s for n, s in old.solutions.items() if n not in new.solutions}
    if not kept:
        return new
    solutions = {**new.solutions, **kept}
    metrics = new.metrics
    ok = {n: s for n, s in solutions.items() if s.ok and s.deflection}
    theta = new.crank_angle if new.crank_angle is not None else old.crank_angle
    if theta is not None and ok:
        try:
            metrics = all_pairs(theta, {n: s.histories for n, s in ok.items()},
                                {n: s.fidelity for n, s in ok.items()}, omega=rpm_to_rad_s(new.rpm),
                                omega1_min=new.omega1_min, tolerance=new.spec.tolerance,
                                direction_sign=direction_sign(new.spec.direction))
        except ValueError:
            pass
    return dataclasses.replace(new, solutions=solutions, metrics=metrics)
