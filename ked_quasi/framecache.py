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
prestressed structure K_E + (Omega / Omega_ref)^2 K_G,ref is not linear in Omega^2 and is done per speed
(:func:`ked_quasi.frame.condensed_structure`).

The cache is keyed by content: the scene's type, its four-bar (every compared field: lengths, coupler angle,
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
from dataclasses import dataclass, fields, is_dataclass, replace
from typing import Any, TypeVar

import numpy as np

from .frame import FrameDofs, assemble, frame_dofs
from .kinematics import loop
from .massmodel import lumps
from .scene import Scene
from .solver import inertia_loads, node_masses
from .structure import Geometry, Topology, element_forces, geometry, topology

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
    return (kind, type(scene).__name__, scene.fourbar, scene.mass_model, theta.shape, theta.tobytes())


def load_scale(scene: Scene) -> float:
    """(rpm / :data:`REFERENCE_RPM`)^2: the factor from the reference-speed loads, axial forces and geometric
    stiffness to the scene's."""
    return (float(scene.rpm) / REFERENCE_RPM) ** 2


@dataclass(frozen=True)
class FrameParts:
    """The speed-free frame model at n crank angles.

    topo, dofs: the structure and its dof numbering; geo: the frozen geometry; node_mass (N,) [kg]; nodes:
    the mass-carrying nodes; master: their translational dofs (x1, y1, x2, y2, ...); elastic (n, d, d): the
    elastic stiffness K_E [N/m, N, N m]; loads (n, N, 2) [N] and axial (n, E) [N, tension > 0]: the
    d'Alembert loads and the elements' quasi-static axial forces at :data:`REFERENCE_RPM`.
    """

    topo: Topology
    dofs: FrameDofs
    geo: Geometry
    node_mass: np.ndarray
    nodes: np.ndarray
    master: np.ndarray
    elastic: np.ndarray
    loads: np.ndarray
    axial: np.ndarray


def _build(scene: Scene, theta: np.ndarray) -> FrameParts:
    lm = lumps(scene.fourbar, scene.mass_model)
    topo = topology(lm)
    dofs = frame_dofs(topo)
    lp = loop(scene.fourbar, theta)
    geo = geometry(scene.fourbar, topo, theta, lp)
    loads = inertia_loads(replace(scene, rpm=REFERENCE_RPM), topo, lm, theta, geo, lp)
    with np.errstate(divide="ignore", invalid="ignore"):
        axial = element_forces(topo, geo, loads)[..., 0]
    mass = node_masses(topo, lm)
    nodes = np.flatnonzero(mass > 0)
    master = np.stack([2 * nodes, 2 * nodes + 1], axis=1).ravel()
    return FrameParts(topo=topo, dofs=dofs, geo=geo, node_mass=mass, nodes=nodes, master=master,
                      elastic=assemble(scene.fourbar, topo, dofs, geo), loads=loads, axial=axial)


def frame_parts(scene: Scene, crank_angle: np.ndarray) -> FrameParts:
    """The speed-free :class:`FrameParts` of ``scene`` at ``crank_angle`` [rad] (cached)."""
    theta = np.atleast_1d(np.asarray(crank_angle, dtype=float))
    return CACHE.get(speed_free_key("parts", scene, theta), lambda: _build(scene, theta))


def geometric_stiffness(scene: Scene, crank_angle: np.ndarray) -> np.ndarray:
    """(n, d, d): the geometric stiffness of the quasi-static axial forces at :data:`REFERENCE_RPM` (cached;
    at the scene's speed it is :func:`load_scale` times this)."""
    theta = np.atleast_1d(np.asarray(crank_angle, dtype=float))

    def build() -> np.ndarray:
        p = frame_parts(scene, theta)
        return assemble(scene.fourbar, p.topo, p.dofs, p.geo, p.axial, elastic=False)

    return CACHE.get(speed_free_key("geometric", scene, theta), build)


def cached(kind: str, scene: Scene, crank_angle: np.ndarray, compute: Callable[[], T]) -> T:
    """compute() once per content key (:func:`speed_free_key`) of a speed-free ``kind`` of result: the
    caller promises it depends on the scene only through its four-bar, mass model and ``crank_angle``."""
    return CACHE.get(speed_free_key(kind, scene, crank_angle), compute)


__all__ = ["CACHE", "REFERENCE_RPM", "ContentCache", "FrameParts", "cached", "frame_parts", "geometric_stiffness",
           "load_scale", "speed_free_key"]
