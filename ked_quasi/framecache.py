"""The speed-free part of the frozen frame model, built once per linkage, mass model and set of crank angles.

At constant crank speed Omega and without gravity (the loads are the d'Alembert forces of the rigid motion
alone) every rigid-body acceleration is Omega^2 times a function of the crank angle: the crank's
-Omega^2 z1, the coupler's and follower's angular velocities are linear in Omega and their angular
accelerations quadratic (:func:`ked_quasi.kinematics.acceleration_field`).  So the inertia loads, the
quasi-static axial forces (linear in the loads) and their geometric stiffness K_G are (Omega / Omega_ref)^2
times their values at the reference speed :data:`REFERENCE_RPM`, while the geometry, the elastic stiffness
K_E, the lumped masses, the unstressed static condensation and natural frequencies do not depend on the
speed at all.  A repeated solve of one linkage at many speeds (``ked check --rpm-range``, an atlas family's
speed-ratio sweep, the critical-speed sweep) builds them once here; the static condensation of the
prestressed structure K_E + (Omega / Omega_ref)^2 K_G,ref is not linear in Omega^2: its speed-free factors
(the slave block's Cholesky factor and the eigenvectors of its geometric part) are kept here too and
combined per speed by a few small products (:func:`ked_quasi.frame.condensed_structure`).  The parts
themselves are built in :mod:`ked_quasi.frame` (:func:`~ked_quasi.frame.frame_parts`,
:func:`~ked_quasi.frame.geometric_stiffness`); this module holds the cache, its key and the speed scaling,
and imports neither the frame model nor the solver (they import it).

The cache is keyed by content: the scene's class, its four-bar (every compared field: lengths, coupler angle,
sections with the stiffness scale in their moduli, pivots, branch, direction) and mass model (name, lumps,
payload, joint split, placement), and the crank angles' bytes: everything these parts depend on except the
speed, which is not in the key.  It keeps at most :data:`MAX_ENTRIES` entries and :data:`MAX_BYTES` bytes
(the least recently used go first; an entry larger than a quarter of that is computed and not kept), and
its arrays are read-only.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import fields, is_dataclass
from typing import Any, TypeVar

import numpy as np

from .scene import Scene

REFERENCE_RPM = 60.0
"""The speed [rev/min] at which the speed-dependent parts are kept (1 rev/s); at ``rpm`` they are
(rpm / REFERENCE_RPM)^2 times those."""
MAX_ENTRIES = 48
"""Entries kept (each one linkage x mass model x set of crank angles x kind of part)."""
MAX_BYTES = 160 * 2**20
"""Bytes of arrays kept (the elastic and geometric stiffness of a 512-angle grid of the 5-lump
distributed model take 21 MB each)."""

T = TypeVar("T")


class ContentCache:
    """A bounded least-recently-used map from hashable content keys to computed values (thread-safe)."""

    def __init__(self, max_entries: int, max_bytes: int):
        self.max_entries, self.max_bytes = max_entries, max_bytes
        self._items: OrderedDict[Any, tuple[Any, int]] = OrderedDict()
        self._bytes = 0
        self._lock = threading.Lock()
        self.hits = self.misses = 0

    def get(self, key: Any, compute: Callable[[], T]) -> T:
        """The value of ``key``, computed (and kept if small enough) on a miss; a key that cannot be hashed
        is computed every time."""
        try:
            hash(key)
        except TypeError:
            return compute()
        with self._lock:
            if key in self._items:
                self._items.move_to_end(key)
                self.hits += 1
                return self._items[key][0]
            self.misses += 1
        value = compute()
        size = _nbytes(value)
        if size > self.max_bytes // 4:
            return value
        _freeze(value)
        with self._lock:
            if key not in self._items:
                self._items[key] = (value, size)
                self._bytes += size
            while self._items and (len(self._items) > self.max_entries or self._bytes > self.max_bytes):
                _, (_, dropped) = self._items.popitem(last=False)
                self._bytes -= dropped
        return value

    def clear(self) -> None:
        with self._lock:
            self._items.clear()
            self._bytes = 0

    def __len__(self) -> int:
        return len(self._items)

    @property
    def nbytes(self) -> int:
        return self._bytes


def _arrays(value: Any) -> list[np.ndarray]:
    if isinstance(value, np.ndarray):
        return [value]
    if isinstance(value, (tuple, list)):
        return [a for v in value for a in _arrays(v)]
    if is_dataclass(value) and not isinstance(value, type):
        return [a for f in fields(value) for a in _arrays(getattr(value, f.name))]
    return []


def _nbytes(value: Any) -> int:
    return sum(a.nbytes for a in _arrays(value))


def _freeze(value: Any) -> None:
    for a in _arrays(value):
        a.flags.writeable = False


CACHE = ContentCache(MAX_ENTRIES, MAX_BYTES)
"""The process's cache of frame parts (``CACHE.clear()`` empties it)."""


def speed_free_key(kind: str, scene: Scene, crank_angle: np.ndarray) -> tuple:
    """The content key of a speed-free part ``kind`` of ``scene`` at ``crank_angle``: everything but the speed."""
    theta = np.ascontiguousarray(crank_angle, dtype=float)
    return (kind, type(scene), scene.fourbar, scene.mass_model, theta.shape, theta.tobytes())


def load_scale(scene: Scene) -> float:
    """(rpm / :data:`REFERENCE_RPM`)^2: the factor from the reference-speed loads, axial forces and geometric
    stiffness to the scene's."""
    return (float(scene.rpm) / REFERENCE_RPM) ** 2


def cached(kind: str, scene: Scene, crank_angle: np.ndarray, compute: Callable[[], T]) -> T:
    """compute() once per content key (:func:`speed_free_key`) of a speed-free ``kind`` of result: the
    caller promises it depends on the scene only through its four-bar, mass model and ``crank_angle``."""
    return CACHE.get(speed_free_key(kind, scene, crank_angle), compute)


__all__ = ["CACHE", "REFERENCE_RPM", "ContentCache", "cached", "load_scale", "speed_free_key"]
