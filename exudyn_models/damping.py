"""Modal damping ratio -> Exudyn beam damping parameters.

Mapping (stiffness-proportional Rayleigh damping, D = beta * K):
    beta = 2 * zeta / omega_ref,   omega_ref = 2 * pi * f_ref   [s]
    ObjectANCFCable2D:              bendingDamping = beta * E*I   [N m^2 s]
                                    axialDamping   = beta * E*A   [N s]
    ObjectBeamGeometricallyExact2D: bendingDamping = beta * E*I, axialDamping = beta * E*A,
                                    shearDamping   = beta * G*A_s
Both element types add the damping stress resultants  beta * (rate of the strain measure) next to
the elastic ones, so the beam damping matrix is exactly beta times the tangent stiffness of the
unstressed structure. The joints are rigid constraints and add no stiffness, so every mode i of the
frozen structure gets the modal damping ratio zeta_i = beta * omega_i / 2: exactly zeta at f_ref,
proportionally more above it (high modes are strongly damped), less below.
"""

from __future__ import annotations

import math


def rayleigh_beta(damping_ratio: float, reference_hz: float) -> float:
    """Stiffness-proportional damping coefficient beta [s] giving `damping_ratio` at `reference_hz`."""
    if not reference_hz > 0.0:
        raise ValueError(f"reference_hz must be positive, got {reference_hz!r}")
    if damping_ratio < 0.0:
        raise ValueError(f"damping_ratio must be non-negative, got {damping_ratio!r}")
    return 2.0 * damping_ratio / (2.0 * math.pi * reference_hz)


def modal_damping_ratio(beta: float, frequency_hz: float) -> float:
    """Modal damping ratio of a mode at `frequency_hz` under stiffness-proportional damping beta."""
    return beta * math.pi * frequency_hz


def reference_frequency(scene, settings) -> float:
    """Damping reference frequency [Hz]: settings.damping_reference_hz, or if None the first
    natural frequency of the frozen structure (ked_quasi.solver.natural_frequencies, same scene and
    mass model) averaged over the scene's crank-angle grid."""
    if settings.damping_reference_hz is not None:
        return float(settings.damping_reference_hz)
    import numpy as np

    from ked_quasi.solver import natural_frequencies

    return float(np.mean(np.asarray(natural_frequencies(scene, n_modes=1))[:, 0]))
