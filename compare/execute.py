"""Compute one scene: natural frequencies, every requested solver, the metrics of every pair.

:func:`run_scene` is what a worker process (local pool or Dask worker) executes.  It never raises for
a problem of the scene itself: a failing stage or solver is caught and recorded (stage, exception type
and message) and whatever else was computed is kept.  Units: SI, crank speed in rev/min where named
``rpm``.
"""

from __future__ import annotations

import os
import socket
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np

from compare.metrics import all_pairs
from compare.results import STATUS_FAILED, STATUS_OK, RunStats, SceneResult, utc_now
from compare.scenes import SceneSpec
from compare.solvers import Solution, Solver
from ked_quasi import kinds, units

_MAX_MESSAGE = 2000


def resolve_rpm(spec: SceneSpec, omega1_min: float) -> float:
    """Crank speed [rev/min]: the given rpm, or ratio * omega1_min [rad/s] converted to rev/min."""
    if spec.speed.kind == "rpm":
        return spec.speed.value
    return units.rad_s_to_rpm(spec.speed.value * omega1_min)


def message_of(exc: BaseException) -> str:
    """An exception's message (at most 2000 characters)."""
    return (str(exc) or repr(exc))[:_MAX_MESSAGE]


@dataclass(frozen=True)
class Frame:
    """What every solver shares: the scene at its resolved speed and the frozen frequencies."""

    scene: object
    rpm: float
    omega1_min: float
    natural_frequencies: np.ndarray
    frequencies_wall_s: float


def frame(spec: SceneSpec) -> Frame:
    """Resolve the scene: frozen natural frequencies (at a probe speed), omega1_min, rpm."""
    t0 = time.perf_counter()
    probe = spec.scene(spec.speed.value if spec.speed.kind == "rpm" else 1.0)
    freqs = np.asarray(kinds.model(probe).natural_frequencies(probe, n_modes=spec.n_modes), dtype=float)
    omega1_min = units.omega1_min(freqs[:, 0])
    rpm = resolve_rpm(spec, omega1_min)
    return Frame(spec.scene(rpm), rpm, omega1_min, freqs, time.perf_counter() - t0)


def coupler_path(scene: object) -> np.ndarray:
    """(n, 2) rigid-kinematics position [m] of the coupler point P over the scene's crank-angle grid."""
    return kinds.model(scene).coupler_path(scene)


def settings_of(solver: Solver, spec: SceneSpec) -> object:
    """The settings ``solver`` runs with on ``spec``: the scene's shared physical settings the solver
    knows, its own explicit overrides, the damping ratio."""
    fields = solver.setting_fields()
    shared = {k: v for k, v in spec.shared_settings().items() if k in fields}
    return solver.make_settings({**shared, **spec.settings_for(solver.name)}, spec.damping_ratio)


def solve_one(solver: Solver, spec: SceneSpec, scene: object) -> Solution:
    """One solver on the scene; an exception becomes a failed :class:`Solution` (class and evidence
    taken from the exception when it carries them)."""
    t0 = time.perf_counter()
    try:
        settings = settings_of(solver, spec)
    except (TypeError, ValueError) as exc:
        return Solution(solver.name, STATUS_FAILED, message=message_of(exc), error_type=type(exc).__name__,
                        failure_class="input", stats={"wall_s": time.perf_counter() - t0}, fidelity=solver.fidelity)
    try:
        sol = solver.run(scene, settings, spec.outputs)
    except Exception as exc:  # a solver's own failure: record it, keep the scene going
        return Solution(solver.name, STATUS_FAILED, settings=solver.settings_dict(settings),
                        message=message_of(exc), error_type=type(exc).__name__,
                        failure_class=str(getattr(exc, "failure_class", "") or ""),
                        stats={"wall_s": time.perf_counter() - t0}, fidelity=solver.fidelity)
    return replace(sol, settings=sol.settings or solver.settings_dict(settings), fidelity=solver.fidelity)


def run_scene(spec: SceneSpec, solvers: Sequence[Solver] | None = None,
              reuse: Mapping[str, Solution] | None = None) -> SceneResult:
    """Run ``solvers`` (default: the scene's own, from the registry) on one scene and compare them (see
    module docstring).  ``reuse``: solutions already stored for this scene (kept, not recomputed)."""
    t_start = time.perf_counter()
    if solvers is None:
        from compare import solvers as registry

        solvers = [registry.get(n) for n in spec.solvers]
    reuse = dict(reuse or {})
    worker = f"{socket.gethostname()}:{os.getpid()}"

    def stats(freq_wall: float = 0.0) -> RunStats:
        return RunStats(frequencies_wall_s=freq_wall, total_wall_s=time.perf_counter() - t_start,
                        worker=worker, finished_utc=utc_now())

    try:
        fr = frame(spec)
    except Exception as exc:  # the scene cannot be set up (a linkage that cannot assemble, ...)
        return SceneResult(spec=spec, status=STATUS_FAILED, stage="setup", error_type=type(exc).__name__,
                           message=message_of(exc), failure_class="input", stats=stats())
    theta = fr.scene.crank_angles
    linkage = fr.scene.linkage

    solutions = {s.name: reuse[s.name] if s.name in reuse else solve_one(s, spec, fr.scene) for s in solvers}
    base = dict(spec=spec, rpm=fr.rpm, omega1_min=fr.omega1_min, crank_angle=theta,
                coupler_point=coupler_path(fr.scene),
                natural_frequencies=fr.natural_frequencies, solutions=solutions,
                warnings="; ".join(s.warnings for s in solutions.values() if s.warnings)[:_MAX_MESSAGE])
    failed = [s for s in solutions.values() if not s.ok]
    try:
        ok = {n: s for n, s in solutions.items() if s.ok}
        metrics = all_pairs(theta, {n: s.histories for n, s in ok.items()}, {n: s.fidelity for n, s in ok.items()},
                            omega=fr.scene.omega,
                            omega1_min=fr.omega1_min, tolerance=spec.tolerance, direction_sign=linkage.sign)
    except Exception as exc:
        return SceneResult(**base, status=STATUS_FAILED, stage="metrics", error_type=type(exc).__name__,
                           message=message_of(exc), stats=stats(fr.frequencies_wall_s))
    if failed:
        f = failed[0]
        return SceneResult(**base, metrics=metrics, status=STATUS_FAILED, stage=f.solver, error_type=f.error_type,
                           message=f.message, failure_class=f.failure_class, stats=stats(fr.frequencies_wall_s))
    return SceneResult(**base, metrics=metrics, status=STATUS_OK, stats=stats(fr.frequencies_wall_s))

