"""The elastic motion of the linear model's masses near a crank angle: the dynamic part a start state needs.

The Exudyn reference can start its constant-speed phase on (nearly) its periodic orbit when it knows the
inertia of the elastic motion there (``exudyn_models.start``, ``start = "linear"``).  The linear model has it:
its periodic steady state u(theta) of the masses' absolute elastic displacements (``ked_linear.linkage``), on
the model that carries the dynamics (``ked_linear.lumping.dynamic_scene``).  Accelerations at constant crank
speed are Omega^2 d2u/dtheta2, by 5-point central differences of the steady state (step :data:`STEP_RAD`:
error ~ (k h)^4 / 90 of harmonic k, 1e-7 at k = 32).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .corotating import periodic_steady_state
from .linkage import four_bar_system
from .lumping import dynamic_scene
from .reduction import REDUCE_FROM
from .runtime import single_threaded_blas
from .settings import LinearSettings

STEP_RAD = 0.005
"""Crank-angle step [rad] of the differences."""
MAX_ERROR = 0.05
"""Largest estimated relative error of the steady state (fraction of the peak) accepted for a start."""


@dataclass(frozen=True)
class MassMotion:
    """Elastic motion of the masses at crank angles ``theta`` (m,) [rad]: ``link`` (K,) and ``s`` (K,) place
    mass k on a link (fraction from its root); ``displacement`` (m, K, 2) [m] and ``acceleration`` (m, K, 2)
    [m/s^2]: absolute x, y of the elastic motion at constant crank speed."""

    theta: np.ndarray
    link: tuple[str, ...]
    s: np.ndarray
    displacement: np.ndarray
    acceleration: np.ndarray


def mass_motion(scene: object, settings: LinearSettings, theta: np.ndarray) -> MassMotion:
    """The masses' elastic motion of a four-bar ``scene`` at ``theta``.  Raises ValueError when the steady state
    is not resolved to :data:`MAX_ERROR` (then no start should rest on it)."""
    from ked_quasi.frame import condensed_structure
    from ked_quasi.massmodel import lumps
    from ked_quasi.structure import topology

    dyn, s = dynamic_scene(scene, settings)
    system = four_bar_system(dyn, s, masses=True).system
    theta = np.atleast_1d(np.asarray(theta, dtype=float))
    offsets = STEP_RAD * np.arange(-2, 3)
    with single_threaded_blas():
        ss = periodic_steady_state(dyn, system, (theta[:, None] + offsets).ravel(), s.tolerance, s.harmonics,
                                   s.max_harmonics, None,
                                   reduce=s.damping_ratio > 0.0 and system.mass.size >= REDUCE_FROM)
    if not ss.error_estimate <= MAX_ERROR:
        raise ValueError(f"linear steady state not resolved (estimated error {ss.error_estimate:.2g} of the peak)")
    u = np.asarray(ss.output).reshape(theta.size, offsets.size, -1)
    d2 = (-u[:, 0] + 16 * u[:, 1] - 30 * u[:, 2] + 16 * u[:, 3] - u[:, 4]) / (12 * STEP_RAD**2)
    topo = topology(lumps(dyn.fourbar, dyn.mass_model))
    nodes = condensed_structure(dyn, theta[:1]).mass_node
    return MassMotion(theta=theta, link=tuple(topo.node_link[n] for n in nodes), s=np.asarray(topo.node_s)[nodes],
                      displacement=u[:, 2].reshape(theta.size, -1, 2),
                      acceleration=(system.speed**2 * d2).reshape(theta.size, -1, 2))
