"""Natural frequencies of the frozen Exudyn model (crank held at fixed angles), for comparison with
ked_quasi.solver.natural_frequencies on the same scene and mass model."""

from __future__ import annotations

import numpy as np

from .builder import build_model
from .settings import DynamicSettings

EIGEN_LINK_MASS_PER_LENGTH = 1e-5
"""[kg/m] given to links that are massless in the mass model, only for eigenvalue analysis (the mass
matrix must not be singular). About 1e-5 kg per link, negligible against the lumps; much smaller
values make the constraint null-space projection ill-conditioned (spurious shifts of ~5 %)."""


def frozen_natural_frequencies(scene, crank_angles, n_modes: int = 3,
                               settings: DynamicSettings | None = None) -> np.ndarray:
    """(len(crank_angles), n_modes) undamped natural frequencies [Hz] of the frozen structure.

    The crank is clamped at each crank angle [rad] (ked_quasi convention); damping is left out.
    """
    settings = DynamicSettings() if settings is None else settings
    angles = np.atleast_1d(np.asarray(crank_angles, dtype=float))
    out = np.empty((angles.size, n_modes))
    for i, th in enumerate(angles):
        model = build_model(scene, settings, frozen_angle=float(th), damping_beta=0.0,
                            massless_link_mass_per_length=EIGEN_LINK_MASS_PER_LENGTH, p_sensor=False)
        f, _ = model.mbs.ComputeODE2Eigenvalues(convert2Frequencies=True)
        out[i] = np.sort(np.asarray(f))[:n_modes]
    return out
