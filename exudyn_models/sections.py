"""Section forces of the Exudyn beam elements in their current state: axial force N and bending moment M.

Read from the elements' own outputs (``GetObjectOutputBody`` with ``OutputVariableType.ForceLocal`` and
``TorqueLocal`` at a local position), not recomputed from nodal coordinates:

* ``ancf`` (ObjectANCFCable2D, cubic Hermite): curvature, hence M = EI kappa, varies linearly along an
  element, so M at both element ends describes it; N = EA (axial strain) at the same points.
* ``gebeam`` (ObjectBeamGeometricallyExact2D, linear interpolation): the strains and curvature are constant
  per element (its output is the same at any local position), so the moment it reports is the element's mean:
  it is attributed to the element's midpoint (a linear moment is exact there).

Moments carry Exudyn's sign (counterclockwise curvature of the element's reference axis positive); forces
in N, moments in N m.  Free of I/O and of the CLI.
"""

from __future__ import annotations

import exudyn as exu
import numpy as np

ELEMENTS = ("ancf", "gebeam")


def _scalar(value: object, k: int) -> float:
    v = np.atleast_1d(np.asarray(value, dtype=float))
    return float(v[k] if v.size > 1 else v[0])


def section_forces(mbs: exu.MainSystem, element: str, objects: list[int], length: float) -> tuple[
        np.ndarray, np.ndarray, np.ndarray]:
    """(s, N, M) of one link's chain of beam ``objects`` (from its root, each of length ``length`` [m]) of kind
    ``element`` (one of :data:`ELEMENTS`): s the sampling points as fractions of the chain (both ends of every
    ANCF element; every geometrically exact element's midpoint), N [N] (tension > 0) and M [N m] there."""
    if element not in ELEMENTS:
        raise ValueError(f"element: must be one of {', '.join(ELEMENTS)}; got {element!r}")
    n = len(objects)
    local = (0.0, length) if element == "ancf" else (0.5 * length,)
    s, axial, moment = [], [], []
    for i, obj in enumerate(objects):
        for x in local:
            pos = [x, 0.0, 0.0]
            f = mbs.GetObjectOutputBody(obj, exu.OutputVariableType.ForceLocal, localPosition=pos)
            m = mbs.GetObjectOutputBody(obj, exu.OutputVariableType.TorqueLocal, localPosition=pos)
            s.append((i + x / length) / n)
            axial.append(_scalar(f, 0))
            moment.append(_scalar(m, 2))
    return np.array(s), np.array(axial), np.array(moment)


def element_forces(mbs: exu.MainSystem, element: str, objects: list[int], length: float) -> tuple[
        np.ndarray, np.ndarray]:
    """(N (E,), M (E, 2)) of one link's chain of beam ``objects`` (each of length ``length`` [m]): N [N] at each
    element's midpoint (exact for the ANCF element's linear axial force: its mean), M [N m] at its inner and
    outer end (ANCF; a geometrically exact element's constant moment at both)."""
    if element not in ELEMENTS:
        raise ValueError(f"element: must be one of {', '.join(ELEMENTS)}; got {element!r}")
    force, torque = exu.OutputVariableType.ForceLocal, exu.OutputVariableType.TorqueLocal
    ends = (0.0, length) if element == "ancf" else (0.5 * length, 0.5 * length)
    axial = np.empty(len(objects))
    moment = np.empty((len(objects), 2))
    for i, obj in enumerate(objects):
        axial[i] = _scalar(mbs.GetObjectOutputBody(obj, force, localPosition=[0.5 * length, 0.0, 0.0]), 0)
        for k, x in enumerate(ends):
            moment[i, k] = _scalar(mbs.GetObjectOutputBody(obj, torque, localPosition=[x, 0.0, 0.0]), 2)
    return axial, moment


__all__ = ["ELEMENTS", "element_forces", "section_forces"]
