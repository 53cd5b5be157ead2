"""Quasi-static KED solver: the thesis's flexibility method, corrected and general.

At each crank angle the linkage is frozen (see :mod:`ked_quasi.structure`), loaded by the
d'Alembert inertia forces P = -m a of its lumped masses (rigid-body accelerations at constant crank
speed), and the elastic deflection of every node follows from delta = beta^T F beta P.  Vectorized
over crank angles.  Natural frequencies of the frozen structure follow from the flexibility matrix
condensed onto the mass coordinates.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from .kinematics import Loop, acceleration_field, loop
from .linkage import LINKS
from .massmodel import Lumps, lumps
from .scene import Scene
from .structure import (
    Geometry,
    Topology,
    element_deformations,
    element_flexibility,
    element_forces,
    force_transformation,
    geometry,
    nodal_deflections,
    system_flexibility,
    topology,
)

#: an angle is flagged when the transmission angle is within this of 0 or 180 deg (toggle)
TOGGLE_TOLERANCE_DEG = 1.0


class ToggleWarning(UserWarning):
    """The frozen structure is singular or nearly so (transmission angle near 0 or 180 deg)."""


@dataclass(frozen=True)
class QuasiStaticResult:
    """Quasi-static elastic deflections over the scene's crank-angle grid.

    crank_angle (n,) [rad]; deflection (n, 3): dx, dy [m] (global frame) and rotation [rad, CCW] of P;
    node_deflection (n, N, 2) [m] at every structural node (labels in node_label); loads (n, N, 2)
    d'Alembert forces [N]; transmission_angle (n,) [rad]; condition (n,) = 1/|sin(transmission angle)|
    (the amplification of the pin-force solve); flagged (n,) near-toggle angles (values there are
    ill-conditioned; exactly singular ones are NaN).
    """

    crank_angle: np.ndarray
    deflection: np.ndarray
    node_label: tuple[str, ...]
    node_deflection: np.ndarray
    loads: np.ndarray
    transmission_angle: np.ndarray
    condition: np.ndarray
    flagged: np.ndarray


def node_masses(topo: Topology, lm: Lumps) -> np.ndarray:
    """Mass [kg] at each structural node (lumps at the same node add up)."""
    mass = np.zeros(topo.n_nodes)
    for lk, s, m in zip(lm.link, lm.s, lm.mass):
        mass[topo.node_of(lk, float(s))] += m
    return mass


def inertia_loads(scene: Scene, topo: Topology, lm: Lumps, crank_angle: np.ndarray,
                  geo: Geometry | None = None, lp: Loop | None = None) -> np.ndarray:
    """d'Alembert loads P = -m a at the nodes, (n, N, 2) [N], from the rigid acceleration field."""
    lp = loop(scene.fourbar, crank_angle) if lp is None else lp
    geo = geometry(scene.fourbar, topo, crank_angle, lp) if geo is None else geo
    root, a_root, c = acceleration_field(scene.fourbar, lp, scene.rpm)
    li = [LINKS.index(lk) for lk in topo.node_link]
    acc = a_root[:, li] + c[:, li] * (geo.z_nodes - root[:, li])
    load = -node_masses(topo, lm) * acc
    return np.stack([load.real, load.imag], axis=-1)


def _toggle_mask(sin_mu: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    mu = np.arcsin(np.clip(np.abs(sin_mu), 0.0, 1.0))
    with np.errstate(divide="ignore"):
        cond = 1.0 / np.abs(sin_mu)
    flagged = mu < np.radians(TOGGLE_TOLERANCE_DEG)
    singular = ~np.isfinite(cond) | (np.abs(sin_mu) < 1e-13)
    return cond, flagged | singular, singular


def _warn(crank_angle: np.ndarray, flagged: np.ndarray) -> None:
    if flagged.any():
        deg = np.round(np.degrees(crank_angle[flagged]), 3)
        warnings.warn(
            f"transmission angle within {TOGGLE_TOLERANCE_DEG} deg of a toggle at crank angles {deg.tolist()} deg: "
            "the frozen structure is (nearly) singular there; see result.flagged and result.condition",
            ToggleWarning, stacklevel=3,
        )


def solve_quasi_static(scene: Scene, crank_angle: np.ndarray | None = None) -> QuasiStaticResult:
    """Quasi-static elastic deflections of ``scene`` (default grid: ``scene.crank_angles``)."""
    theta = scene.crank_angles if crank_angle is None else np.atleast_1d(np.asarray(crank_angle, float))
    lm = lumps(scene.fourbar, scene.mass_model)
    topo = topology(lm)
    lp = loop(scene.fourbar, theta)
    geo = geometry(scene.fourbar, topo, theta, lp)
    F = element_flexibility(scene.fourbar, topo)
    loads = inertia_loads(scene, topo, lm, theta, geo, lp)
    with np.errstate(divide="ignore", invalid="ignore"):
        f = element_forces(topo, geo, loads)  # f = beta P
        d = element_deformations(F, f)  # F f
        nodes, rot = nodal_deflections(topo, geo, d)  # delta = beta^T F beta P
    cond, flagged, singular = _toggle_mask(geo.sin_transmission)
    nodes[singular] = np.nan
    rot[singular] = np.nan
    _warn(theta, flagged)
    p = topo.p_index
    deflection = np.column_stack([nodes[:, p, 0], nodes[:, p, 1], rot])
    mu = np.abs(np.angle((geo.zA - geo.zB) / (geo.zQ - geo.zB)))
    return QuasiStaticResult(
        crank_angle=theta, deflection=deflection, node_label=topo.node_label,
        node_deflection=nodes, loads=loads,
        transmission_angle=mu, condition=cond, flagged=flagged,
    )


def flexibility_at_masses(scene: Scene, crank_angle: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Flexibility matrix condensed on the translational coordinates of the lumped masses.

    Returns (D, m): D (n, 2K, 2K) [m/N] in the order (x1, y1, x2, y2, ...), m (2K,) [kg].
    Massless coordinates are condensed out exactly (they are simply not loaded).
    """
    theta = scene.crank_angles if crank_angle is None else np.atleast_1d(np.asarray(crank_angle, float))
    lm = lumps(scene.fourbar, scene.mass_model)
    topo = topology(lm)
    geo = geometry(scene.fourbar, topo, theta)
    beta = force_transformation(topo, geo)
    mass = node_masses(topo, lm)
    nodes = np.flatnonzero(mass > 0)
    cols = np.stack([2 * nodes, 2 * nodes + 1], axis=1).ravel()
    D = system_flexibility(element_flexibility(scene.fourbar, topo), beta[:, :, cols])
    return D, np.repeat(mass[nodes], 2)


def natural_frequencies(scene: Scene, n_modes: int = 3, crank_angle: np.ndarray | None = None) -> np.ndarray:
    """Lowest natural frequencies [Hz] of the frozen structure at each crank angle, (n, n_modes).

    Undamped free vibration of the lumped masses on the instantaneous structure:
    det(D M - 1/omega^2 I) = 0, solved as the symmetric problem sqrt(M) D sqrt(M).  At most 2K modes
    exist for K lumps; missing ones are NaN.  Rotary inertia of the lumps is neglected.
    """
    if isinstance(n_modes, bool) or not isinstance(n_modes, (int, np.integer)) or n_modes < 1:
        raise ValueError(f"n_modes must be an integer >= 1, got {n_modes!r}")
    from .framecache import cached  # the frequencies do not depend on the speed: computed once per linkage

    theta = scene.crank_angles if crank_angle is None else np.atleast_1d(np.asarray(crank_angle, float))
    f = cached("frequencies", scene, theta, lambda: _frequencies(scene, theta))
    out = np.full((f.shape[0], n_modes), np.nan)
    k = min(n_modes, f.shape[1])
    out[:, :k] = f[:, :k]
    return out


def _frequencies(scene: Scene, crank_angle: np.ndarray) -> np.ndarray:
    """All natural frequencies [Hz] (n, 2K) of the frozen structure, the lowest first (NaN: none)."""
    D, m = flexibility_at_masses(scene, crank_angle)
    sq = np.sqrt(m)
    lam = np.linalg.eigvalsh(sq[:, None] * D * sq[None, :])[:, ::-1]  # descending 1/omega^2
    with np.errstate(divide="ignore", invalid="ignore"):
        return 1.0 / np.sqrt(lam) / (2.0 * np.pi)
