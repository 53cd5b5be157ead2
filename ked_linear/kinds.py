"""The linkage kinds of the linear model, one seam: each kind (four-bar, slider-crank) is one :class:`LinearKind`,
the functions of its linear time-periodic model, and the generic entries (:func:`linkage_system`,
``ked_linear.solve_linear``, ``ked_linear.stress.linear_stress``, ``ked_linear.size.elastic_size``) ask the scene's
kind (``scene.kind``) for them instead of branching on the scene's type.  A new kind is one more entry here and its
own module (as :mod:`ked_linear.fourbar` and :mod:`ked_linear.slider`).

Each function takes the scene first: ``system(scene, settings)`` (its periodic system and damping: ``.system``, a
:class:`~ked_linear.periodic.PeriodicSystem`), ``solve(scene, settings)`` (the periodic steady state and stability
on the scene's own lumps: a :class:`~ked_linear.result.LinearResult`), ``dynamic_stress(scene, settings, theta)``
(the link stresses of the masses' steady motion on the model that carries the dynamics,
:func:`ked_linear.lumping.dynamic_scene`), ``reduced_stability(scene, system, settings, reductions)`` (the reduced
system's Floquet result, or None where the full propagator decides), ``elastic_coordinates(scene)`` (the model's
size, counted without a frame solve).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from .settings import LinearSettings


@dataclass(frozen=True)
class LinearKind:
    """The linear model's functions of one linkage kind (see the module docstring)."""

    name: str
    system: Callable[..., Any]
    solve: Callable[..., Any]
    dynamic_stress: Callable[..., Any]
    reduced_stability: Callable[..., Any]
    elastic_coordinates: Callable[[Any], int]


@functools.cache
def models() -> dict[str, LinearKind]:
    """Kind name -> its :class:`LinearKind` (built on first use)."""
    from ked_quasi import scene as four_bar
    from ked_quasi import slidercrank

    from . import fourbar, slider

    return {four_bar.KIND: LinearKind(four_bar.KIND, fourbar.four_bar_system, fourbar.solve_four_bar,
                                      fourbar.dynamic_stress, fourbar.reduced_stability,
                                      fourbar.elastic_coordinates),
            slidercrank.KIND: LinearKind(slidercrank.KIND, slider.slider_system, slider.solve_slider_linear,
                                         slider.dynamic_stress, slider.reduced_stability,
                                         slider.elastic_coordinates)}


def model(scene: Any) -> LinearKind:
    """The :class:`LinearKind` of a scene's linkage kind; ValueError naming the kinds for an unknown one."""
    kinds = models()
    if scene.kind not in kinds:
        raise ValueError(f"linkage kind {scene.kind!r} has no linear model; known: {', '.join(kinds)}")
    return kinds[scene.kind]


def linkage_system(scene: Any, settings: LinearSettings, **options: Any) -> Any:
    """The linear KED equations of a scene of any kind: its periodic system (``.system``) and damping reference
    [Hz] and beta [s] (``.damping_reference_hz``, ``.damping_beta``).  ``options``: the kind's own (a four-bar's
    ``masses``: output every mass coordinate, :func:`ked_linear.linkage.four_bar_system`)."""
    return model(scene).system(scene, settings, **options)


__all__ = ["LinearKind", "linkage_system", "model", "models"]
