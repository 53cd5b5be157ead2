"""solve_linear: the linear time-periodic KED model of a scene of any linkage kind, its periodic steady state
and stability (each kind's model: :mod:`ked_linear.kinds`)."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import replace

import numpy as np

from ked_quasi.scene import Scene
from ked_quasi.units import omega1_min, speed_ratio

from .floquet import FloquetResult
from .fourbar import elastic_coordinates, stability  # noqa: F401  (re-exported where they were defined)
from .kinds import model
from .lumping import coarse_scene, first_frequencies, static_correction
from .periodic import PeriodicSystem
from .reduction import REDUCE_FROM, Reductions  # noqa: F401  (REDUCE_FROM re-exported where it was defined)
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
from .runtime import (  # noqa: F401  (re-exported where they were defined)
    forget_recalled,
    keep_freed_memory,
    single_threaded_blas,
)
from .settings import LinearSettings


def solve_linear(scene: Scene, settings: LinearSettings | None = None) -> LinearResult:
    """Periodic steady state of the linear KED model of a scene of any kind (see docs/linear_model.md): its
    kind's solve (:mod:`ked_linear.kinds`), on ``settings.dynamic_lumps`` plus the static correction when the
    scene has more lumps."""
    keep_freed_memory()
    with single_threaded_blas():
        coarse = coarse_scene(scene, settings.dynamic_lumps) if isinstance(settings, LinearSettings) else None
        if coarse is None:
            return _solve_kind(scene, settings)
        return _on_fewer_lumps(scene, coarse, settings)


def _solve_kind(scene: Scene, settings: LinearSettings | None) -> LinearResult:
    return model(scene).solve(scene, settings)


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


def reduced_stability(scene: Scene, system: PeriodicSystem, settings: LinearSettings,
                      reductions: Callable[[], Reductions] | None = None) -> FloquetResult | None:
    """The Floquet result of the reduced system of a scene of any kind (its kind's, :mod:`ked_linear.kinds`), or
    None where the full system must decide (see :func:`ked_linear.fourbar.reduced_stability`)."""
    return model(scene).reduced_stability(scene, system, settings, reductions)
