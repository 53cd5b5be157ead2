"""The four-bar's linear KED model: its elastic coordinates, its periodic steady state and stability
(:func:`solve_four_bar`), and the stress of its masses' dynamics (:func:`dynamic_stress`).  One entry of
:mod:`ked_linear.kinds`; callers use :func:`ked_linear.solve_linear`, :func:`ked_linear.stress.linear_stress`."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import replace

import numpy as np

from ked_quasi.scene import Scene
from ked_quasi.solver import natural_frequencies
from ked_quasi.stress import StressHistory, four_bar_stress_from_loads
from ked_quasi.units import omega1_min, speed_ratio

from .corotating import periodic_steady_state
from .floquet import FloquetResult, floquet
from .linkage import four_bar_system, frequencies_of
from .lumping import dynamic_scene
from .motion import mass_motion
from .periodic import PeriodicSystem
from .reduction import REDUCE_FROM, Reductions, link_frames, reduced_floquet
from .result import MAX_COORDINATES, OUTPUT_GROUPS, LinearResult, _message
from .runtime import _recall
from .settings import LinearSettings


def elastic_coordinates(scene: Scene) -> int:
    """Elastic coordinates of the linear model of ``scene``: 2 per frame node carrying mass (as
    ``ked_quasi.frame.condensed_structure`` keeps them), counted without any frame solve."""
    from ked_quasi.massmodel import lumps
    from ked_quasi.solver import node_masses
    from ked_quasi.structure import topology

    lm = lumps(scene.fourbar, scene.mass_model)
    return 2 * int(np.count_nonzero(node_masses(topology(lm), lm) > 0))



def reduced_stability(scene: Scene, system: PeriodicSystem, settings: LinearSettings,
                      reductions: Callable[[], Reductions] | None = None) -> FloquetResult | None:
    """The Floquet result of the reduced system in co-rotating link frames (:mod:`ked_linear.reduction`;
    ``steps``: its Radau IIA steps per cycle), or None where the full system must decide: a fixed
    ``floquet_steps``, no damping, fewer than :data:`REDUCE_FROM` coordinates, or a
    reduction that does not vouch for half of ``floquet_tolerance`` (its estimate covering the step levels
    and the basis).  ``reductions``: gives the system's :class:`ked_linear.reduction.Reductions` if shared."""
    if settings.floquet_steps is not None or settings.damping_ratio <= 0.0 or system.mass.size < REDUCE_FROM:
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


def solve_four_bar(scene: Scene, settings: LinearSettings | None) -> LinearResult:
    """Periodic steady state and Floquet stability of the linear model of a four-bar ``scene`` on its own lumps."""
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
    ls = _recall(("system", *system_key), lambda: four_bar_system(scene, replace(settings, damping_reference_hz=f_ref)))
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


def dynamic_stress(scene: Scene, settings: LinearSettings, theta: np.ndarray) -> StressHistory:
    """The four-bar model's stress under -M (a_rigid + u'') at ``theta`` [rad], on the model that carries the
    dynamics (:func:`ked_linear.lumping.dynamic_scene`; no static correction here: :mod:`ked_linear.stress`)."""
    from ked_quasi.frame import condensed_structure
    from ked_quasi.massmodel import lumps
    from ked_quasi.solver import inertia_loads, node_masses
    from ked_quasi.structure import topology

    dyn, _ = dynamic_scene(scene, settings)
    motion = mass_motion(scene, settings, theta)
    lm = lumps(dyn.fourbar, dyn.mass_model)
    topo = topology(lm)
    loads = inertia_loads(dyn, topo, lm, theta)
    nodes = condensed_structure(dyn, theta[:1]).mass_node
    loads[:, nodes] -= node_masses(topo, lm)[nodes][None, :, None] * motion.acceleration
    return four_bar_stress_from_loads(dyn, theta, loads, tier="linear")
