"""The linear time-periodic KED model of the slider-crank (ked_linear.slider): its frozen structure against
the quasi-static flexibility method, its low-speed limit, its prestress and its command line."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest
from click.testing import CliRunner

from ked_cli.main import cli
from ked_linear import LinearResult, LinearSettings, result_flags, solve_linear
from ked_linear.slider import axial_forces, condensed_slider, slider_frame, slider_frozen_frequencies
from ked_quasi.massmodel import MassModel
from ked_quasi.slider_static import (
    flexibility_at_masses,
    inertia_loads,
    node_positions,
    solve_slider_quasi_static,
    stiffness_deflections,
)
from ked_quasi.slidercrank import SliderScene, simeon_slider_crank, slider_kinematics, slider_lumps
from ked_quasi.units import rad_s_to_rpm


def elastic_crank(offset: float = 0.0):
    """Simeon's mechanism with an elastic crank (its nominal steel section) and an offset slider line."""
    return replace(simeon_slider_crank(), rigid=(False, False), offset=offset)


SCENES = [
    ("rigid crank, distributed", simeon_slider_crank(), MassModel("distributed", lumps=6)),
    ("rigid crank, joints", simeon_slider_crank(), MassModel("joints")),
    ("elastic crank, offset, distributed", elastic_crank(0.02), MassModel("distributed", lumps=4)),
    ("elastic crank, tip payload", elastic_crank(-0.01), MassModel("tip", payload=0.05)),
]


@pytest.mark.parametrize("name,sc,mm", SCENES, ids=[s[0] for s in SCENES])
def test_condensed_stiffness_is_the_inverse_of_the_quasi_static_flexibility(name, sc, mm):
    # Independent: ked_quasi's flexibility method (beta^T F beta, statically determinate) at the masses; the
    # linear model's direct-stiffness frame condensed on the coordinates that move must be its inverse.
    scene = SliderScene(sc, mm, rpm=1000.0, step_deg=30.0)
    theta = scene.crank_angles[::3]
    D, _ = flexibility_at_masses(scene, theta)
    moving = np.flatnonzero(np.any(D[0] != 0.0, axis=1))
    cs = condensed_slider(scene, theta)
    assert cs.stiffness.shape[1] == moving.size == slider_frame(scene).master.size
    K_from_D = np.linalg.inv(D[:, moving[:, None], moving])
    assert np.max(np.abs(cs.stiffness - K_from_D)) < 1e-9 * np.max(np.abs(K_from_D))


@pytest.mark.parametrize("name,sc,mm", SCENES, ids=[s[0] for s in SCENES])
def test_output_map_gives_the_quasi_static_deflection_of_p_and_the_midspan(name, sc, mm):
    # Independent: the direct-stiffness saddle-point solve of ked_quasi (stiffness_deflections) for P and the
    # flexibility method for the midspan; the linear model's output map applied to K^-1 f must give both.
    scene = SliderScene(sc, mm, rpm=1000.0, step_deg=30.0)
    cs = condensed_slider(scene)
    u = np.linalg.solve(cs.stiffness, cs.load[..., None])[..., 0]
    y = np.einsum("npk,nk->np", cs.output, u)
    qs = solve_slider_quasi_static(scene)
    full = stiffness_deflections(scene)
    p = qs.node_label.index("P") if "P" in qs.node_label else None
    ref_p = np.column_stack([qs.deflection[:, 0], qs.deflection[:, 1], full[:, -1]])
    if p is not None:
        np.testing.assert_allclose(ref_p[:, :2], full[:, [2 * p, 2 * p + 1]], atol=1e-9 * np.max(np.abs(ref_p)))
    # (a straight rod between a fixed A and a slider has no midspan deflection: scale by the translations)
    scale = np.max(np.abs(ref_p[:, :2]))
    for col, ref in ((slice(0, 2), ref_p[:, :2]), (slice(2, 3), ref_p[:, 2:]), (slice(3, 4), qs.midspan[:, None])):
        assert np.max(np.abs(y[:, col] - ref)) < 1e-8 * np.max(np.abs(ref)) + 1e-12 * scale


LOW_SPEED = [*SCENES[::2], ("elastic crank, offset, cw", replace(elastic_crank(0.02), direction="cw"),
                             MassModel("distributed", lumps=3))]


@pytest.mark.parametrize("name,sc,mm", LOW_SPEED, ids=[s[0] for s in LOW_SPEED])
def test_low_speed_limit_is_the_quasi_static_solution(name, sc, mm):
    # Limit: at r ~ 1e-3 the inertia of the elastic motion changes the answer by ~(k r)^2 and the damping by
    # ~2 zeta k r per crank harmonic k of the load (k <= 3 carry it): bound 6 zeta r; the quasi-static solver
    # is independent (flexibility method).
    scene = SliderScene(sc, mm, rpm=20.0, step_deg=10.0)
    res = solve_linear(scene, LinearSettings(damping_ratio=0.02, prestress=False))
    assert isinstance(res, LinearResult) and res.stable and res.speed_ratio < 2e-3
    bound = 6 * 0.02 * res.speed_ratio
    qs = solve_slider_quasi_static(scene)
    d = np.hypot(*(res.deflection[:, :2] - qs.deflection[:, :2]).T)
    assert np.max(d) < bound * np.max(np.hypot(qs.deflection[:, 0], qs.deflection[:, 1]))
    assert np.max(np.abs(res.midspan - qs.midspan)) < bound * np.max(np.abs(qs.midspan))
    assert result_flags(res, scene.linkage) == ()


def test_prestress_axial_force_at_the_slider_is_its_inertia_load():
    # Closed form: at crank angle 0 the rod lies on the slider line, B accelerates by -Omega^2 l1 (1 + l1/l2)
    # along x, so the rod element ending at B carries the slider's d'Alembert force m3 Omega^2 l1 (1 + l1/l2)
    # as tension (the slider's normal reaction has no axial part there).  At 180 deg B accelerates by
    # +Omega^2 l1 (1 - l1/l2): compression m3 Omega^2 l1 (1 - l1/l2).
    sc = simeon_slider_crank()
    scene = SliderScene(sc, MassModel("distributed", lumps=4), rpm=rad_s_to_rpm(150.0), step_deg=10.0)
    theta = np.array([0.0, np.pi])
    topo = slider_frame(scene).topology
    kin = slider_kinematics(sc, theta, scene.rpm)
    loads = inertia_loads(scene, topo, slider_lumps(sc, scene.mass_model), kin)
    N = axial_forces(scene, topo, node_positions(topo, kin), kin, loads)
    last = int(np.flatnonzero(np.array(topo.elem_link) == "coupler")[-1])
    w, l1, l2 = 150.0, sc.crank, sc.coupler
    expected = sc.slider_mass * w**2 * l1 * np.array([1 + l1 / l2, -(1 - l1 / l2)])
    np.testing.assert_allclose(N[:, last], expected, rtol=1e-12)
    # tension stiffens, compression softens the rod's first bending mode
    f0 = slider_frozen_frequencies(scene, theta, prestress=False)[:, 0]
    f1 = slider_frozen_frequencies(scene, theta, prestress=True)[:, 0]
    assert f1[0] > f0[0] and f1[1] < f0[1]


def test_frozen_frequency_is_the_pinned_pinned_rod():
    # Closed form: (pi / L)^2 sqrt(EI / (rho A)) = 1276.7 rad/s (data sheet); 48 midpoint lumps of the rod's
    # mass converge to it within 0.1 %; the slider moves only along its line, held stiffly by the rod's axial
    # stiffness.
    sc = simeon_slider_crank()
    rod = sc.section("coupler")
    scene = SliderScene(sc, MassModel("distributed", lumps=48), rpm=300.0, step_deg=45.0)
    f = slider_frozen_frequencies(scene)[:, 0]
    exact = (np.pi / sc.coupler) ** 2 * math.sqrt(rod.bending_stiffness / rod.mass_per_length) / (2 * np.pi)
    np.testing.assert_allclose(f, exact, rtol=1e-3)


def test_linkage_system_dispatches_a_slider_crank():
    from ked_linear import linkage_system

    scene = SliderScene(simeon_slider_crank(), MassModel("distributed", lumps=4), rpm=300.0, step_deg=30.0)
    ls = linkage_system(scene, LinearSettings(damping_reference_hz=200.0))
    # 4 rod lumps (x, y) and the slider along its line; outputs dx, dy, rotation, midspan
    assert ls.system.mass.size == 9 and ls.damping_reference_hz == 200.0
    assert ls.system.coefficients(scene.crank_angles).output.shape == (12, 4, 9)


def test_rigid_coupler_is_refused_in_one_line():
    sc = replace(simeon_slider_crank(), rigid=(False, True))
    with pytest.raises(ValueError, match="elastic coupler"):
        solve_linear(SliderScene(sc, MassModel("distributed"), rpm=300.0))


def test_four_bar_path_unchanged_by_the_dispatch():
    # Regression pin: the four-bar still goes through the four-bar model (no midspan, its own output).
    from ked_quasi.linkage import thesis_fourbar
    from ked_quasi.scene import build_scene

    res = solve_linear(build_scene(thesis_fourbar(), "source", "joints", 100.0, 10.0))
    assert type(res) is LinearResult and res.stable


def test_cli_linear_takes_the_simeon_preset():
    runner = CliRunner()
    res = runner.invoke(cli, ["linear", "--linkage", "simeon", "--rpm", "1432.4", "--step-deg", "30", "--json"])
    assert res.exit_code == 0, res.output
    out = json.loads(res.output)
    for key in ("crank_angle_deg", "dx_m", "dy_m", "rotation_rad", "floquet_max_abs", "stable", "flags", "valid",
                "midspan_m", "speed_ratio", "status"):
        assert key in out
    assert out["stable"] and out["valid"] and len(out["midspan_m"]) == 12
    # r = 150 rad/s over the rod's first bending frequency with 5 lumps of its mass (data sheet: 0.1175)
    assert out["speed_ratio"] == pytest.approx(0.1175, rel=0.01)
    table = runner.invoke(cli, ["linear", "--linkage", "simeon", "--rpm", "1432.4", "--step-deg", "45"])
    assert table.exit_code == 0 and "mid mm" in table.output and "distributed" in table.output
    assert max(len(line) for line in table.output.splitlines()) <= 100
    bad = runner.invoke(cli, ["linear", "--linkage", "simeon", "--mechanism", "cognate"])
    assert bad.exit_code == 2 and "cognate" in bad.output and "Traceback" not in bad.output
