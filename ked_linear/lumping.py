"""The linear model's answer on the scene's own lumps from a model with fewer (the static correction).

The inertia of the elastic motion converges in the lumps per link much faster than the quasi-static part of
the answer: on the atlas's distributed four-bars near the 10 % margin the quasi-static vs linear history
error moves by 0.1-0.2 points from 5 to 20 lumps while each answer alone moves by 1-2 % of its peak
(docs/linear_model.md).  So the dynamic model runs on ``LinearSettings.dynamic_lumps`` and its answer is
corrected by the difference of the quasi-static answers on the scene's lumps and on those:

    u(theta) = u_dyn,coarse(theta) + (q_scene(theta) - q_coarse(theta))

exact in the quasi-static limit (the linear model equals the quasi-static one there) and as cheap as two
quasi-static solves.  Mass models without distributed lumps (tip, joints) are left alone.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

LUMPED = ("extender", "distributed")
"""Mass models whose mass sits in ``lumps`` lumps per link."""


def coarse_scene(scene: Any, dynamic_lumps: int | None) -> Any | None:
    """The scene with ``dynamic_lumps`` lumps per link, or None when it has no more than that (or a mass
    model without lumps, or ``dynamic_lumps`` None)."""
    mm = scene.mass_model
    if dynamic_lumps is None or mm.name not in LUMPED or mm.lumps <= dynamic_lumps:
        return None
    return replace(scene, mass_model=replace(mm, lumps=dynamic_lumps))


def static_correction(scene: Any, coarse: Any) -> np.ndarray:
    """q_scene - q_coarse on the scene's grid (columns: :func:`ked_quasi.kinds.quasi_static_outputs`)."""
    from ked_quasi.kinds import quasi_static_outputs

    return quasi_static_outputs(scene) - quasi_static_outputs(coarse)


def first_frequencies(scene: Any) -> np.ndarray:
    """First unstressed frozen natural frequency [Hz] on the scene's grid (n,), on the scene's own lumps."""
    from ked_quasi.kinds import model

    return np.asarray(model(scene).natural_frequencies(scene, n_modes=1))[:, 0]


def dynamic_scene(scene: Any, settings: Any) -> tuple[Any, Any]:
    """The scene and settings the inertia of the elastic motion is solved on (Floquet multipliers, dynamic
    response): the scene on ``settings.dynamic_lumps`` when it has more, damped with the scene's own reference
    frequency (the mean of its first frozen frequency, the Exudyn model's definition) unless one is given."""
    coarse = coarse_scene(scene, settings.dynamic_lumps)
    if coarse is None:
        return scene, settings
    f_ref = settings.damping_reference_hz
    f_ref = float(np.nanmean(first_frequencies(scene))) if f_ref is None else f_ref
    return coarse, replace(settings, damping_reference_hz=f_ref)
