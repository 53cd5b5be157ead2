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

from ked_quasi.stress import StressHistory, combine, four_bar_stress_from_loads, quasi_static_stress, slider_stress

from .lumping import dynamic_scene
from .settings import LinearSettings


def linear_stress(scene: object, settings: LinearSettings | None = None, crank_angle: np.ndarray | None = None,
                  stable: bool = True) -> StressHistory:
    """Stress histories of the linear model's periodic steady state of a four-bar ``scene`` at ``crank_angle``
    [rad] (default: its grid; a slider-crank too); ``stable``: solve_linear's verdict (False: every history NaN).
    ValueError when the masses' steady state is not resolved to :data:`ked_linear.motion.MAX_ERROR`."""
    from ked_quasi.frame import condensed_structure
    from ked_quasi.massmodel import lumps
    from ked_quasi.slidercrank import SliderScene
    from ked_quasi.solver import inertia_loads, node_masses
    from ked_quasi.structure import topology

    from .motion import mass_motion

    settings = LinearSettings() if settings is None else settings
    theta = scene.crank_angles if crank_angle is None else np.atleast_1d(np.asarray(crank_angle, float))
    dyn, dyn_settings = dynamic_scene(scene, settings)
    if isinstance(scene, SliderScene):
        out = _slider_dynamic(dyn, dyn_settings, theta)
    else:
        motion = mass_motion(scene, settings, theta)
        lm = lumps(dyn.fourbar, dyn.mass_model)
        topo = topology(lm)
        loads = inertia_loads(dyn, topo, lm, theta)
        nodes = condensed_structure(dyn, theta[:1]).mass_node
        loads[:, nodes] -= node_masses(topo, lm)[nodes][None, :, None] * motion.acceleration
        out = four_bar_stress_from_loads(dyn, theta, loads, tier="linear")
    if dyn != scene:
        out = combine(out, quasi_static_stress(scene, theta), quasi_static_stress(dyn, theta), "linear")
    if not stable:
        for ls in out.links.values():
            ls.axial[:] = np.nan
            ls.moment[:] = np.nan
    return out


def _slider_dynamic(scene: object, settings: LinearSettings, theta: np.ndarray) -> StressHistory:
    """The slider-crank model's stress under -M (a_rigid + u'') on its own lumps (no static correction here)."""
    from ked_quasi.slider_static import _frozen, inertia_loads

    from .motion import MAX_ERROR, STEP_RAD
    from .periodic import steady_state
    from .slider import slider_frame, slider_system

    system = slider_system(scene, settings).system
    offsets = STEP_RAD * np.arange(-2, 3)
    ss = steady_state(system, (theta[:, None] + offsets).ravel(), settings.tolerance, settings.harmonics,
                      settings.max_harmonics)
    if not ss.error_estimate <= MAX_ERROR:
        raise ValueError(f"linear steady state not resolved (estimated error {ss.error_estimate:.2g} of the peak)")
    u = np.asarray(ss.displacement).reshape(theta.size, offsets.size, -1)
    d2 = (-u[:, 0] + 16 * u[:, 1] - 30 * u[:, 2] + 16 * u[:, 3] - u[:, 4]) / (12 * STEP_RAD**2)
    frame = slider_frame(scene)
    lm, topo, kin, _ = _frozen(scene, theta)
    loads = inertia_loads(scene, topo, lm, kin)
    loads[:, frame.master // 2, frame.master % 2] -= frame.mass * system.speed**2 * d2
    return slider_stress(scene, theta, loads, tier="linear")


__all__ = ["linear_stress"]
