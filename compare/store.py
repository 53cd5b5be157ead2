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

import dataclasses
import io
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

from compare import h5layout
from compare.metrics import all_pairs
from compare.results import SceneResult, utc_now  # noqa: F401 (store.utc_now: its users' name)
from compare.solvers import Solution
from ked_quasi.linkage import direction_sign
from ked_quasi.units import rpm_to_rad_s

SCHEMA = "ked-harness/campaign"
SCHEMA_VERSION = 5
READABLE_VERSIONS = (1, 2, 3, 4, 5)
"""Schema versions this harness reads; it writes :data:`SCHEMA_VERSION` and upgrades an older file it
writes into (:func:`upgrade`: same scenes, same numbers, new layout, verified before it replaces the
old file).  Version 5 is version 4 plus the optional link stresses (``/scenes/<key>/stress/<solver>`` and
``stress_<link>`` metric rows): a version-4 file is a version-5 file without stresses, upgraded by its label
alone (a harness that reads only version 4 would take the stress rows for damage, hence the new number)."""
TABLE_LAYOUT = 4
"""The first schema version with the per-file tables (versions 1-3: one group per scene)."""
LIBVER = ("v110", "latest")
"""HDF5 format bounds of the files the harness creates (compact groups; readable by HDF5 >= 1.10)."""
SCENES = h5layout.SCENES
RUNS = h5layout.RUNS
TMP_MARK = ".tmp-"

class StoreError(ValueError):
    """A results file that does not follow the schema (or is damaged)."""


# --------------------------------------------------------------------------------------------------
# provenance


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


class CommitError(OSError):
    """A results file could not be written (permissions, full disk, immutable file, ...); the file is
    unchanged."""


def target(path: str | Path) -> Path:
    """The file a results path means: a symbolic link is followed (the link stays, its target is
    written), relative paths are made absolute."""
    return Path(path).resolve()


def check_writable(path: str | Path) -> None:
    """Refuse before any computation a results file that may not be replaced: an existing file without
    write permission (read-only means: leave it alone) or a directory where no file can be created."""
    path = target(path)
    if path.exists() and (not os.access(path, os.W_OK) or not path.stat().st_mode & 0o222):  # root: mode bits
        raise CommitError(f"{path}: the file is read-only (no write permission); refusing to change it; "
                          "make it writable or give another --out file")
    parent = next((p for p in (path.parent, *path.parent.parents) if p.exists()), None)
    if parent is not None and not os.access(parent, os.W_OK | os.X_OK):
        raise CommitError(f"{parent}: directory is not writable; give an --out file in a writable directory")
    if parent is not None:  # a commit writes a whole new copy beside the file
        st = os.statvfs(parent)
        free, need = st.f_bavail * st.f_frsize, (path.stat().st_size if path.exists() else 0) + COMMIT_HEADROOM
        if free < need:
            raise CommitError(f"{path}: cannot be written (No space left on device: {free // 1024} kB free, a "
                              f"commit needs about {need // 1024} kB); free space and rerun")


COMMIT_HEADROOM = 64 * 1024
"""Bytes a commit needs on top of a copy of the file (a run record and a few scenes) [B]."""


@contextmanager
def transaction(path: str | Path, repack: bool = False) -> Iterator[h5py.File]:
    """Open a private copy of ``path`` for writing; on success atomically replace ``path`` by it (its
    permissions kept; a symbolic link's target is replaced, the link stays).

    The copy is built in memory (HDF5 never writes to the disk here: it can crash on a disk that fills
    while it flushes) and written to a temporary file beside ``path`` by Python, fsynced and renamed.
    On any exception (or kill) the results file is untouched and the temporary file removed (or left as
    a stale temp file that nothing reads).  Failures of the file system (full disk, permissions, an
    immutable file) raise :class:`CommitError`.  ``repack``: the copy is rewritten compactly (HDF5 does
    not give back the space of deleted objects; the campaign tables are rewritten by every commit), as
    is any copy whose free space grew large.
    """
    path = target(path)
    tmp = _tmp_beside(path)
    try:
        buf = _memory_copy(path)
        f = _open_memory(buf, new=not path.exists())
        try:
            yield f
        except BaseException:
            _close_quietly(f)
            raise
        try:
            f.flush()
            fragmented = _fragmented(f)
            f.close()
            image = _repacked(buf.getvalue()) if repack or fragmented else buf.getvalue()
        except Exception as exc:  # a damaged file shows when HDF5 rewrites its metadata, as any error
            _close_quietly(f)
            raise CommitError(f"{path}: cannot be written ({type(exc).__name__}: {_short(exc)}); is the file "
                              f"damaged (`ked inspect {path} --verify`)?") from exc
        _write_image(image, tmp, path)
        _install(tmp, path)
    finally:
        _discard(tmp)


REPACK_SHARE = 0.25
"""A commit rewrites the file compactly when more than this share of it (and more than 64 kB) is free
space left by replaced tables and scenes."""


def _fragmented(f: h5py.File) -> bool:
    try:
        free, size = f.id.get_freespace(), f.id.get_filesize()
    except (OSError, RuntimeError, AttributeError):
        return False
    return free > max(64 * 1024, REPACK_SHARE * size)


def _memory_copy(path: Path) -> io.BytesIO:
    """The bytes of ``path`` (empty for a new file) in memory."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        return io.BytesIO(path.read_bytes() if path.exists() else b"")
    except OSError as exc:
        raise CommitError(f"{path}: cannot be written ({exc.strerror or _short(exc)})") from exc


def _open_memory(buf: io.BytesIO, new: bool) -> h5py.File:
    if new:
        return h5py.File(buf, "w", libver=LIBVER, fs_strategy="fsm", fs_persist=True)
    return h5py.File(buf, "r+", libver=LIBVER)


def _repacked(image: bytes) -> bytes:
    """An HDF5 file image rewritten without free space: every object copied into a new file."""
    out = io.BytesIO()
    with h5py.File(io.BytesIO(image), "r+") as old, _open_memory(out, new=True) as new:
        ours = schema_version(old) is not None
        if ours:  # a campaign file: a copy would leave its scales' references dangling; attached anew below
            h5layout.detach_dimensions(old)
        for k, v in old.attrs.items():
            new.attrs[k] = v
        for name in old:
            old.copy(old[name], new, name)
        if ours:
            h5layout.attach_dimensions(new)
    return out.getvalue()


def _write_image(image: bytes, tmp: Path, path: Path) -> None:
    """The finished file image written to ``tmp`` (``path``'s permissions), synced; a full disk or any
    other failure is a :class:`CommitError` and ``tmp`` is removed."""
    try:
        with open(tmp, "wb") as fh:
            fh.write(image)
            fh.flush()
            os.fsync(fh.fileno())
        if path.exists():
            shutil.copymode(path, tmp)
    except OSError as exc:
        _discard(tmp)
        raise CommitError(f"{path}: cannot be written ({exc.strerror or _short(exc)}; is the disk full?)") from exc


def _repack(path: Path) -> None:
    """Rewrite the file ``path`` compactly (in memory, then written beside it and renamed onto it)."""
    fresh = path.with_name(path.name + ".repack")
    try:
        _write_image(_repacked(path.read_bytes()), fresh, path)
        os.replace(fresh, path)
    finally:
        _discard(fresh)


def _tmp_beside(path: Path) -> Path:
    """A fresh private name beside ``path`` for a copy to be renamed onto it (see :func:`stale_temps`)."""
    return path.with_name(f"{path.name}{TMP_MARK}{os.getpid()}-{uuid.uuid4().hex[:8]}")


def _install(tmp: Path, path: Path, copy_mode: bool = False) -> None:
    """Atomically rename the finished file ``tmp`` onto ``path`` (with ``copy_mode``: ``path``'s
    permissions first), synced to disk; a failure is a :class:`CommitError` and ``path`` is unchanged."""
    try:
        if copy_mode:
            shutil.copymode(path, tmp)
        _fsync_path(tmp)
        os.replace(tmp, path)
    except OSError as exc:
        raise CommitError(f"{path}: cannot be replaced ({exc.strerror or _short(exc)})") from exc
    _fsync_path(path.parent, directory=True)


def _discard(tmp: Path) -> None:
    """Remove a temporary copy that was not renamed into place (quietly: a leftover is only stale)."""
    if tmp.exists():
        try:
            tmp.unlink()
        except OSError:
            pass


@contextmanager
def _hdf5_errors(path: Path) -> Iterator[None]:
    """Inside a transaction of the store's own: HDF5's errors (a damaged file shows only when its
    metadata is rewritten; h5py raises OSError, KeyError, ValueError or RuntimeError) become a
    :class:`CommitError` naming the file, so that callers save what they computed elsewhere."""
    try:
        yield
    except (CommitError, LockedError):
        raise
    except Exception as exc:
        raise CommitError(f"{path}: cannot be written ({type(exc).__name__}: {_short(exc)}); is the disk full, "
                          f"or the file damaged (`ked inspect {path} --verify`)?") from exc


def _close_quietly(f: h5py.File) -> None:
    try:
        f.close()
    except (OSError, RuntimeError):
        pass


class LockedError(RuntimeError):
    """Another process is writing the same results file."""


@contextmanager
def writer_lock(path: str | Path, wait_s: float = 0.0) -> Iterator[None]:
    """Exclusive lock on ``<path>.lock`` for one writer (campaign or merge) at a time; released by the
    kernel if the process dies.  Waits up to ``wait_s`` [s] for another writer to finish, then raises
    :class:`LockedError`."""
    import fcntl
    import time

    path = target(path)
    lock = path.with_name(path.name + ".lock")
    deadline = time.monotonic() + max(0.0, wait_s)
    while True:
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            fd = os.open(lock, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as exc:
            raise CommitError(f"{lock}: cannot create the writer lock ({exc.strerror}); "
                              "give an --out file in a writable directory") from exc
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            os.close(fd)
            if time.monotonic() >= deadline:
                raise LockedError(f"{path} is being written by another process (lock {lock})") from exc
            time.sleep(0.05)
            continue
        if _same_file(fd, lock):
            break
        os.close(fd)  # the previous holder removed the lock file after we opened it: lock the new one
    if not _claim(fd):
        os.close(fd)
        raise CommitError(f"{lock}: a file the harness did not make is in the way of its writer lock; move or "
                          "rename it (the harness never writes into or deletes files it did not create; an empty "
                          "one left by an interrupted run may be deleted)")
    try:
        yield
    finally:
        try:
            lock.unlink()
        except OSError:
            pass
        os.close(fd)


LOCK_MARK = b"ked-harness writer lock\n"
"""What every writer lock file holds (then the holder's process id): a file without it is not the harness's."""


def _claim(fd: int) -> bool:
    """Under the lock: True when the lock file is the harness's (empty because this process just created
    it, or marked by an earlier holder), now marked with this process; False for someone else's file."""
    st = os.fstat(fd)
    head = os.pread(fd, len(LOCK_MARK), 0)
    if head != LOCK_MARK and not (st.st_size == 0 and _recent(st.st_mtime_ns)):
        return False
    try:
        os.ftruncate(fd, 0)
        os.pwrite(fd, LOCK_MARK + f"{os.getpid()}\n".encode(), 0)
    except OSError:  # a full disk: the lock holds unmarked (the commit reports the disk, naming the file)
        pass
    return True


def _recent(mtime_ns: int, within_s: float = 60.0) -> bool:
    """Whether a file modified at ``mtime_ns`` was made in the last ``within_s`` seconds (a lock file this
    or another harness process created just now and has not marked yet)."""
    import time

    return abs(time.time_ns() - mtime_ns) <= within_s * 1e9


def _same_file(fd: int, path: Path) -> bool:
    try:
        a, b = os.fstat(fd), os.stat(path)
    except OSError:
        return False
    return (a.st_dev, a.st_ino) == (b.st_dev, b.st_ino)


def is_locked(path: str | Path) -> bool:
    """Whether a live process holds the writer lock of ``path`` (without taking it)."""
    import fcntl

    lock = target(path).with_name(target(path).name + ".lock")
    try:
        fd = os.open(lock, os.O_RDONLY)
    except OSError:
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
    except OSError:
        return True
    finally:
        os.close(fd)
    return False


def stale_temp_files(path: str | Path) -> list[Path]:
    """Temporary files left next to ``path`` by killed writers."""
    path = target(path)
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
# whose file is it


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


def _short(exc: BaseException) -> str:
    return str(exc).split("\n")[0][:200]


# --------------------------------------------------------------------------------------------------
# writing


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


# --------------------------------------------------------------------------------------------------
# reading


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
        return h5layout.read_scene(self.scenes[key], self.version)

    def metric_rows(self, key: str) -> h5layout.MetricRows:
        return h5layout.stored_metric_rows(self.scenes[key], self.version)


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


# --------------------------------------------------------------------------------------------------
# verification


_FILE_ATTRS = ("schema", "schema_version", "created_utc", "modified_utc", "harness_version", "exudyn_version",
               "numpy_version", "campaign_config", "campaign_name")


def verify(path: str | Path) -> list[str]:
    """Integrity and schema check; returns a list of problems (empty = valid).  A campaign file's
    scenes are checked one by one (:func:`verify_scenes`); an atlas file by its own checks
    (:func:`compare.atlas.layout.verify`)."""
    kind = file_kind(path)
    if kind == "atlas":
        from compare.atlas import layout as atlas_layout

        return atlas_layout.verify(Path(path))
    problems, scenes = verify_scenes(path, trial_write=True)
    return problems + [f"/{SCENES}/{key}: {p}" for key, ps in scenes.items() for p in ps]


def file_kind(path: str | Path) -> str:
    """"campaign" (results and study files), "atlas", or "" (not HDF5, or not a harness file)."""
    from compare.atlas import layout as atlas_layout

    try:
        with h5py.File(Path(path), "r") as f:
            schema = h5layout.text(f.attrs.get("schema", ""))
    except Exception:  # not HDF5, or damaged: the readers say which
        return ""
    return {SCHEMA: "campaign", atlas_layout.SCHEMA: "atlas"}.get(schema, "")


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
                scenes[name] = h5layout.verify_scene(name, g, version)
                run = g.attrs.get("run") if isinstance(g, h5py.Group) and h5layout.complete(g) else None
                if run is not None and (runs is None or int(run) not in runs):
                    scenes[name].append(f"run {run} is not in /{RUNS}")
            except Exception as exc:
                scenes[name] = [f"unreadable ({type(exc).__name__}: {_short(exc)}) in {path}"]
    return problems, scenes


def _verify_v4(f: h5py.File, path: Path, trial_write: bool = False) -> tuple[list[str], dict[str, list[str]]]:
    try:
        problems = h5layout.verify_tables(f)
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
            scenes[name] = view.verify_scene(name) + _verify_run_of(view, name, runs)
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
            _commit(copy, [fresh], _record_run(copy, "", "verify", 1))
    except Exception as exc:  # whatever a writer would meet
        return [f"{path}: a write into this file fails ({type(exc).__name__}: {_short(exc)}): `ked run` and "
                "`ked merge` cannot add scenes to it"]
    return []


# --------------------------------------------------------------------------------------------------
# upgrade of older layouts: read everything, write a new file, verify every number, then replace

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
            out[key] = (h5layout.read_scene(g, version), int(g.attrs["run"]), h5layout.stored_metric_rows(g, version))
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
    h5layout.attach_dimensions(new)


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
    old_rows, new_rows = h5layout.stored_metric_rows(g, version), view.metric_rows(key)
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


# --------------------------------------------------------------------------------------------------
# rescue and merge: nothing computed is lost


def rescue(results: list[SceneResult], out: str | Path, config_text: str, campaign_name: str) -> Path:
    """Write ``results`` (scenes computed but not committed to ``out``) into a new results file beside
    ``out``, else in the temporary directory, else in the home directory; returns its path.  Raises
    CommitError if no location can take it."""
    import tempfile
    import time

    out = target(out)
    stamp = time.strftime("%Y%m%dT%H%M%S")
    name = f"{out.stem}.rescue-{stamp}-{os.getpid()}.h5"
    reasons = []
    for directory in (out.parent, Path(tempfile.gettempdir()), Path.home() / ".cache" / "ked-harness"):
        if directory != Path.home() / ".cache" / "ked-harness" and not directory.is_dir():
            reasons.append(f"{directory}: no such directory (not made again)")
            continue  # a directory deleted during the run is not re-created
        path = directory / name
        try:
            commit(path, results, record_run(path, config_text, campaign_name, len(results)))
            return path
        except (CommitError, OSError) as exc:
            reasons.append(str(exc))
            try:
                path.unlink()
            except OSError:
                pass
    raise CommitError("the computed scenes could not be saved anywhere: " + "; ".join(reasons))


MERGE_WAIT_S = 60.0
"""How long ``ked merge`` waits for another writer of DEST (a merge or a campaign) to finish [s]."""


@dataclasses.dataclass(frozen=True)
class MergeReport:
    """What ``ked merge`` did: ``added`` scenes carried into DEST, ``kept`` offered scenes DEST already
    held, ``refused``: key -> why a scene of SRC was not carried (it fails the checks of
    ``ked inspect --verify``)."""

    added: int
    kept: int
    refused: dict[str, str]


def merge(src: str | Path, dest: str | Path, wait_s: float = MERGE_WAIT_S) -> MergeReport:
    """Add the scenes of results file ``src`` that ``dest`` lacks (or holds only as failed) to ``dest``
    (created if missing).  Both files must be harness files; ``src`` is not changed.  Every scene of
    ``src`` is checked as ``ked inspect --verify`` checks it (:func:`verify_scenes`); only those that
    verify are carried, the others are returned as refused.  The new ``dest`` is verified before it
    replaces the old one: a merge that would add a problem to ``dest`` raises :class:`StoreError` and
    changes nothing.  Holds ``dest``'s writer lock (waiting up to ``wait_s`` [s] for another writer)
    from reading ``dest`` to its atomic replacement, and writes the run record and the scenes in one
    transaction."""
    check_ours(src)
    check_ours(dest)
    check_writable(dest)
    offered = read_scenes(src)
    damage, checks = verify_scenes(src)
    if damage:  # the file's own tables or records are damaged: none of its scenes is carried
        more = f" and {len(damage) - 1} more problem(s)" if len(damage) > 1 else ""
        raise StoreError(f"{target(src)}: fails `ked inspect --verify` ({damage[0]}{more}); refusing to merge "
                         "from it; nothing was merged")
    refused = {k: p[0] + (f" (and {len(p) - 1} more problem(s))" if len(p) > 1 else "")
               for k, p in sorted(checks.items()) if p}
    carried = [r for r in offered if r.key not in refused]
    config = str(file_info(src).get("campaign_config", ""))
    with writer_lock(dest, wait_s=wait_s):
        check_ours(dest)
        have = stored_status(dest)
        new = [r for r in carried if have.get(r.key) is None or (have.get(r.key) == "failed" and r.ok)]
        if new or not target(dest).exists():
            before = set(verify(dest)) if target(dest).exists() else set()
            upgrade(dest)
            with transaction(dest, repack=True) as f, _hdf5_errors(target(dest)):
                run = _record_run(f, config, f"merge of {target(src).name}", len(new))
                _commit(f, new, run)
                f.flush()
                added = [p for p in _verify_image(f, target(dest)) if p not in before]
                if added:
                    raise StoreError(f"{target(dest)}: refusing to merge {target(src).name}: the result would not "
                                     f"verify ({added[0]}); {target(dest)} is unchanged")
    return MergeReport(len(new), len(carried) - len(new), refused)


def _verify_image(f: h5py.File, path: Path) -> list[str]:
    """:func:`verify` of the open in-memory file ``f`` (written to a private file beside ``path``)."""
    tmp = _tmp_beside(path)
    try:
        tmp.write_bytes(f.id.get_file_image())
        return [p.replace(str(tmp), str(path)) for p in verify(tmp)]
    finally:
        _discard(tmp)
