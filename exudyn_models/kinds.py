"""The linkage kinds of the Exudyn reference, one seam: each kind (four-bar, slider-crank) is one
:class:`ExudynKind`, and :func:`exudyn_models.simulate.simulate_steady_state` asks the scene's kind (``scene.kind``)
for it instead of branching on the scene's type.  A new kind is one more entry here and its own modules (as
:mod:`exudyn_models.fourbar_run` and :mod:`exudyn_models.slider_simulate`).

``run(scene, settings, damping_beta, stress)``: one run at fixed settings (a ``RunRecord``);
``check_settings(scene, settings)``: refuses (ValueError) what the kind's model does not take;
``reference_frequency(scene, settings)``: the damping reference frequency [Hz].
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class ExudynKind:
    """The Exudyn model's functions of one linkage kind (see the module docstring)."""

    name: str
    run: Callable[..., Any]
    check_settings: Callable[..., None]
    reference_frequency: Callable[..., float]


@functools.cache
def models() -> dict[str, ExudynKind]:
    """Kind name -> its :class:`ExudynKind` (built on first use)."""
    from ked_quasi import scene as four_bar
    from ked_quasi import slidercrank

    from .damping import reference_frequency
    from .fourbar_run import check_four_bar_settings, run_four_bar
    from .slider_builder import check_slider_settings
    from .slider_simulate import run_slider, slider_reference_frequency

    return {four_bar.KIND: ExudynKind(four_bar.KIND, run_four_bar, check_four_bar_settings, reference_frequency),
            slidercrank.KIND: ExudynKind(slidercrank.KIND, run_slider, check_slider_settings,
                                         slider_reference_frequency)}


def model(scene: Any) -> ExudynKind:
    """The :class:`ExudynKind` of a scene's linkage kind; ValueError naming the kinds for an unknown one."""
    kinds = models()
    if scene.kind not in kinds:
        raise ValueError(f"linkage kind {scene.kind!r} has no Exudyn model; known: {', '.join(kinds)}")
    return kinds[scene.kind]


__all__ = ["ExudynKind", "model", "models"]
