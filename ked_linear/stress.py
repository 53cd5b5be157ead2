"""Link stress histories of the linear KED model.

The linear model is M u'' + C u' + K u = -M a_rigid on the lumped masses of the frozen structure (static
condensation: every other node carries no load, :mod:`ked_linear.linkage`).  Its masses are in equilibrium
under their d'Alembert forces -M (a_rigid + u'') and the section forces of the structure (elastic K u and
viscous C u', both carried by the sections), and the frozen structure is statically determinate, so its
member forces are those of the quasi-static statics under the loads

    P = -M (a_rigid + u''),   u'' = Omega^2 d2u/dtheta2 of the periodic steady state,

exactly for the unprestressed model (the default): equivalent to the element end forces k_e u_e of the
deformed frame, with no recovery of the slave nodes needed.  With ``prestress`` the model's geometric
stiffness (the axial forces acting through the deflection) is not redistributed along the links here (an
approximation of the order of that stiffening).  u'' comes from :func:`ked_linear.motion.mass_motion` (the
model that carries the dynamics, on ``LinearSettings.dynamic_lumps``); on fewer lumps than the scene's the
stress gets the same static correction as the deflection (:mod:`ked_linear.lumping`):

    sigma(theta) = sigma_dyn,coarse(theta) + (sigma_qs,scene(theta) - sigma_qs,coarse(theta)),

link by link on the union of both element layouts (exact there: N piecewise constant, M piecewise linear).
The periodic orbit's stability is :func:`ked_linear.solve_linear`'s verdict (``stable``: pass it to get NaN
histories where no stable steady state exists).  A slider-crank: the same statics on its frozen structure
(:func:`ked_quasi.stress.slider_stress`), u'' of its masses' free coordinates (:mod:`ked_linear.slider`) by the
same 5-point differences as :mod:`ked_linear.motion`.  SI units.
"""

from __future__ import annotations

import numpy as np

from ked_quasi.kinds import quasi_static_stress
from ked_quasi.stress import StressHistory, combine

from .kinds import model
from .lumping import dynamic_scene
from .settings import LinearSettings


def linear_stress(scene: object, settings: LinearSettings | None = None, crank_angle: np.ndarray | None = None,
                  stable: bool = True) -> StressHistory:
    """Stress histories of the linear model's periodic steady state of a ``scene`` of any kind at ``crank_angle``
    [rad] (default: its grid; each kind's dynamics: :mod:`ked_linear.kinds`); ``stable``: solve_linear's verdict
    (False: every history NaN).
    ValueError when the masses' steady state is not resolved to :data:`ked_linear.motion.MAX_ERROR`."""
    settings = LinearSettings() if settings is None else settings
    theta = scene.crank_angles if crank_angle is None else np.atleast_1d(np.asarray(crank_angle, float))
    dyn, _ = dynamic_scene(scene, settings)
    out = model(scene).dynamic_stress(scene, settings, theta)
    if dyn != scene:
        out = combine(out, quasi_static_stress(scene, theta), quasi_static_stress(dyn, theta), "linear")
    if not stable:
        for ls in out.links.values():
            ls.axial[:] = np.nan
            ls.moment[:] = np.nan
    return out


__all__ = ["linear_stress"]
