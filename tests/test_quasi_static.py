"""The quasi-static flexibility solver against independent methods and closed-form physics."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest
from click.testing import CliRunner

from ked_cli.main import cli as main
from ked_quasi import FourBar, MassModel, Scene, Section, natural_frequencies, solve_quasi_static
from ked_quasi.massmodel import lumps
from ked_quasi.solver import ToggleWarning, flexibility_at_masses
from ked_quasi.stiffness import stiffness_deflections
from ked_quasi.structure import geometry, topology

from .conftest import MASS_MODEL_CASES, random_fourbars


def _flex_all(res):
    n = res.crank_angle.size
    return np.concatenate([res.node_deflection.reshape(n, -1), res.deflection[:, 2:3]], axis=1)


@pytest.mark.parametrize("mm", list(MASS_MODEL_CASES))
@pytest.mark.parametrize("mech", ["thesis", "thesis_cognate"])
def test_flexibility_equals_direct_stiffness_thesis(mm, mech, request):
    # independent method: direct-stiffness frame model of the same frozen structure (ked_quasi.stiffness)
    fb = request.getfixturevalue(mech)
    scene = Scene(fb, MASS_MODEL_CASES[mm], rpm=300.0, step_deg=5.0)
    flex = _flex_all(solve_quasi_static(scene))
    stiff = stiffness_deflections(scene)
    assert np.abs(flex - stiff).max() <= 1e-9 * np.abs(stiff).max()


@pytest.mark.parametrize("fb", random_fourbars(5, seed=11))
@pytest.mark.parametrize("mm", list(MASS_MODEL_CASES))
def test_flexibility_equals_direct_stiffness_random(fb, mm):
    scene = Scene(fb, MASS_MODEL_CASES[mm], rpm=500.0, step_deg=15.0)
    flex = _flex_all(solve_quasi_static(scene))
    stiff = stiffness_deflections(scene)
    assert np.abs(flex - stiff).max() <= 1e-9 * np.abs(stiff).max()


def test_tip_load_on_cantilevered_extender_closed_form():
    # crank, coupler and follower (nearly) rigid: the extender is a cantilever clamped at A, so the
    # flexibility at P is Euler-Bernoulli closed form: P L^3/(3EI) across AP and P L/(EA) along it
    rigid = Section(1e17, 1.0, 1.0, 1.0)
    ext = Section(70e9, 1e-4, 2e-9, 2700)
    fb = FourBar(crank=0.1, coupler=0.4, follower=0.35, extender=0.3, coupler_angle=0.0,
                 sections=(rigid, rigid, ext, rigid), follower_pivot=(0.4, 0.0))
    scene = Scene(fb, MassModel("tip", payload=1.0), rpm=100.0)
    theta = np.array([1.0])
    D, _ = flexibility_at_masses(scene, theta)
    geo = geometry(fb, topology(lumps(fb, scene.mass_model)), theta)
    e = geo.elem_axis[0, [i for i, lk in enumerate(topology(lumps(fb, scene.mass_model)).elem_link)
                          if lk == "extender"][0]]
    n = np.array([-e[1], e[0]])
    L, EI, EA = 0.3, 70e9 * 2e-9, 70e9 * 1e-4
    assert n @ D[0] @ n == pytest.approx(L**3 / (3 * EI), rel=1e-9)
    assert e @ D[0] @ e == pytest.approx(L / EA, rel=1e-6)


@pytest.mark.parametrize("mm", list(MASS_MODEL_CASES))
def test_deflection_scales_with_rpm_squared_and_inverse_E(thesis, mm):
    base = solve_quasi_static(Scene(thesis, MASS_MODEL_CASES[mm], 300.0, 10.0)).deflection
    fast = solve_quasi_static(Scene(thesis, MASS_MODEL_CASES[mm], 450.0, 10.0)).deflection
    stiff = solve_quasi_static(Scene(thesis.with_stiffness_scale(7.0), MASS_MODEL_CASES[mm], 300.0, 10.0)).deflection
    assert np.allclose(fast, base * 1.5**2, rtol=1e-12, atol=0)
    assert np.allclose(stiff, base / 7.0, rtol=1e-12, atol=0)


def test_dalembert_sign_points_against_acceleration(thesis):
    # P = -m a: the load on the tip mass is opposite to the acceleration of P
    from ked_quasi import kinematics
    scene = Scene(thesis, MASS_MODEL_CASES["tip"], 300.0, 30.0)
    res = solve_quasi_static(scene)
    aP = kinematics(thesis, scene.crank_angles, 300.0).aP
    p = res.node_label.index("P")
    assert np.allclose(res.loads[:, p], -scene.mass_model.payload * aP)


def test_direction_does_not_change_quasi_static(thesis):
    a = solve_quasi_static(Scene(thesis, MASS_MODEL_CASES["joints"], 300.0, 10.0)).deflection
    b = solve_quasi_static(Scene(thesis.with_direction("cw"), MASS_MODEL_CASES["joints"], 300.0, 10.0)).deflection
    assert np.allclose(a, b, rtol=1e-12, atol=1e-18)


def test_natural_frequency_of_a_tip_mass_on_a_cantilever_closed_form():
    # crank, coupler and follower (nearly) rigid, a point mass m at the tip of the extender (a cantilever
    # clamped at A): the two modes are the Euler-Bernoulli closed forms sqrt(3EI/(m L^3)) across AP and
    # sqrt(EA/(m L)) along it
    rigid = Section(1e17, 1.0, 1.0, 1.0)
    ext = Section(70e9, 1e-4, 2e-9, 2700)
    fb = FourBar(crank=0.1, coupler=0.4, follower=0.35, extender=0.3, coupler_angle=0.0,
                 sections=(rigid, rigid, ext, rigid), follower_pivot=(0.4, 0.0))
    m, L = 1.0, 0.3
    f = natural_frequencies(Scene(fb, MassModel("tip", payload=m), rpm=100.0, step_deg=30.0), n_modes=3)
    bending = np.sqrt(3 * 70e9 * 2e-9 / (m * L**3)) / (2 * np.pi)
    axial = np.sqrt(70e9 * 1e-4 / (m * L)) / (2 * np.pi)
    assert np.allclose(f[:, 0], bending, rtol=1e-6) and np.allclose(f[:, 1], axial, rtol=1e-6)
    assert np.isnan(f[:, 2]).all()  # a single point mass has two modes only


@pytest.mark.parametrize("mm", list(MASS_MODEL_CASES))
def test_natural_frequencies_match_the_stiffness_model(thesis_cognate, mm):
    # independent: the flexibility from unit-load solves of the direct-stiffness frame model
    # (ked_quasi.stiffness), eigenvalues of (D M)^-1 by a general (non-symmetric) solver
    from ked_quasi.stiffness import unit_load_flexibility

    scene = Scene(thesis_cognate, MASS_MODEL_CASES[mm], 300.0, 45.0)
    D, m = unit_load_flexibility(scene)
    f = natural_frequencies(scene, n_modes=3)
    k = min(3, len(m))
    for i in range(D.shape[0]):
        w2 = np.sort(np.linalg.eigvals(np.linalg.inv(D[i] * m[None, :])).real)[:k]
        assert np.allclose(f[i, :k], np.sqrt(w2) / (2 * np.pi), rtol=1e-8)


def test_flexibility_at_masses_matches_unit_load_solves(thesis):
    # the flexibility method's condensed flexibility against the stiffness model's unit-load solves
    from ked_quasi.stiffness import unit_load_flexibility

    scene = Scene(thesis, MASS_MODEL_CASES["distributed"], 300.0, 30.0)
    D, m = flexibility_at_masses(scene)
    D2, m2 = unit_load_flexibility(scene)
    assert np.array_equal(m, m2)
    assert np.abs(D - D2).max() <= 1e-9 * np.abs(D2).max()


def test_near_toggle_is_flagged_not_silent():
    # a crank-rocker at the Grashof boundary: coupler + follower = ground + crank -> toggle at theta = 180 deg
    sec = Section(70e9, 1e-4, 1e-9, 2700)
    fb = FourBar(crank=0.1, coupler=0.3, follower=0.3, extender=0.1, coupler_angle=0.5, sections=(sec,) * 4,
                 follower_pivot=(0.5, 0.0), check_toggle=False)  # every loader refuses it; the solver must flag it
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = solve_quasi_static(Scene(fb, MassModel("joints"), 300.0, 10.0))
    assert any(issubclass(w.category, ToggleWarning) for w in caught)
    i180 = 18
    assert res.flagged[i180]
    assert not res.flagged[0]
    assert np.isfinite(res.deflection[~res.flagged]).all()
    assert res.condition[i180] > 1e3
    assert np.degrees(res.transmission_angle[i180]) > 179 or np.degrees(res.transmission_angle[i180]) < 1


def test_cli_quasi_json_contract():
    out = CliRunner().invoke(main, ["quasi", "--linkage", "thesis", "--mechanism", "cognate", "--mass-model",
                                    "extender", "--rpm", "300", "--step-deg", "30", "--json"])
    assert out.exit_code == 0, out.output
    d = json.loads(out.output)
    for key in ("crank_angle_deg", "dx_m", "dy_m", "rotation_rad", "f1_hz"):
        assert len(d[key]) == 12
    assert d["crank_angle_deg"][1] == pytest.approx(30.0)


@pytest.mark.parametrize("args, word", [(["--mass-model", "lumpy"], "mass-model"), (["--rpm", "-3"], "rpm"),
                                        (["--step-deg", "7"], "step-deg"), (["--rpm", "nan"], "rpm")])
def test_cli_quasi_bad_input(args, word):
    out = CliRunner().invoke(main, ["quasi", *args])
    assert out.exit_code != 0
    assert word in out.output


@pytest.mark.parametrize("mm", list(MASS_MODEL_CASES))
def test_matrix_free_statics_equal_explicit_beta(thesis_cognate, mm):
    # the solver's matrix-free f = beta P and delta = beta^T d must equal the explicit force transformation
    from ked_quasi.solver import inertia_loads
    from ked_quasi.structure import (
        element_flexibility,
        element_forces,
        force_transformation,
        geometry,
        nodal_deflections,
        system_flexibility,
    )
    scene = Scene(thesis_cognate, MASS_MODEL_CASES[mm], 300.0, 20.0)
    lm = lumps(thesis_cognate, scene.mass_model)
    topo = topology(lm)
    geo = geometry(thesis_cognate, topo, scene.crank_angles)
    beta = force_transformation(topo, geo)
    loads = inertia_loads(scene, topo, lm, scene.crank_angles)
    P = np.concatenate([loads.reshape(loads.shape[0], -1), np.full((loads.shape[0], 1), 3.0)], axis=1)
    f_explicit = np.einsum("amd,ad->am", beta, P)
    f_free = element_forces(topo, geo, loads, np.full(loads.shape[0], 3.0)).reshape(loads.shape[0], -1)
    assert np.allclose(f_free, f_explicit, rtol=0, atol=1e-12 * np.abs(f_explicit).max())
    delta_explicit = np.einsum("amd,ad->am", system_flexibility(element_flexibility(thesis_cognate, topo), beta), P)
    F = element_flexibility(thesis_cognate, topo)
    nodes, rot = nodal_deflections(topo, geo, (F @ f_free.reshape(*loads.shape[:1], -1, 3)[..., None])[..., 0])
    delta_free = np.concatenate([nodes.reshape(loads.shape[0], -1), rot[:, None]], axis=1)
    assert np.allclose(delta_free, delta_explicit, rtol=0, atol=1e-12 * np.abs(delta_explicit).max())
