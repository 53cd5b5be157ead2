"""Simeon's flexible slider-crank (ked_bench.simeon) in the Exudyn tier: its scene, its damping, and the
midspan history the benchmark compares (exudyn_models.slider_builder / slider_simulate).  The benchmark knows
the model, never the other way round."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from exudyn_models.settings import DynamicSettings
from exudyn_models.simulate import simulate_steady_state

from .simeon import simeon_scene


def simeon_damping() -> tuple[float, float]:
    """(damping ratio [1], reference frequency [Hz]) matching Simeon's damped model: his first bending mode's
    ratio DQ11 / (2 sqrt(KQ11 MQ11)) (2.59 %) at the rod's first bending frequency (pinned-pinned, 203.2 Hz),
    both from ked_bench.simeon."""
    from .simeon import SimeonParameters, rod_matrices

    par = SimeonParameters(damped=True)
    rod = rod_matrices(par)
    zeta = float(rod.dq[0, 0] / (2.0 * math.sqrt(rod.kq[0, 0] * rod.mq[0, 0])))
    return zeta, par.first_bending_rad_s / (2.0 * math.pi)


def slider_midspan_history(omega: float, *, step_deg: float = 5.0, settings: DynamicSettings | None = None):
    """Exudyn's periodic steady state of Simeon's slider-crank at crank speed ``omega`` [rad/s]: the rod's
    midspan transverse deflection over one cycle, damped like Simeon's model (:func:`simeon_damping`).

    settings: Exudyn settings (its damping_ratio and damping_reference_hz are replaced by Simeon's); None:
    6 ANCF elements on the rod, 1080 steps per cycle (the default campaign's discretization).  Returns
    (crank_angle (n,) [rad] from 0 in steps of step_deg, midspan (n,) [m], the DynamicResult) with
    n = 360 / step_deg (72 at the default, the grid of ked_bench.simeon.steady_state).  Raises
    SimulationError when no run goes through; check result.converged before using the history.
    """
    zeta, f_ref = simeon_damping()
    base = DynamicSettings(elements_per_link=6, steps_per_cycle=1080) if settings is None else settings
    s = replace(base, damping_ratio=zeta, damping_reference_hz=f_ref)
    scene = simeon_scene(omega, step_deg)
    res = simulate_steady_state(scene, s)
    return np.asarray(res.crank_angle), np.asarray(res.midspan), res
