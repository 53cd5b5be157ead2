"""Section forces read from the Exudyn beam elements against the cantilever beam table.

A cantilever of length L clamped at x = 0 with a transverse tip load P carries M(x) = P (L - x) and N = 0
(beam table; geometrically linear: the tip deflection is ~1e-3 L); an axial tip load P gives N = P, M = 0.
"""

from __future__ import annotations

import exudyn as exu
import exudyn.itemInterface as eii
import numpy as np
import pytest
from exudyn.beams import GenerateBeamElementsAlongLine

from exudyn_models.builder import beam_template
from exudyn_models.sections import section_forces
from ked_quasi.linkage import THESIS_SECTION

L = 0.762  # [m] the thesis coupler length


def _solve(element: str, load: list[float], n_el: int = 4):
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    clamp = [1, 1, 0, 1] if element == "ancf" else [1, 1, 1]
    created = GenerateBeamElementsAlongLine(mbs, [0, 0, 0], [L, 0, 0], n_el,
                                            beam_template(element, THESIS_SECTION, 0.0, 0.0),
                                            groundConstraintsStart=clamp)
    marker = mbs.AddMarker(eii.MarkerNodePosition(nodeNumber=created["nodes"][-1]))
    mbs.AddLoad(eii.LoadForceVector(markerNumber=marker, loadVector=[*load, 0.0]))
    mbs.Assemble()
    sset = exu.SimulationSettings()
    sset.staticSolver.verboseMode = 0
    mbs.SolveStatic(sset)
    return section_forces(mbs, element, list(created["elements"]), L / n_el)


@pytest.mark.parametrize("element", ["ancf", "gebeam"])
def test_cantilever_moment_is_the_beam_table(element):
    P = 1.0
    s, N, M = _solve(element, [0.0, P])
    np.testing.assert_allclose(np.abs(M), P * L * (1 - s), rtol=2e-3, atol=1e-6)
    # N = 0 up to the elements' second-order coupling of rotation and stretch (EA theta^2 ~ 1 N here): as a
    # stress, below 1 % of the peak bending stress M c / I
    sec = THESIS_SECTION
    assert np.abs(N).max() / sec.area < 1e-2 * P * L * sec.extreme_fibre / sec.second_moment
    assert s.size == (8 if element == "ancf" else 4)


@pytest.mark.parametrize("element", ["ancf", "gebeam"])
def test_axial_tip_load_is_the_axial_force(element):
    P = 100.0
    _, N, M = _solve(element, [P, 0.0])
    np.testing.assert_allclose(N, P, rtol=1e-6)
    assert np.abs(M).max() < 1e-9 * P * L


def test_unknown_element_refused():
    with pytest.raises(ValueError, match="element"):
        section_forces(None, "shell", [], 1.0)
