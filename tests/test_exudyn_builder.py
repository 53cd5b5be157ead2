"""exudyn_models builder inventory, input validation and failure reporting."""

from __future__ import annotations

import exudyn as exu
import numpy as np
import pytest

from exudyn_models import DynamicSettings, SimulationError, build_model, simulate_steady_state
from ked_quasi.massmodel import lumps
from ked_quasi.presets import make_scene


def _inventory(model) -> dict[str, int]:
    """Count of Exudyn objects (by type name) and nodes (by "node " + type name)."""
    mbs, sd = model.mbs, model.mbs.systemData
    out: dict[str, int] = {}
    for t in [mbs.GetObject(i)["objectType"] for i in range(sd.NumberOfObjects())] + \
             ["node " + mbs.GetNode(i)["nodeType"] for i in range(sd.NumberOfNodes())]:
        out[t] = out.get(t, 0) + 1
    return out


def _dense(matrix) -> np.ndarray:
    return np.asarray(matrix.Convert2DenseMatrix() if hasattr(matrix, "Convert2DenseMatrix") else matrix)


def _beam_mass(model) -> list[float]:
    mbs = model.mbs
    return [mbs.GetObjectParameter(o, "massPerLength") for els in model.link_elements.values() for o in els]


@pytest.mark.parametrize("element", ["ancf", "gebeam"])
@pytest.mark.parametrize("mass_model", ["tip", "joints", "extender", "distributed"])
def test_model_holds_only_what_the_scene_needs(mass_model, element):
    scene = make_scene(mass_model=mass_model)
    n = 3
    model = build_model(scene, DynamicSettings(element=element, elements_per_link=n), damping_beta=0.0)
    inv = _inventory(model)
    beam = "ANCFCable2D" if element == "ancf" else "BeamGeometricallyExact2D"
    assert inv[beam] == 4 * n
    assert model.mbs.systemData.NumberOfSensors() == 1  # only the P sensor
    assert model.mbs.systemData.NumberOfLoads() == 0  # inertia only: no gravity, no forces
    # joints: 2 revolute (A, B), 2 generic (crank clamp, extender), 2 + 3 coordinate constraints (Q, hub)
    assert inv["JointRevolute2D"] == 2 and inv["JointGeneric"] == 2 and inv["ConnectorCoordinate"] == 5
    assert inv["RigidBody2D"] == 1  # the drive hub
    assert inv["node PointGround"] == 1 and "MassPoint2D" not in inv
    node = "node Point2DSlope1" if element == "ancf" else "node RigidBody2D"
    assert inv[node] == 4 * (n + 1) + (element == "gebeam")  # + the hub node for gebeam
    n_point_masses = inv.get("GenericODE2", 0)
    if mass_model == "distributed":
        assert n_point_masses == 0  # default thesis scene: no payload, the beams carry the mass
        assert all(m > 0 for m in _beam_mass(model))
    else:
        assert all(m == 0 for m in _beam_mass(model))  # massless links, the mass is in the lumps
        lp = lumps(scene.fourbar, scene.mass_model)
        assert n_point_masses >= 1
        k = 4 if element == "ancf" else 3  # node coordinates (x, y, x', y') or (x, y, phi)
        # the x-position rows/columns of each lump's m S^T S add up to m (partition of unity)
        total = sum(np.sum(_dense(model.mbs.GetObjectParameter(o, "massMatrix"))[0::k, 0::k])
                    for o in model.mass_objects)
        assert total == pytest.approx(lp.total_mass, rel=1e-12)
    if mass_model == "tip":
        assert n_point_masses == 1


def test_no_files_written(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    scene = make_scene(mass_model="extender", rpm=300.0, step_deg=30.0)
    simulate_steady_state(scene, DynamicSettings(steps_per_cycle=72, max_cycles=2, min_cycles=1))
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(("field", "value"), [
    ("element", "shell"), ("elements_per_link", 0), ("elements_per_link", -2), ("steps_per_cycle", 0),
    ("steps_per_cycle", -10), ("max_cycles", 0), ("spectral_radius", 1.5), ("damping_ratio", -0.1),
    ("damping_reference_hz", 0.0), ("ramp_cycles", 0.0), ("steady_tol", 0.0),
])
def test_bad_settings_raise_value_error_naming_the_parameter(field, value):
    with pytest.raises(ValueError, match=field):
        DynamicSettings(**{field: value})


def test_newton_failure_raises_simulation_error_with_time_and_crank_angle():
    """An unreachable Newton tolerance with one iteration per step fails in the first step."""
    scene = make_scene(mass_model="extender")
    settings = DynamicSettings(
        newton_abs_tol=1e-30, newton_rel_tol=1e-30, newton_max_iterations=1, refine=False
    )
    with pytest.raises(SimulationError, match=r"t = .* s, crank angle = .* deg") as info:
        simulate_steady_state(scene, settings)
    assert 0.0 < info.value.time < 0.05
    assert 0.0 <= info.value.crank_angle < 2 * np.pi


def test_frozen_model_has_no_drive_and_exudyn_types():
    scene = make_scene(mass_model="joints")
    model = build_model(scene, frozen_angle=0.5, damping_beta=0.0)
    assert model.drive is None and model.start_angle == 0.5
    assert isinstance(model.mbs, exu.MainSystem)
