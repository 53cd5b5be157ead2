"""Structural damping shared by the dynamic models: stiffness-proportional (Rayleigh beta) damping.

D = beta K with beta = 2 zeta / omega_ref, omega_ref = 2 pi f_ref: a mode of the frozen structure at
frequency f gets the modal damping ratio zeta * f / f_ref, exactly ``damping_ratio`` at the reference
frequency.  The default reference frequency is a property of the frozen linkage:
:func:`damping_reference_hz`, the first natural frequency of the frozen structure averaged over the
scene's crank-angle grid.  Every dynamic model (the Exudyn model, the linear KED model) uses these two
definitions, so their damping is the same.
"""

from __future__ import annotations

import math

import numpy as np

from .scene import Scene
from .solver import natural_frequencies


def damping_reference_hz(scene: Scene) -> float:
    """Default damping reference frequency [Hz]: the first natural frequency of the frozen structure
    (:func:`ked_quasi.natural_frequencies`, the scene's mass model) averaged over ``scene.crank_angles``."""
    return float(np.mean(natural_frequencies(scene, n_modes=1)[:, 0]))


def rayleigh_beta(damping_ratio: float, reference_hz: float) -> float:
    """Stiffness-proportional damping coefficient beta [s] giving ``damping_ratio`` at ``reference_hz`` [Hz]."""
    if not reference_hz > 0.0:
        raise ValueError(f"reference_hz must be positive (Hz), got {reference_hz!r}")
    if not damping_ratio >= 0.0:
        raise ValueError(f"damping_ratio must be non-negative, got {damping_ratio!r}")
    return 2.0 * damping_ratio / (2.0 * math.pi * reference_hz)
