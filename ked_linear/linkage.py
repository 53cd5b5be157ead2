"""A scene as a linear time-periodic system on the absolute elastic displacements of its lumped masses.

M u'' + C(theta) u' + K(theta) u = -M a_rigid(theta), theta = theta0 + s Omega t (s = +1 ccw, -1 cw):
K = the frozen structure condensed on the masses (:func:`ked_quasi.frame.condensed_structure`, with the
geometric stiffness of the quasi-static axial forces if prestressed), C = beta K_E (the unstressed
part on the same static modes, :mod:`ked_quasi.damping`), output: dx, dy, rotation of P from the mass
displacements (static condensation).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ked_quasi.damping import damping_reference_hz, rayleigh_beta
from ked_quasi.frame import condensed_structure
from ked_quasi.scene import Scene

from .periodic import Coefficients, PeriodicSystem
from .sampled import SampledCoefficients
from .settings import LinearSettings

SAMPLING_START = 64
"""The first grid of the coefficients' sampling (:class:`~ked_linear.sampled.SampledCoefficients` doubles it
until the interpolant passes its midpoint check): no scene of benchmarks/compare_linear_grid.py (thesis
source and cognate, every mass model, 30 to 3133 rpm) passes on 32 angles (128 or 256 samples kept, or
none), so the check on 32 is skipped; a linkage smooth enough for 32 keeps 128 samples instead of 64."""


@dataclass(frozen=True)
class LinkageSystem:
    """The scene's periodic system plus its damping: reference frequency [Hz] and beta [s]."""

    system: PeriodicSystem
    damping_reference_hz: float
    damping_beta: float


def four_bar_system(scene: Scene, settings: LinearSettings, masses: bool = False) -> LinkageSystem:
    """The linear KED equations of a four-bar ``scene`` as a :class:`~ked_linear.periodic.PeriodicSystem`
    (any kind: :func:`ked_linear.kinds.linkage_system`); ``masses``: its output is every mass coordinate (the
    identity) instead of dx, dy, rotation of P."""
    f_ref = settings.damping_reference_hz
    f_ref = damping_reference_hz(scene) if f_ref is None else float(f_ref)
    beta = rayleigh_beta(settings.damping_ratio, f_ref)

    def direct(theta: np.ndarray) -> Coefficients:
        cs = condensed_structure(scene, theta, prestress=settings.prestress)
        out = np.broadcast_to(np.eye(cs.mass.size), cs.stiffness.shape) if masses else cs.output
        return Coefficients(stiffness=cs.stiffness, damping=beta * cs.material_stiffness, load=cs.load,
                            output=out)

    # sampled once, interpolated on the uniform grids of the periodic solve and the Floquet propagator
    coefficients = SampledCoefficients(direct, start=SAMPLING_START)
    mass = condensed_structure(scene, np.zeros(1)).mass
    system = PeriodicSystem(mass=mass, speed=scene.fourbar.sign * scene.omega, coefficients=coefficients)
    return LinkageSystem(system=system, damping_reference_hz=f_ref, damping_beta=beta)


def frozen_frequencies(scene: Scene, crank_angle: np.ndarray | None = None, prestress: bool = False,
                       n_modes: int = 1) -> np.ndarray:
    """Natural frequencies [Hz] (n, n_modes) of (M, K(theta)) at the crank angles (default the scene's
    grid), the lowest first; an imaginary frequency (buckled prestressed structure) is returned negative."""
    theta = scene.crank_angles if crank_angle is None else np.atleast_1d(np.asarray(crank_angle, float))
    cs = condensed_structure(scene, theta, prestress=prestress)
    return frequencies_of(cs.stiffness, cs.mass, n_modes)


def frequencies_of(stiffness: np.ndarray, mass: np.ndarray, n_modes: int = 1) -> np.ndarray:
    """Natural frequencies [Hz] (m, n_modes) of (diag(mass), stiffness (m, n, n)), the lowest first,
    an imaginary one negative (as :func:`frozen_frequencies`)."""
    w = 1.0 / np.sqrt(mass)
    lam = np.linalg.eigvalsh(w[:, None] * stiffness * w[None, :])[:, :n_modes]
    return np.sign(lam) * np.sqrt(np.abs(lam)) / (2.0 * np.pi)
