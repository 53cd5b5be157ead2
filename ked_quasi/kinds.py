"""The linkage kinds of the scene model, one seam: each kind (four-bar, slider-crank) is one :class:`KindModel`, the
functions of its frozen structure, and a caller asks the scene's kind (``scene.kind``) for them instead of branching
on the scene's type.  A new kind is one more entry here and its own modules.

Each function takes the scene first: ``quasi_static(scene, crank_angle=None)`` (a result with ``deflection`` (n, 3)
[m, m, rad], ``loads`` and ``transmission_angle`` [rad]), ``natural_frequencies(scene, n_modes=3, crank_angle=None)``
((n, n_modes) [Hz] of the frozen structure), ``coupler_path(scene)`` ((n, 2) [m]: the rigid coupler point P over the
scene's grid), ``outputs(scene)`` (the quasi-static answer on the grid, (n, 3) dx, dy [m], rotation [rad] of P, and
the kind's further outputs as more columns: a slider-crank's midspan deflection [m]), ``stress(scene,
crank_angle=None)`` (:class:`ked_quasi.stress.StressHistory` of every link of the kind).

The linkage itself: ``scene_type`` (the scene class: ``scene_type(linkage, mass_model, rpm, step_deg)``),
``variant(source, mechanism, stiffness_scale, direction)`` (the linkage a scene analyses), ``read_linkage(d)`` (a
stored ``to_dict`` back, leniently: a four-bar that cannot turn a full cycle is read all the same, as stored
failed), ``mechanisms`` and ``mass_models`` (the names a grid may give it).

The generic entries :func:`quasi_static_outputs` and :func:`quasi_static_stress` take a scene of any kind;
:func:`of_linkage` gives a linkage's kind.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np


@dataclass(frozen=True)
class KindModel:
    """The frozen-structure functions of one linkage kind (see the module docstring)."""

    name: str
    quasi_static: Callable[..., Any]
    natural_frequencies: Callable[..., np.ndarray]
    coupler_path: Callable[[Any], np.ndarray]
    outputs: Callable[[Any], np.ndarray]
    stress: Callable[..., Any]
    scene_type: type
    variant: Callable[..., Any]
    read_linkage: Callable[[dict[str, Any]], Any]
    mechanisms: tuple[str, ...]
    mass_models: tuple[str, ...]


def _four_bar_path(scene: Any) -> np.ndarray:
    from .kinematics import coupler_point

    return np.asarray(coupler_point(scene.linkage, scene.crank_angles), dtype=float)


def _slider_path(scene: Any) -> np.ndarray:
    from .slidercrank import slider_kinematics

    return np.asarray(slider_kinematics(scene.linkage, scene.crank_angles, scene.rpm).P, dtype=float)


def _four_bar_outputs(scene: Any) -> np.ndarray:
    from .solver import solve_quasi_static

    return np.asarray(solve_quasi_static(scene).deflection)


def _slider_outputs(scene: Any) -> np.ndarray:
    from .slider_static import solve_slider_quasi_static

    res = solve_slider_quasi_static(scene)
    return np.column_stack([res.deflection, res.midspan])


def _read_four_bar(d: dict[str, Any]) -> Any:
    from .linkage import FourBar

    try:
        return FourBar.from_dict(d)
    except ValueError:  # stored as failed because it cannot assemble: read it all the same
        return FourBar.from_dict(d, full_turn=False)


@functools.cache
def models() -> dict[str, KindModel]:
    """Kind name -> its :class:`KindModel` (built on first use: the solvers load only then)."""
    from . import scene as four_bar
    from . import slidercrank
    from .cognates import MECHANISMS
    from .massmodel import MASS_MODELS
    from .slider_static import slider_natural_frequencies, solve_slider_quasi_static
    from .solver import natural_frequencies, solve_quasi_static
    from .stress import four_bar_stress, slider_stress

    return {four_bar.KIND: KindModel(four_bar.KIND, solve_quasi_static, natural_frequencies, _four_bar_path,
                                     _four_bar_outputs, four_bar_stress, four_bar.Scene, four_bar.variant,
                                     _read_four_bar, MECHANISMS, MASS_MODELS),
            slidercrank.KIND: KindModel(slidercrank.KIND, solve_slider_quasi_static, slider_natural_frequencies,
                                        _slider_path, _slider_outputs, slider_stress, slidercrank.SliderScene,
                                        slidercrank.slider_variant, slidercrank.SliderCrank.from_dict,
                                        slidercrank.MECHANISMS, slidercrank.SLIDER_MASS_MODELS)}


def model(scene: Any) -> KindModel:
    """The :class:`KindModel` of a scene's (or a linkage's) kind; ValueError naming the kinds for an unknown one."""
    return named(scene.kind)


def of_linkage(linkage: Any) -> KindModel:
    """The :class:`KindModel` of a linkage (``FourBar``, ``SliderCrank``: its ``kind``)."""
    return model(linkage)


def named(kind: str) -> KindModel:
    """The :class:`KindModel` of a kind's name (a stored ``kind`` attribute); ValueError naming the kinds."""
    kinds = models()
    if kind not in kinds:
        raise ValueError(f"linkage kind {kind!r} unknown; known: {', '.join(kinds)}")
    return kinds[kind]


def quasi_static_outputs(scene: Any) -> np.ndarray:
    """The quasi-static answer of a scene of any kind on its grid (columns: :attr:`KindModel.outputs`)."""
    return model(scene).outputs(scene)


def quasi_static_stress(scene: Any, crank_angle: np.ndarray | None = None) -> Any:
    """Quasi-static stress histories (:class:`ked_quasi.stress.StressHistory`) of a scene of any kind (default
    grid: its ``crank_angles``): the frozen structure's member forces under the d'Alembert loads -m a_rigid.
    Four-bar: crank, coupler, extender, follower; slider-crank: crank and coupler (the rod)."""
    return model(scene).stress(scene, crank_angle)


__all__ = ["KindModel", "model", "models", "named", "of_linkage", "quasi_static_outputs", "quasi_static_stress"]
