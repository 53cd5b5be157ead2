"""solve_linear: the linear time-periodic KED model of a scene, its periodic steady state and stability."""

from __future__ import annotations

import contextlib
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import replace
from typing import TypeVar

import numpy as np

from ked_quasi.scene import Scene
from ked_quasi.solver import natural_frequencies
from ked_quasi.units import omega1_min, speed_ratio

from .corotating import periodic_steady_state
from .floquet import FloquetResult, floquet
from .linkage import frequencies_of, linkage_system
from .lumping import coarse_scene, first_frequencies, static_correction
from .periodic import PeriodicSystem
from .reduction import Reductions, link_frames, reduced_floquet
from .result import (  # noqa: F401  (the answer's type and flags, re-exported where they were defined)
    MARGINAL,
    MAX_COORDINATES,
    OUTPUT_GROUPS,
    RESULT_FLAGS,
    SETTLE_BUDGET,
    SETTLE_TOL,
    UNRESOLVED_ESTIMATE,
    WEAKLY_DAMPED,
    LinearResult,
    _message,
    cycles_to_settle,
    describe_flags,
    result_flags,
    weakly_damped,
)
from .settings import LinearSettings


def elastic_coordinates(scene: Scene) -> int:
    """Elastic coordinates of the linear model of ``scene``: 2 per frame node carrying mass (as
    ``ked_quasi.frame.condensed_structure`` keeps them), counted without any frame solve."""
    from ked_quasi.massmodel import lumps
    from ked_quasi.solver import node_masses
    from ked_quasi.structure import topology

    lm = lumps(scene.fourbar, scene.mass_model)
    return 2 * int(np.count_nonzero(node_masses(topology(lm), lm) > 0))


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


def _is_slider(scene: object) -> bool:
    from ked_quasi.slidercrank import SliderScene

    return isinstance(scene, SliderScene)


def solve_linear(scene: Scene, settings: LinearSettings | None = None) -> LinearResult:
    """Periodic steady state of the linear KED model of ``scene`` (see docs/linear_model.md); a slider-crank
    scene goes to :func:`ked_linear.slider.solve_slider_linear`."""
    keep_freed_memory()
    with single_threaded_blas():
        coarse = coarse_scene(scene, settings.dynamic_lumps) if isinstance(settings, LinearSettings) else None
        if coarse is None:
            return _solve_kind(scene, settings)
        return _on_fewer_lumps(scene, coarse, settings)


def _solve_kind(scene: Scene, settings: LinearSettings | None) -> LinearResult:
    if _is_slider(scene):
        from .slider import solve_slider_linear

        return solve_slider_linear(scene, settings)
    return _solve_linear(scene, settings)


def _on_fewer_lumps(scene: Scene, coarse: Scene, settings: LinearSettings) -> LinearResult:
    """The answer of the model on ``settings.dynamic_lumps`` plus the static correction to the scene's own lumps
    (:mod:`ked_linear.lumping`); the damping reference and the speed ratio are the scene's own (its frozen first
    frequency, as the Exudyn model's damping reference)."""
    t0 = time.perf_counter()
    f1 = first_frequencies(scene)
    f_ref = float(np.nanmean(f1)) if settings.damping_reference_hz is None else settings.damping_reference_hz
    res = _solve_kind(coarse, replace(settings, damping_reference_hz=f_ref))
    fix = static_correction(scene, coarse) if res.stable else np.zeros((scene.crank_angles.size, 4))
    extra = {"midspan": res.midspan + fix[:, 3]} if getattr(res, "midspan", None) is not None else {}
    return replace(res, deflection=res.deflection + fix[:, :3], settings=settings,
                   speed_ratio=speed_ratio(scene.omega, omega1_min(f1)),
                   wall_s=time.perf_counter() - t0, **extra)


REDUCE_FROM = 8
"""Damped four-bar systems with at least this many coordinates (extender, distributed) get their Floquet
multipliers from the reduced system (:mod:`ked_linear.reduction`) when it vouches for the tolerance;
smaller ones (tip, joints: the full propagator is as fast), undamped ones and a fixed ``floquet_steps``
use the full propagator (:func:`ked_linear.floquet.floquet`)."""


def reduced_stability(scene: Scene, system: PeriodicSystem, settings: LinearSettings,
                      reductions: Callable[[], Reductions] | None = None) -> FloquetResult | None:
    """The Floquet result of the reduced system in co-rotating link frames (:mod:`ked_linear.reduction`;
    ``steps``: its Radau IIA steps per cycle), or None where the full system must decide: a fixed
    ``floquet_steps``, no damping, fewer than :data:`REDUCE_FROM` coordinates, a slider-crank, or a
    reduction that does not vouch for half of ``floquet_tolerance`` (its estimate covering the step levels
    and the basis).  ``reductions``: gives the system's :class:`ked_linear.reduction.Reductions` if shared."""
    if settings.floquet_steps is not None or settings.damping_ratio <= 0.0 or system.mass.size < REDUCE_FROM \
            or _is_slider(scene):
        return None
    built = None if reductions is None else reductions()
    red = reduced_floquet(system, link_frames(scene) if built is None else built.frames,
                          settings.floquet_tolerance, built)
    return None if red is None else red.result


def stability(scene: Scene, system: PeriodicSystem, settings: LinearSettings,
              reductions: Callable[[], Reductions] | None = None) -> FloquetResult:
    """The Floquet result of the linear model of ``scene``: :func:`reduced_stability` where it answers, else
    the full system's (:func:`ked_linear.floquet.floquet`)."""
    red = reduced_stability(scene, system, settings, reductions)
    return red if red is not None else floquet(system, settings.floquet_tolerance, settings.floquet_steps)


def _solve_linear(scene: Scene, settings: LinearSettings | None) -> LinearResult:
    t0 = time.perf_counter()
    settings = LinearSettings() if settings is None else settings
    if not isinstance(settings, LinearSettings):
        raise TypeError(f"settings must be a LinearSettings, got {type(settings).__name__}")
    # refused before any work (the damping reference frequency of an oversized model alone takes a minute)
    size = elastic_coordinates(scene)
    if size > MAX_COORDINATES:
        raise ValueError(f"mass model: the linear KED model takes at most {MAX_COORDINATES // 2} moving lumps "
                         f"({MAX_COORDINATES} coordinates: its memory grows as their square times the Floquet "
                         f"steps); this scene has {size // 2}: use fewer lumps per link")
    # the unstressed first frozen frequency on the grid: the speed ratio's omega1_min and, by default, the
    # damping reference (its mean, as ked_quasi.damping.damping_reference_hz): computed once for both
    f1 = natural_frequencies(scene, n_modes=1)[:, 0]
    f_ref = float(np.mean(f1)) if settings.damping_reference_hz is None else settings.damping_reference_hz
    system_key = (scene, settings.damping_ratio, f_ref, settings.prestress)
    ls = _recall(("system", *system_key), lambda: linkage_system(scene, replace(settings, damping_reference_hz=f_ref)))
    theta = scene.crank_angles

    def reductions() -> Reductions:  # the reduced systems' common parts, built once for both passes
        return _recall(("reductions", *system_key), lambda: Reductions(ls.system, link_frames(scene)))

    ss = periodic_steady_state(scene, ls.system, theta, settings.tolerance, settings.harmonics,
                               settings.max_harmonics, OUTPUT_GROUPS,
                               reduce=settings.damping_ratio > 0.0 and ls.system.mass.size >= REDUCE_FROM,
                               reductions=reductions)
    fl = _recall(("floquet", *system_key, settings.floquet_tolerance, settings.floquet_steps),
                 lambda: stability(scene, ls.system, settings, reductions))
    # the uncertainty counts against stability: a multiplier within its error of 1 is no attracting orbit
    err = fl.error_estimate if np.isfinite(fl.error_estimate) else 0.0
    stable = bool(fl.max_abs + err < 1.0)
    # undamped: max |mu| >= 1 in theory (det Phi = 1, reciprocal pairs); = 1 within its error is marginal
    marginal = not stable and settings.damping_ratio == 0.0 and fl.max_abs - 1.0 <= err
    status = "ok" if stable else "marginal" if marginal else "unstable"
    deflection = ss.output if stable else np.full_like(ss.output, np.nan)
    return LinearResult(
        crank_angle=theta, deflection=deflection, status=status, stable=stable,
        message=_message(status, fl.max_abs, fl.error_estimate, ss.error_estimate, settings.tolerance,
                         ss.harmonics),
        floquet_max_abs=fl.max_abs, floquet_error=fl.error_estimate, floquet_steps=fl.steps,
        floquet_reduced=fl.reduced,
        harmonics=ss.harmonics, collocation_points=ss.points, radau_steps=ss.radau_steps,
        error_estimate=ss.error_estimate,
        damping_reference_hz=ls.damping_reference_hz, damping_beta=ls.damping_beta,
        speed_ratio=speed_ratio(scene.omega, omega1_min(f1)),
        frozen_f1_hz=frequencies_of(ls.system.coefficients(theta).stiffness, ls.system.mass)[:, 0],
        settings=settings,
        wall_s=time.perf_counter() - t0,
    )
