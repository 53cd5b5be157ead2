"""Link stress histories of the quasi-static tier against beam-table closed forms (point loads).

Expected values come from statics, not from the code: a link pinned at both ends carries the bending moment
of a simply supported beam under the transverse components of its loads (Roark / any beam table, point load
P at a from the left end of a span L: M(x) = P x (L - a) / L for x <= a, P a (L - x) / L for x >= a,
superposed over the lumps); a link clamped at one end and free of moment at the other is a cantilever
(M at the root = P a for a transverse point load P at distance a from the root).
"""

from __future__ import annotations

import numpy as np
import pytest

from ked_quasi.kinds import quasi_static_stress
from ked_quasi.linkage import Section
from ked_quasi.slider_static import _frozen, inertia_loads
from ked_quasi.slidercrank import build_slider_scene, simeon_slider_crank
from ked_quasi.stress import link_stress, slider_stress

ANGLES = np.deg2rad([0.0, 30.0, 100.0, 200.0, 290.0])


def _scene(rpm: float = 1000.0):
    return build_slider_scene(simeon_slider_crank(), "distributed", rpm=rpm)


def _simply_supported(q: np.ndarray, a: np.ndarray, x: np.ndarray, L: float) -> np.ndarray:
    """Beam table: moment (n, len(x)) of a simply supported span L under point loads q (n, k) at a (k,)."""
    xx, aa = x[:, None], a[None, :]
    influence = np.where(xx <= aa, xx * (L - aa) / L, aa * (L - xx) / L)  # (len(x), k)
    return q @ influence.T


def test_slider_rod_is_a_simply_supported_beam_under_its_inertia_loads():
    """The rod (pinned at the crank pin and the slider) under the frozen structure's d'Alembert loads:
    M along it equals the simply supported beam's point-load superposition of the loads' components
    normal to the rod (sagging positive for loads along the CCW normal: the code's sign is the opposite,
    hogging positive, pinned here by comparing -M)."""
    scene = _scene()
    lm, topo, kin, _ = _frozen(scene, ANGLES)
    loads = inertia_loads(scene, topo, lm, kin)
    rod = np.array([lk == "coupler" for lk in topo.node_link])
    e = (kin.zB - kin.zA) / np.abs(kin.zB - kin.zA)
    normal = 1j * e
    q = (loads[..., 0] + 1j * loads[..., 1]) * np.conj(normal)[:, None]
    L = scene.linkage.coupler
    a = topo.node_s[rod] * L
    ls = quasi_static_stress(scene, ANGLES).links["coupler"]
    x = np.r_[ls.s0, ls.s1[-1]] * L
    expected = _simply_supported(q.real[:, rod], a, x, L)
    got = np.concatenate([ls.moment[:, :, 0], ls.moment[:, -1:, 1]], axis=1)
    peak = np.abs(expected).max()
    assert peak > 1.0  # a real bending load at 1000 rpm
    np.testing.assert_allclose(-got, expected, atol=1e-9 * peak)
    # pinned ends: no moment (beam table boundary condition)
    np.testing.assert_allclose(got[:, [0, -1]], 0.0, atol=1e-9 * peak)


def test_slider_crank_is_a_cantilever_under_a_point_load_on_it():
    """A transverse point load P on the crank at fraction s (nothing else loaded): the rod is a two-force
    member the slider cannot hold, so the crank is a cantilever, M_root = P s L_crank, M = 0 at the pin; the
    rod carries nothing."""
    scene = _scene()
    _, topo, kin, _ = _frozen(scene, ANGLES)
    P, s = 250.0, 0.5
    k = topo.node_of("crank", s)
    normal = 1j * kin.zA / np.abs(kin.zA)
    loads = np.zeros((ANGLES.size, topo.n_nodes, 2))
    loads[:, k, 0], loads[:, k, 1] = P * normal.real, P * normal.imag
    h = slider_stress(scene, ANGLES, loads)
    crank, rod = h.links["crank"], h.links["coupler"]
    Lc = scene.linkage.crank
    np.testing.assert_allclose(np.abs(crank.moment[:, 0, 0]), P * s * Lc, rtol=1e-10)
    np.testing.assert_allclose(crank.moment[:, -1, 1], 0.0, atol=1e-9 * P * Lc)
    np.testing.assert_allclose(crank.moment_at(0.75), crank.moment[:, 0, 0] * 0.0, atol=1e-9 * P * Lc)
    np.testing.assert_allclose(np.abs(crank.moment_at(0.25)), P * (s - 0.25) * Lc, rtol=1e-10)
    np.testing.assert_allclose(crank.axial, 0.0, atol=1e-9 * P)
    np.testing.assert_allclose(rod.moment, 0.0, atol=1e-9 * P * Lc)
    # sigma = N/A + |M| c / I at the root (N = 0): the section's flexure formula
    sec = scene.linkage.section("crank")
    np.testing.assert_allclose(crank.sigma_max, P * s * Lc * sec.extreme_fibre / sec.second_moment, rtol=1e-10)
    np.testing.assert_allclose(crank.sigma_min, -crank.sigma_max, rtol=1e-10)


def test_fibre_stress_is_axial_plus_flexure_with_signs():
    """sigma_max/min = N/A +- |M| c/I (flexure formula), extremes over the element ends."""
    sec = Section(youngs_modulus=2e11, area=1e-4, second_moment=1e-9, density=7800.0, fibre_distance=0.005)
    forces = np.array([[[1000.0, 200.0, 0.0], [1000.0, 0.0, -5.0]]])  # (n=1, E=2, (N, V, M))
    ls = link_stress("rod", sec, 0.2, np.array([0.0, 0.5]), np.array([0.5, 1.0]), forces)
    # element 0: M_i = M_j + L V = 0 + 0.1 * 200 = 20 N m; element 1: |M| = 5 N m at both ends
    assert ls.moment[0, 0, 0] == pytest.approx(20.0)
    assert ls.sigma_max[0] == pytest.approx(1000.0 / 1e-4 + 20.0 * 0.005 / 1e-9)
    assert ls.sigma_min[0] == pytest.approx(1000.0 / 1e-4 - 20.0 * 0.005 / 1e-9)
    assert ls.peak == pytest.approx(ls.sigma_max[0])  # tension side: 110 MPa against -90 MPa


def _four_bar(rpm: float = 300.0):
    from ked_quasi.presets import make_scene

    return make_scene("thesis", "source", "distributed", rpm=rpm)


def test_four_bar_follower_is_a_simply_supported_beam_under_its_inertia_loads():
    """The follower (pinned at the ground pivot and at B) under the frozen structure's d'Alembert loads of its
    own lumps: M along it equals the simply supported beam's point-load superposition (beam table)."""
    from ked_quasi.massmodel import lumps
    from ked_quasi.solver import inertia_loads as four_bar_loads
    from ked_quasi.structure import geometry, topology

    scene = _four_bar()
    lm = lumps(scene.fourbar, scene.mass_model)
    topo = topology(lm)
    geo = geometry(scene.fourbar, topo, ANGLES)
    loads = four_bar_loads(scene, topo, lm, ANGLES)
    on = np.array([lk == "follower" for lk in topo.node_link]) & (topo.node_s > 0) & (topo.node_s < 1)
    assert on.sum() >= 1
    first = topo.elem_link.index("follower")
    axis = geo.z_axis[:, first]
    q = ((loads[..., 0] + 1j * loads[..., 1]) * np.conj(1j * axis)[:, None]).real[:, on]
    L = scene.fourbar.length("follower")
    ls = quasi_static_stress(scene, ANGLES).links["follower"]
    x = np.r_[ls.s0, ls.s1[-1]] * L
    expected = _simply_supported(q, topo.node_s[on] * L, x, L)
    got = np.concatenate([ls.moment[:, :, 0], ls.moment[:, -1:, 1]], axis=1)
    peak = np.abs(expected).max()
    assert peak > 0.1
    sign = np.sign(np.sum(got * expected))  # the code's moment sign convention (hogging or sagging)
    np.testing.assert_allclose(sign * got, expected, atol=1e-9 * peak)


def test_four_bar_crank_is_a_cantilever_under_a_point_load_on_it():
    """A transverse point load P on the clamped crank only: coupler and follower cannot hold a force at A (the
    follower is a two-force member not through A), so M_root = P s L_crank (beam table cantilever)."""
    from ked_quasi.massmodel import lumps
    from ked_quasi.stress import four_bar_stress_from_loads
    from ked_quasi.structure import geometry, topology

    scene = _four_bar()
    topo = topology(lumps(scene.fourbar, scene.mass_model))
    geo = geometry(scene.fourbar, topo, ANGLES)
    k = next(i for i, (lk, s) in enumerate(zip(topo.node_link, topo.node_s)) if lk == "crank" and 0 < s < 1)
    s = float(topo.node_s[k])
    normal = 1j * geo.zA / np.abs(geo.zA)
    P = 100.0
    loads = np.zeros((ANGLES.size, topo.n_nodes, 2))
    loads[:, k, 0], loads[:, k, 1] = P * normal.real, P * normal.imag
    h = four_bar_stress_from_loads(scene, ANGLES, loads)
    Lc = scene.fourbar.length("crank")
    crank = h.links["crank"]
    np.testing.assert_allclose(np.abs(crank.moment[:, 0, 0]), P * s * Lc, rtol=1e-9)
    np.testing.assert_allclose(crank.moment[:, -1, 1], 0.0, atol=1e-9 * P * Lc)
    for lk in ("coupler", "extender", "follower"):
        np.testing.assert_allclose(h.links[lk].moment, 0.0, atol=1e-9 * P * Lc)
