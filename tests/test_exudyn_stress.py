"""Link stresses of the Exudyn tier (``simulate_steady_state(..., stress=True)``, :mod:`exudyn_models.stress_cycle`)
against the quasi-static limit, the linear model (a second implementation) and a beam table.

* At 1 rpm the dynamic part of the response is O(r^2) ~ 1e-6 of the quasi-static one, so every tier's stress is
  the frozen structure's statics.  With the tip and joint mass models the links are massless between their
  joints: N is constant and M linear along every link, which the ANCF element's linear curvature represents
  exactly, so the Exudyn stress equals the quasi-static one up to the steady-state and Newton tolerances.
* At 30 rpm (tip mass) the dynamic part is about 1-3 % of the peak stress: the Exudyn and linear stresses
  resolve it alike (the two models of the same small-deflection physics), the quasi-static one lacks it.
* Simeon's rod at 30 rad/s: its midspan bending moment under the rod's own linearly varying inertia load is
  the beam table's M_mid = (w_A + w_B) L^2 / 16 (the quasi-static tier gives it exactly, tests/test_stress_simeon),
  amplified by 1 / (1 - (2 Omega/omega_1)^2) = 1.002 at the crank's second harmonic.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from exudyn_models.settings import DynamicSettings
from exudyn_models.simulate import simulate_steady_state
from ked_linear.stress import linear_stress
from ked_quasi import MassModel, SliderScene, simeon_slider_crank
from ked_quasi.kinds import quasi_static_stress
from ked_quasi.linkage import LINKS
from ked_quasi.presets import make_scene
from ked_quasi.stress import LinkStress


def _error(a: LinkStress, b: LinkStress) -> float:
    """Largest difference of the largest and smallest fibre stress over the cycle, over b's peak."""
    return max(np.max(np.abs(a.sigma_max - b.sigma_max)), np.max(np.abs(a.sigma_min - b.sigma_min))) / b.peak


@pytest.mark.parametrize("mass_model", ["tip", "joints"])
def test_exudyn_stress_equals_the_quasi_static_one_at_one_rpm(mass_model):
    scene = make_scene(mass_model=mass_model, rpm=1.0, lumps=20)
    res = simulate_steady_state(scene, DynamicSettings(), stress=True)
    assert res.converged and res.stress.tier == "exudyn"
    qs = quasi_static_stress(scene)
    assert set(res.stress.links) == set(LINKS)
    for link in LINKS:
        assert _error(res.stress.links[link], qs.links[link]) < 1e-3, link  # 0.1 % of the peak (measured 1e-4)


@pytest.mark.parametrize("settings", [DynamicSettings(), DynamicSettings(periodic="anderson")],
                         ids=["marching", "anderson"])
def test_exudyn_stress_resolves_the_dynamic_part_as_the_linear_model_does(settings):
    # the stress cycle starts from whatever steady state the run reached (marched or solved periodic)
    scene = make_scene(mass_model="tip", rpm=30.0, lumps=20)
    res = simulate_steady_state(scene, settings, stress=True)
    lin, qs = linear_stress(scene), quasi_static_stress(scene)
    for link in LINKS:
        ex = res.stress.links[link]
        assert _error(ex, lin.links[link]) < 5e-3, link  # measured 0.12-0.14 %
        assert _error(ex, qs.links[link]) > 1e-2, link  # the dynamic part: measured 1.3-2.7 %


def test_simeon_rod_midspan_stress_is_the_beam_table_at_low_speed():
    omega = 30.0  # [rad/s]; (2 Omega / omega_1)^2 = 2.2e-3 (omega_1 = 1276 rad/s)
    scene = SliderScene(simeon_slider_crank(), MassModel("distributed", lumps=4), rpm=omega * 60 / (2 * math.pi),
                        step_deg=10.0)
    res = simulate_steady_state(scene, DynamicSettings(elements_per_link=12, steps_per_cycle=1080), stress=True)
    assert res.converged and set(res.stress.links) == {"coupler"}  # Simeon's crank is rigid: no beam
    ex = res.stress.links["coupler"]
    qs = quasi_static_stress(scene).links["coupler"]
    table = np.abs(qs.moment_at(0.5))  # the beam table's M_mid at every crank angle [N m]
    exudyn = np.abs(ex.moment_at(0.5))
    assert np.max(np.abs(exudyn - table)) < 1e-2 * table.max()  # measured 0.5 %
    assert exudyn.max() == pytest.approx(table.max() / (1 - (2 * omega / 1276.0) ** 2), rel=5e-3)


def test_no_stress_unless_asked():
    res = simulate_steady_state(make_scene(mass_model="tip", rpm=30.0, step_deg=30.0), DynamicSettings())
    assert res.stress is None
