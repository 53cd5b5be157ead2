"""The atomic file layer of the harness's HDF5 files (campaign, study and atlas files alike): a results file is
never modified in place.  A :func:`transaction` builds the new file in memory from a copy, writes it to a temporary
file beside the old one, fsyncs it and renames it onto the old one (``os.replace``), then fsyncs the directory: a
SIGKILL at any moment leaves the old or the new complete file (plus, at worst, a stale ``*.h5.tmp-*`` file that
nothing reads and the next run removes).  One writer at a time (:func:`writer_lock`).  Knows nothing of what the
files hold.
"""

from __future__ import annotations

import io
import os
import shutil
import uuid
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import h5py

from compare import h5dims, h5layout

LIBVER = ("v110", "latest")
"""HDF5 format bounds of the files the harness creates (compact groups; readable by HDF5 >= 1.10)."""


TMP_MARK = ".tmp-"


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
        ours = h5layout.is_campaign(old)
        if ours:  # a campaign file: a copy would leave its scales' references dangling; attached anew below
            h5dims.detach_dimensions(old)
        for k, v in old.attrs.items():
            new.attrs[k] = v
        for name in old:
            old.copy(old[name], new, name)
        if ours:
            h5dims.attach_dimensions(new)
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


def _short(exc: BaseException) -> str:
    return str(exc).split("\n")[0][:200]
