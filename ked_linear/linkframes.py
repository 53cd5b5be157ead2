"""Co-rotating link frames of a linkage's mass coordinates: which link each lump turns with, the links'
angles, rates and accelerations over the cycle, and the per-lump rotations R(phi) and turn J by 90 degrees.

The coordinates u of :mod:`ked_linear.linkage` are absolute x, y displacements of the lumps; u = R v with R
block diagonal, the 2 x 2 rotation by the angle phi of each lump's link, gives the co-rotating coordinates v
in which the reduced Floquet analysis (:mod:`ked_linear.reduction`) and the co-rotating periodic steady
state (:mod:`ked_linear.corotating`) keep a constant basis.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

FrameAngles = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray, np.ndarray]]
"""theta (m,) [rad] -> (phi [rad], phi_dot [rad/s], phi_ddot [rad/s^2]), each (m, n/2): the frame angle of
each coordinate pair (x, y), its rate and acceleration at the system's speed."""


@dataclass(frozen=True)
class LinkFrames:
    """The co-rotating frame of each coordinate pair (x, y of one lump).

    link (N,): for lump j (coordinates 2 j, 2 j + 1), the column of ``angles`` it turns with;
    angles: theta (m,) [rad] -> (phi, phi_dot, phi_ddot), each (m, L): the frame angles [rad], their rates
    [rad/s] and accelerations [rad/s^2] at those crank angles (at the system's speed)."""

    link: np.ndarray
    angles: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray, np.ndarray]]

    def of_lumps(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(phi, phi_dot, phi_ddot) per lump, each (m, N)."""
        return tuple(a[:, self.link] for a in self.angles(theta))  # type: ignore[return-value]


def link_frames(scene: object) -> LinkFrames:
    """The frames of a four-bar scene's mass coordinates (:func:`ked_quasi.frame.condensed_structure` order):
    lumps on the crank turn with the crank, the coupler body's (coupler, extender, A, B, P) with the
    coupler, the follower's with the follower."""
    from ked_quasi.frame import condensed_structure
    from ked_quasi.kinematics import kinematics
    from ked_quasi.massmodel import lumps
    from ked_quasi.structure import topology

    topo = topology(lumps(scene.fourbar, scene.mass_model))
    nodes = condensed_structure(scene, np.zeros(1)).mass_node
    column = {"crank": 0, "coupler": 1, "extender": 1, "follower": 2}
    link = np.array([column[topo.node_link[k]] for k in nodes], dtype=int)
    fourbar, rpm = scene.fourbar, scene.rpm

    def angles(theta: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        kin = kinematics(fourbar, theta, rpm)
        zero = np.zeros_like(theta)
        phi = np.stack([fourbar.ground_angle + theta, kin.coupler_angle, kin.follower_angle], axis=1)
        rate = np.stack([zero + kin.omega, kin.omega_coupler, kin.omega_follower], axis=1)
        acc = np.stack([zero, kin.alpha_coupler, kin.alpha_follower], axis=1)
        return phi, rate, acc

    return LinkFrames(link=link, angles=angles)


def rotate_columns(X: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """R(phi) X for X (..., n, k) (n = 2 N) and lump angles phi (m, N): (m, n, k)."""
    c, s = np.cos(phi)[:, :, None], np.sin(phi)[:, :, None]
    x, y = X[..., 0::2, :], X[..., 1::2, :]
    out = np.empty(np.broadcast_shapes(X.shape, (phi.shape[0], 2 * phi.shape[1], X.shape[-1])))
    out[:, 0::2], out[:, 1::2] = c * x - s * y, s * x + c * y
    return out


def _turn(X: np.ndarray) -> np.ndarray:
    """J X per lump (J = [[0, -1], [1, 0]]), X (..., n, k)."""
    out = np.empty_like(X)
    out[..., 0::2, :], out[..., 1::2, :] = -X[..., 1::2, :], X[..., 0::2, :]
    return out


def _in_frames(K: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """R^T K R (m, n, n) for K (m, n, n) and the lump angles phi (m, N)."""
    RtK = rotate_columns(K, -phi)  # R^T K (R(-phi) = R(phi)^T)
    return np.swapaxes(rotate_columns(np.swapaxes(RtK, 1, 2), -phi), 1, 2)  # (R^T (R^T K)^T)^T = R^T K R
