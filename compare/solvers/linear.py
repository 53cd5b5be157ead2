"""The linear time-periodic KED model (``ked_linear``): the frozen structure plus the inertia of the
elastic motion, periodic steady state solved directly, stability from the Floquet multipliers."""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from compare.solvers import (
    COMPONENTS,
    STATUS_FAILED,
    STATUS_OK,
    STRESS,
    Solution,
    Solver,
    deflection_of,
    register,
    stress_of,
)


def settings_class() -> type:
    from ked_linear.settings import LinearSettings

    return LinearSettings


def setting_rules() -> dict[str, Any]:
    from ked_linear.settings import RULES

    return RULES


def make_settings(overrides: dict[str, Any], damping_ratio: float) -> Any:
    """``LinearSettings`` from the explicit overrides, damped like the scene (its damping ratio)."""
    return settings_class()(**{"damping_ratio": damping_ratio, **overrides})


def legacy_defaults() -> dict[str, Any]:
    """``dynamic_lumps`` was added later: older runs carried the inertia on the scene's own lumps (None)."""
    return {"dynamic_lumps": None}


NUMERICAL_FAILURE = "linear model failed numerically"
"""The start of the message of a linear solve that failed numerically (a singular or non-finite matrix)."""


def run(scene: Any, settings: Any, outputs: tuple[str, ...] = COMPONENTS) -> Solution:
    """The linear model's steady state (a linear-algebra failure of the solve, e.g. a singular or
    non-finite matrix, is a failed solution of class "numerical" whose message starts with
    :data:`NUMERICAL_FAILURE`); without an asymptotically stable periodic steady state (max
    |Floquet multiplier| >= 1: "unstable", or undamped with every multiplier on the unit circle:
    "marginal") a failed solution of class "physical" (error type "Unstable" or "Marginal") with the
    multiplier as evidence; a weakly damped stable one carries the flag "weakly_damped".  The statistic
    ``radau_steps`` is ``LinearResult.radau_steps`` (steps of the co-rotating steady state; 0 when the
    collocation answered, whose ``harmonics`` and ``collocation_points`` are then the statistics).
    ``floquet_steps`` is ``LinearResult.floquet_steps``: Radau IIA steps of the reduced system where the
    reduced Floquet analysis answered (damped extender and distributed models; ``floquet_reduced`` then
    true), else the full model's propagator steps (docs/linear_model.md).  With the output ``stress``, the link
    stresses of the steady state (ked_linear.stress); where the masses' steady state is not resolved well enough
    for its accelerations, none, with a warning."""
    from ked_linear import describe_flags, result_flags, solve_linear

    try:
        res = solve_linear(scene, settings)  # a slider-crank scene dispatches to ked_linear.slider
    except (np.linalg.LinAlgError, ArithmeticError) as exc:  # a numerical failure, not a physical verdict
        return Solution(SOLVER.name, STATUS_FAILED, message=f"{NUMERICAL_FAILURE}: {exc}"[:2000],
                        error_type=type(exc).__name__, failure_class="numerical")
    stats = {"wall_s": float(res.wall_s), "floquet_max_abs": float(res.floquet_max_abs),
             "floquet_error": float(res.floquet_error), "floquet_steps": int(res.floquet_steps),
             "harmonics": int(res.harmonics), "collocation_points": int(res.collocation_points),
             "radau_steps": int(res.radau_steps), "floquet_reduced": bool(res.floquet_reduced),
             "error_estimate": float(res.error_estimate), "damping_reference_hz": float(res.damping_reference_hz),
             "speed_ratio": float(res.speed_ratio)}
    if not res.stable:
        return Solution(SOLVER.name, STATUS_FAILED, stats=stats, message=res.message,
                        error_type="Marginal" if res.status == "marginal" else "Unstable", failure_class="physical")
    d = np.asarray(res.deflection, dtype=float)
    linkage = scene.linkage
    flags = result_flags(res, linkage)
    note = describe_flags(flags, res, linkage)
    if STRESS in outputs:  # the steady state's stresses: a solve of their own, timed as such
        t0 = time.perf_counter()
        stress, stress_note = _stress(scene, settings)
        stats["stress_wall_s"] = time.perf_counter() - t0
    else:
        stress, stress_note = {}, ""
    return Solution(SOLVER.name, STATUS_OK, deflection_of(d, outputs), stats=stats, flags=flags,
                    warnings="; ".join(x for x in (note, stress_note) if x), stress=stress)


def _stress(scene: Any, settings: Any) -> tuple[dict[str, np.ndarray], str]:
    """The steady state's link stresses, or none and why."""
    from ked_linear.stress import linear_stress

    try:
        return stress_of(linear_stress(scene, settings)), ""
    except ValueError as exc:
        return {}, f"no link stresses: {exc}"


SOLVER = register(Solver(
    name="linear", label="linear KED", fidelity=5, settings_class=settings_class, make_settings=make_settings,
    run=run, setting_rules=setting_rules, legacy_defaults=legacy_defaults,
    description="linear time-periodic KED (ked_linear): frozen structure plus the inertia of the elastic motion, "
                "periodic steady state and Floquet stability",
))


def make_classic_settings(overrides: dict[str, Any], damping_ratio: float) -> Any:
    """``LinearSettings`` without prestress: the classical linear KED model."""
    return make_settings({**overrides, "prestress": False}, damping_ratio)


def run_classic(scene: Any, settings: Any, outputs: tuple[str, ...] = COMPONENTS) -> Solution:
    from dataclasses import replace

    return replace(run(scene, settings, outputs), solver=CLASSIC.name)


CLASSIC = register(Solver(
    name="linear_classic", label="linear KED (no prestress)", fidelity=4, settings_class=settings_class,
    make_settings=make_classic_settings, run=run_classic, setting_rules=setting_rules,
    legacy_defaults=legacy_defaults,
    description="the classical linear KED model: as 'linear' without the geometric stiffness of the axial forces",
))
