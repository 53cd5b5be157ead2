"""The linear model's run-time services: a recall of recent systems and Floquet results, single-threaded BLAS
and a glibc allocator that keeps freed memory, shared by every linkage kind's solve."""

from __future__ import annotations

import contextlib
import sys
import threading
from collections.abc import Callable
from typing import TypeVar

_CONTROLLERS: dict[bool, object] = {}

RECALLED = 4
"""Linear systems (with their sampled coefficients) and Floquet results kept for a repeated solve of the
same scene with other periodic-solve settings (``ked check`` solving again with more harmonics): the
system and its multipliers do not depend on them."""

_RECALL: dict[tuple, object] = {}
T = TypeVar("T")


_RECALL_LOCK = threading.Lock()


def _recall(key: tuple, compute: Callable[[], T]) -> T:
    """compute() once per key among the last :data:`RECALLED` of each kind (key[0]); a key that cannot be
    hashed is computed every time.  Thread-safe (threads of one Dask worker may share it): the map is read
    and changed under a lock, compute() runs outside it (two threads may both compute a new key)."""
    try:
        hash(key)
    except TypeError:
        return compute()
    with _RECALL_LOCK:
        if key in _RECALL:
            return _RECALL[key]  # type: ignore[return-value]
    value = compute()
    with _RECALL_LOCK:
        if key not in _RECALL:
            same_kind = [k for k in _RECALL if k[0] == key[0]]
            for k in same_kind[:max(0, len(same_kind) - RECALLED + 1)]:
                del _RECALL[k]
            _RECALL[key] = value
        return _RECALL[key]  # type: ignore[return-value]


def forget_recalled() -> None:
    """Empty the recall of recent linear systems and Floquet results: a timing of repeated solves of one
    scene must call this before each, or it times the recalled parts as free."""
    with _RECALL_LOCK:
        _RECALL.clear()


def single_threaded_blas() -> contextlib.AbstractContextManager:
    """A context in which BLAS/LAPACK run on one thread (``threadpoolctl``; a no-op without it).

    The linear model's work is many small and batched matrix operations (n <= 240): a threaded BLAS
    splits each tiny call over its threads and pays their synchronization, 5-7x slower than one thread
    on a loaded 2-core machine (measured: tip 253 -> 37 ms, extender 318 -> 111 ms at 100 rpm), and no
    faster on an idle one.  The controller is found once per set of loaded BLAS libraries (scipy's own
    OpenBLAS is loaded with scipy.linalg)."""
    try:
        from threadpoolctl import ThreadpoolController
    except ImportError:  # pragma: no cover - threadpoolctl is a dependency
        return contextlib.nullcontext()
    key = "scipy.linalg" in sys.modules
    if key not in _CONTROLLERS:
        _CONTROLLERS[key] = ThreadpoolController()
    return _CONTROLLERS[key].limit(limits=1, user_api="blas")


ALLOCATOR_MMAP_BYTES = 32 * 2**20
ALLOCATOR_TRIM_BYTES = 64 * 2**20
_ALLOCATOR: list[bool] = []


def keep_freed_memory() -> None:
    """Once per process, on glibc: serve arrays up to :data:`ALLOCATOR_MMAP_BYTES` from the heap and keep
    up to :data:`ALLOCATOR_TRIM_BYTES` of freed heap mapped (``mallopt``; elsewhere a no-op).

    The linear model makes many short-lived arrays of 0.1 to a few MB (a Floquet level's step matrices,
    the dense collocation operator); glibc maps the larger ones afresh and returns freed heap to the system
    above a threshold it adapts, so the next temporary touches new pages: a page fault per 4 kB.
    Measured (loaded 2-core machine, joints model, one 512-step Floquet level): 2.2 -> 1.3 ms; the stage
    fields of that level 0.8 -> 0.4 ms.  The cost: up to that much freed memory stays with the process."""
    if _ALLOCATOR:
        return
    _ALLOCATOR.append(True)
    if not sys.platform.startswith("linux"):
        return
    try:
        import ctypes

        libc = ctypes.CDLL("libc.so.6")
        M_TRIM_THRESHOLD, M_MMAP_THRESHOLD = -1, -3
        libc.mallopt(M_MMAP_THRESHOLD, ALLOCATOR_MMAP_BYTES)
        libc.mallopt(M_TRIM_THRESHOLD, ALLOCATOR_TRIM_BYTES)
    except (OSError, AttributeError):  # not glibc (musl has no mallopt): the default allocator
        pass
