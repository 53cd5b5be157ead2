"""Frozen-structure natural frequencies: Exudyn model vs ked_quasi.solver.natural_frequencies.

Expected values come from ked_quasi (flexibility method on the same lumps). The Exudyn model uses
the default discretization; in the lumped models its links are massless (tiny floor mass, see
exudyn_models.modal) so both models hold the same masses. "distributed" compares the beams'
consistent distributed mass with ked_quasi's 5 lumps per link: only the first two modes are compared.
"""

from __future__ import annotations

import numpy as np
import pytest

from exudyn_models import frozen_natural_frequencies
from ked_quasi.presets import make_scene
from ked_quasi.solver import natural_frequencies

ANGLES = np.radians([0.0, 100.0, 230.0])


@pytest.mark.parametrize("mechanism", ["source", "cognate"])
@pytest.mark.parametrize(("mass_model", "n_modes"), [("tip", 2), ("joints", 3), ("extender", 3), ("distributed", 2)])
def test_frozen_frequencies_match_ked_quasi(mass_model, n_modes, mechanism):
    scene = make_scene(mass_model=mass_model, mechanism_name=mechanism)
    expected = natural_frequencies(scene, n_modes=n_modes, crank_angle=ANGLES)
    got = frozen_natural_frequencies(scene, ANGLES, n_modes=n_modes)
    np.testing.assert_allclose(got, expected, rtol=0.01)
