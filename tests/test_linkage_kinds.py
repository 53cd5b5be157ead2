"""The linkage kinds as one seam (:mod:`ked_quasi.kinds`): every scene type names its kind and linkage, and its
kind's model gives the frozen structure's functions a caller would otherwise pick by branching on the type.
Expected values: the kind's own functions called directly (a second path to the same numbers)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pytest

from ked_quasi import MassModel, SliderScene, kinds, simeon_slider_crank, thesis_fourbar
from ked_quasi.kinematics import coupler_point
from ked_quasi.scene import Scene
from ked_quasi.slider_static import slider_natural_frequencies, solve_slider_quasi_static
from ked_quasi.slidercrank import slider_kinematics
from ked_quasi.solver import natural_frequencies, solve_quasi_static


def _scenes():
    return [Scene(thesis_fourbar(), MassModel("tip", payload=0.5), 120.0, 30.0),
            SliderScene(simeon_slider_crank(), MassModel("distributed", lumps=4), 30 * 60 / (2 * math.pi), 30.0)]


def test_every_scene_type_names_its_kind_and_linkage():
    fb, sl = _scenes()
    assert (fb.kind, sl.kind) == ("four-bar", "slider-crank") and set(kinds.models()) == {fb.kind, sl.kind}
    assert fb.linkage is fb.fourbar and isinstance(sl.linkage, type(simeon_slider_crank()))


def test_each_kind_gives_its_own_functions():
    fb, sl = _scenes()
    np.testing.assert_array_equal(kinds.model(fb).coupler_path(fb), coupler_point(fb.fourbar, fb.crank_angles))
    np.testing.assert_array_equal(kinds.model(sl).coupler_path(sl),
                                  slider_kinematics(sl.linkage, sl.crank_angles, sl.rpm).P)
    np.testing.assert_array_equal(kinds.model(fb).quasi_static(fb).deflection, solve_quasi_static(fb).deflection)
    np.testing.assert_array_equal(kinds.model(sl).quasi_static(sl).deflection, solve_slider_quasi_static(sl).deflection)
    np.testing.assert_array_equal(kinds.model(fb).natural_frequencies(fb, n_modes=2),
                                  natural_frequencies(fb, n_modes=2))
    np.testing.assert_array_equal(kinds.model(sl).natural_frequencies(sl, n_modes=2),
                                  slider_natural_frequencies(sl, n_modes=2))


def test_an_unknown_kind_is_refused_naming_the_known_ones():
    @dataclass(frozen=True)
    class SixBar:
        kind: str = "six-bar"

    with pytest.raises(ValueError, match="six-bar.*four-bar, slider-crank"):
        kinds.model(SixBar())
