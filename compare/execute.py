"""Compute one scene: natural frequencies, quasi-static and dynamic solutions, metrics.

:func:`run_scene` is what a worker process (local pool or Dask worker) executes.  It never raises for
a problem of the scene itself: any exception of a solver stage is caught and returned as a
``"failed"`` :class:`~compare.results.SceneResult` with the stage, exception type and message, keeping
whatever earlier stages produced.  Units: SI, crank speed in rev/min where named ``rpm``.
"""

from __future__ import annotations

import math
import os
import socket
import time
import warnings
from dataclasses import asdict
from typing import Any

import numpy as np

from compare.metrics import scene_metrics
from compare.results import STATUS_FAILED, STATUS_OK, RunStats, SceneResult
from compare.scenes import COMPONENTS, SceneSpec
from compare.store import utc_now

_MAX_MESSAGE = 2000


def build_fourbar(spec: SceneSpec) -> Any:
    """The scene's mechanism as a ``ked_quasi.linkage.FourBar`` (source or cognate, stiffness scale and
    direction applied).  Raises ValueError if the linkage cannot assemble."""
    from ked_quasi.cognates import mechanism
    from ked_quasi.linkage import FourBar, Section

    lk = spec.linkage
    source = FourBar(
        crank=lk.crank,
        coupler=lk.coupler,
        follower=lk.follower,
        extender=lk.extender,
        coupler_angle=lk.coupler_angle,
        sections=tuple(Section(**s.to_dict()) for s in lk.sections),
        crank_pivot=lk.crank_pivot,
        follower_pivot=lk.follower_pivot,
        branch=lk.branch,
        direction=spec.direction,
    )
    fb = mechanism(source, spec.mechanism)
    return fb.with_stiffness_scale(spec.stiffness_scale).with_direction(spec.direction)


def build_mass_model(spec: SceneSpec) -> Any:
    """The scene's ``ked_quasi.massmodel.MassModel``."""
    from ked_quasi.massmodel import MassModel

    mm = spec.mass_model
    return MassModel(
        name=mm.name, lumps=mm.lumps, payload=mm.payload, joint_split=mm.joint_split, placement=mm.placement
    )


def dynamic_api() -> tuple[Any, Any]:
    """``(DynamicSettings, simulate_steady_state)`` of ``exudyn_models``."""
    try:
        from exudyn_models import DynamicSettings, simulate_steady_state
    except ImportError:  # pragma: no cover - package not re-exporting yet
        from exudyn_models.settings import DynamicSettings
        from exudyn_models.simulate import simulate_steady_state
    return DynamicSettings, simulate_steady_state


def build_settings(spec: SceneSpec) -> Any:
    """The scene's ``exudyn_models.DynamicSettings`` (explicit overrides on top of the defaults)."""
    settings_cls, _ = dynamic_api()
    return settings_cls(**dict(spec.dynamic))


def resolve_rpm(spec: SceneSpec, omega1_min: float) -> float:
    """Crank speed [rev/min]: the given rpm, or ratio * omega1_min [rad/s] converted to rev/min."""
    if spec.speed.kind == "rpm":
        return spec.speed.value
    return spec.speed.value * omega1_min * 60.0 / (2.0 * math.pi)


def _message(exc: BaseException) -> str:
    text = str(exc) or repr(exc)
    extra = []
    for attr, unit in (("time", "s"), ("crank_angle", "rad")):
        v = getattr(exc, attr, None)
        if isinstance(v, (int, float)):
            extra.append(f"{attr}={v:.6g} {unit}")
    if extra:
        text += f" ({', '.join(extra)})"
    return text[:_MAX_MESSAGE]


def run_scene(spec: SceneSpec) -> SceneResult:
    """Run both solvers on one scene and compare them (see module docstring)."""
    from ked_quasi.kinematics import coupler_point
    from ked_quasi.solver import Scene, natural_frequencies, solve_quasi_static

    t_start = time.perf_counter()
    state: dict[str, Any] = {"spec": spec}
    stats: dict[str, Any] = {"worker": f"{socket.gethostname()}:{os.getpid()}"}
    stage = "setup"

    def finish(status: str, stage_: str = "", exc: BaseException | None = None, message: str = "") -> SceneResult:
        stats["total_wall_s"] = time.perf_counter() - t_start
        stats["finished_utc"] = utc_now()
        return SceneResult(
            status=status,
            stage=stage_,
            error_type=type(exc).__name__ if exc is not None else ("NoSteadyState" if message else ""),
            message=_message(exc) if exc is not None else message,
            stats=RunStats(**stats),
            **state,
        )

    try:
        fourbar = build_fourbar(spec)
        mass_model = build_mass_model(spec)
        settings = build_settings(spec)
        state["dynamic_settings"] = asdict(settings)

        stage = "frequencies"
        t0 = time.perf_counter()
        probe_rpm = spec.speed.value if spec.speed.kind == "rpm" else 1.0
        probe = Scene(fourbar, mass_model, rpm=probe_rpm, step_deg=spec.step_deg)
        freqs = np.asarray(natural_frequencies(probe, n_modes=spec.n_modes), dtype=float)
        stats["frequencies_wall_s"] = time.perf_counter() - t0
        state["natural_frequencies"] = freqs
        f1_min = float(np.nanmin(freqs[:, 0]))
        omega1_min = 2.0 * math.pi * f1_min
        state["omega1_min"] = omega1_min
        rpm = resolve_rpm(spec, omega1_min)
        state["rpm"] = rpm
        scene = Scene(fourbar, mass_model, rpm=rpm, step_deg=spec.step_deg)
        theta = np.asarray(scene.crank_angles, dtype=float)
        state["crank_angle"] = theta
        state["coupler_point"] = np.asarray(coupler_point(fourbar, theta), dtype=float)

        stage = "quasi_static"
        t0 = time.perf_counter()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            qs = solve_quasi_static(scene)
        stats["quasi_static_wall_s"] = time.perf_counter() - t0
        state["warnings"] = "; ".join(sorted({str(w.message) for w in caught}))[:_MAX_MESSAGE]
        qs_defl = np.asarray(qs.deflection, dtype=float)
        state["quasi_static"] = {c: qs_defl[:, COMPONENTS.index(c)].copy() for c in spec.outputs}

        stage = "dynamic"
        _, simulate_steady_state = dynamic_api()
        t0 = time.perf_counter()
        try:
            dyn = simulate_steady_state(scene, settings)
        finally:
            stats["dynamic_wall_s"] = time.perf_counter() - t0
        stats["steps"] = int(dyn.steps)
        stats["newton_iterations"] = int(dyn.newton_iterations)
        stats["cycles"] = int(dyn.cycles)
        stats["converged"] = bool(dyn.converged)
        stats["dynamic_message"] = str(dyn.message)[:_MAX_MESSAGE]
        if not np.allclose(np.asarray(dyn.crank_angle, dtype=float), theta, rtol=0.0, atol=1e-9):
            raise ValueError("dynamic result is not on the scene's crank-angle grid")
        dyn_defl = np.asarray(dyn.deflection, dtype=float)
        state["dynamic"] = {c: dyn_defl[:, COMPONENTS.index(c)].copy() for c in spec.outputs}
        if not dyn.converged:
            return finish(STATUS_FAILED, "dynamic",
                          message=f"no periodic steady state: {dyn.message}"[:_MAX_MESSAGE])

        stage = "metrics"
        state["metrics"] = scene_metrics(
            theta,
            state["quasi_static"],
            state["dynamic"],
            omega=scene.omega,
            omega1_min=omega1_min,
            tolerance=spec.tolerance,
            direction_sign=1 if spec.direction == "ccw" else -1,
        )
    except Exception as exc:  # a scene's own failure: record it, keep the campaign going
        return finish(STATUS_FAILED, stage, exc)
    return finish(STATUS_OK)
