"""Exudyn beam elements as used by exudyn_models: static tip load and damping mapping.

Expected values: closed-form Euler-Bernoulli / Timoshenko cantilever deflection and the
stiffness-proportional damping law zeta = beta * omega / 2 (exudyn_models.damping).
"""

from __future__ import annotations

import math

import exudyn as exu
import exudyn.itemInterface as eii
import numpy as np
import pytest
from exudyn.beams import GenerateBeamElementsAlongLine

from exudyn_models.builder import POISSON_RATIO, SHEAR_CORRECTION, beam_template
from exudyn_models.damping import modal_damping_ratio, rayleigh_beta
from ked_quasi.linkage import THESIS_SECTION

L = 0.762  # [m] the thesis coupler length, 30 in


def _cantilever(element: str, n_el: int, mass_per_length: float = 0.0, beta: float = 0.0):
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    clamp = [1, 1, 0, 1] if element == "ancf" else [1, 1, 1]  # ANCF: x, y and slope_y (tangent along x)
    created = GenerateBeamElementsAlongLine(mbs, [0, 0, 0], [L, 0, 0], n_el,
                                            beam_template(element, THESIS_SECTION, mass_per_length, beta),
                                            groundConstraintsStart=clamp)
    tip = created["nodes"][-1]
    marker = mbs.AddMarker(eii.MarkerNodePosition(nodeNumber=tip))
    return SC, mbs, tip, marker


@pytest.mark.parametrize("element", ["ancf", "gebeam"])
def test_cantilever_tip_load_matches_closed_form(element):
    """delta = P L^3 / (3 E I) (+ P L / (k G A) shear for the geometrically exact beam), within 0.5 %."""
    P = 1.0  # [N], deflection ~ 2 mm: geometrically linear
    # linear geometrically exact elements converge as 1/n^2 (1.6 % at 4 elements), cubic ANCF is exact
    SC, mbs, tip, marker = _cantilever(element, 4 if element == "ancf" else 16)
    mbs.AddLoad(eii.LoadForceVector(markerNumber=marker, loadVector=[0, -P, 0]))
    mbs.Assemble()
    sset = exu.SimulationSettings()
    sset.solution.file.write = False
    sset.staticSolver.newton.absoluteTolerance = 1e-12
    mbs.SolveStatic(sset)
    y = mbs.GetNodeOutput(tip, exu.OutputVariableType.Displacement)[1]
    E, A, I = THESIS_SECTION.youngs_modulus, THESIS_SECTION.area, THESIS_SECTION.second_moment
    expected = P * L**3 / (3 * E * I)
    if element == "gebeam":
        expected += P * L / (SHEAR_CORRECTION * E / (2 * (1 + POISSON_RATIO)) * A)
    assert -y == pytest.approx(expected, rel=5e-3)


def test_damping_ratio_from_free_vibration_log_decrement():
    """Free vibration of an ANCF cantilever with zeta = 0.05 imposed at its first natural frequency:
    the log decrement of the tip deflection gives zeta back within 3 % (stiffness-proportional
    damping, exudyn_models.damping; the reference frequency is the model's own f1)."""
    zeta = 0.05
    mu = THESIS_SECTION.mass_per_length
    # f1 of the undamped model (Exudyn eigenvalues, constraints projected out)
    _, mbs0, _, _ = _cantilever("ancf", 4, mu)
    mbs0.Assemble()
    f, _ = mbs0.ComputeODE2Eigenvalues(convert2Frequencies=True)
    f1 = float(np.sort(f)[0])
    E, I = THESIS_SECTION.youngs_modulus, THESIS_SECTION.second_moment
    assert f1 == pytest.approx(1.875104**2 / (2 * math.pi) * math.sqrt(E * I / (mu * L**4)), rel=1e-2)

    beta = rayleigh_beta(zeta, f1)
    assert modal_damping_ratio(beta, f1) == pytest.approx(zeta)
    SC, mbs, tip, marker = _cantilever("ancf", 4, mu, beta)
    load = mbs.AddLoad(eii.LoadForceVector(markerNumber=marker, loadVector=[0, -1.0, 0]))
    sensor = mbs.AddSensor(eii.SensorNode(nodeNumber=tip, outputVariableType=exu.OutputVariableType.Displacement,
                                          storeInternal=True, writeToFile=False))
    mbs.Assemble()
    sset = exu.SimulationSettings()
    sset.solution.file.write = False
    mbs.SolveStatic(sset)  # deflected by the tip load, then released
    mbs.SetLoadParameter(load, "loadVector", [0, 0, 0])
    mbs.systemData.SetSystemState(mbs.systemData.GetSystemState(exu.ConfigurationType.Current),
                                  exu.ConfigurationType.Initial)
    n_per_period, periods = 200, 6
    sset.timeIntegration.endTime = periods / f1
    sset.timeIntegration.numberOfSteps = n_per_period * periods
    sset.timeIntegration.generalizedAlpha.spectralRadius = 1.0  # no numerical damping
    sset.timeIntegration.adaptiveStep = False
    sset.timeIntegration.verboseMode = 0
    sset.timeIntegration.newton.absoluteTolerance = 1e-6
    sset.solution.sensors.writePeriod = 0.5 / (n_per_period * f1)
    mbs.SolveDynamic(sset)
    y = mbs.GetSensorStoredData(sensor)[:, 2]
    # successive negative peaks (release from a downward deflection)
    peaks = [-y[i] for i in range(1, len(y) - 1) if y[i] < y[i - 1] and y[i] <= y[i + 1] and y[i] < 0]
    assert len(peaks) >= 4
    delta = math.log(peaks[1] / peaks[3]) / 2.0  # skip the first cycle (higher modes die out)
    measured = delta / math.sqrt(4 * math.pi**2 + delta**2)
    assert measured == pytest.approx(zeta, rel=0.03)
