"""Closed-form rigid-body kinematics of a four-bar at constant crank speed, vectorized over angles.

Positions, velocities and accelerations of the joints A, B, the coupler point P, and of any point
on a link (for lumped masses).  Complex numbers are used internally (x + i y); public arrays are
(n, 2) in m, m/s, m/s^2 in the global frame.  With a constant crank speed every acceleration is
proportional to omega^2 and independent of the crank direction.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .linkage import LINKS, FourBar
from .units import rpm_to_rad_s


def _as_angles(crank_angle: np.ndarray | float) -> np.ndarray:
    theta = np.atleast_1d(np.asarray(crank_angle, dtype=float))
    if theta.ndim != 1:
        raise ValueError("crank_angle must be a scalar or a 1-D array of angles in rad")
    if not np.all(np.isfinite(theta)):
        raise ValueError("crank_angle must be finite (rad)")
    return theta


def _xy(z: np.ndarray) -> np.ndarray:
    return np.stack([z.real, z.imag], axis=-1)


def _solve_real(u: np.ndarray, v: np.ndarray, rhs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Real x, y with x*u + y*v = rhs for complex u, v, rhs (2x2 real system, Cramer)."""
    x = (np.conj(v) * rhs).imag / (np.conj(v) * u).imag
    y = (np.conj(u) * rhs).imag / (np.conj(u) * v).imag
    return x, y


@dataclass(frozen=True)
class Loop:
    """Complex loop quantities of a four-bar at an array of crank angles (internal)."""

    M: complex
    Q: complex
    z1: np.ndarray  # M->A
    z3: np.ndarray  # A->B
    z4: np.ndarray  # Q->B
    k: complex  # P - A = k (B - A)


def loop(fourbar: FourBar, crank_angle: np.ndarray) -> Loop:
    """Assemble the four-bar at the given crank angles (rad) on its branch."""
    theta = _as_angles(crank_angle)
    M = complex(*fourbar.crank_pivot)
    Q = complex(*fourbar.follower_pivot)
    z1 = fourbar.crank * np.exp(1j * (fourbar.ground_angle + theta))
    A = M + z1
    d = Q - A
    dist = np.abs(d)
    a = (fourbar.coupler**2 - fourbar.follower**2 + dist**2) / (2.0 * dist)
    h2 = fourbar.coupler**2 - a**2
    h = np.sqrt(np.clip(h2, 0.0, None))
    if np.any(h2 < -1e-9 * fourbar.coupler**2):
        bad = np.degrees(theta[h2 < -1e-9 * fourbar.coupler**2])
        raise ValueError(f"four-bar cannot assemble at crank angles {np.round(bad, 3)} deg")
    sign = 1.0 if fourbar.branch == "open" else -1.0
    e = d / dist
    B = A + e * (a + 1j * sign * h)
    k = fourbar.extender / fourbar.coupler * np.exp(1j * fourbar.coupler_angle)
    return Loop(M=M, Q=Q, z1=z1, z3=B - A, z4=B - Q, k=k)


@dataclass(frozen=True)
class Kinematics:
    """Rigid kinematics at constant crank speed ``omega`` [rad/s, signed: + for CCW].

    Arrays over n crank angles: positions [m], velocities [m/s], accelerations [m/s^2] as (n, 2);
    link angles [rad], angular velocities [rad/s], angular accelerations [rad/s^2] as (n,).
    ``transmission_angle`` is the angle at B between B->A and B->Q, in (0, pi) [rad].
    """

    crank_angle: np.ndarray
    omega: float
    M: np.ndarray
    Q: np.ndarray
    A: np.ndarray
    B: np.ndarray
    P: np.ndarray
    vA: np.ndarray
    vB: np.ndarray
    vP: np.ndarray
    aA: np.ndarray
    aB: np.ndarray
    aP: np.ndarray
    coupler_angle: np.ndarray
    follower_angle: np.ndarray
    omega_coupler: np.ndarray
    omega_follower: np.ndarray
    alpha_coupler: np.ndarray
    alpha_follower: np.ndarray
    transmission_angle: np.ndarray


@dataclass(frozen=True)
class _Rates:
    omega: float
    w3: np.ndarray
    w4: np.ndarray
    a3: np.ndarray
    a4: np.ndarray


def _rates(lp: Loop, omega: float) -> _Rates:
    # velocity loop: i w1 z1 + i w3 z3 - i w4 z4 = 0
    w3, w4m = _solve_real(lp.z3, -lp.z4, -omega * lp.z1)
    w4 = w4m
    # acceleration loop (alpha1 = 0): a3 z3 - a4 z4 = -i (w1^2 z1 + w3^2 z3 - w4^2 z4)
    rhs = -1j * (omega**2 * lp.z1 + w3**2 * lp.z3 - w4**2 * lp.z4)
    a3, a4 = _solve_real(lp.z3, -lp.z4, rhs)
    return _Rates(omega, w3, w4, a3, a4)


def crank_speed(fourbar: FourBar, rpm: float) -> float:
    """Signed crank speed [rad/s] for a speed in rev/min (> 0) and the four-bar's direction."""
    if not np.isfinite(rpm) or rpm <= 0:
        raise ValueError(f"rpm must be a positive finite crank speed in rev/min, got {rpm!r}")
    return rpm_to_rad_s(rpm) * fourbar.sign


def kinematics(fourbar: FourBar, crank_angle: np.ndarray | float, rpm: float) -> Kinematics:
    """Closed-form positions, velocities and accelerations at constant crank speed ``rpm``."""
    lp = loop(fourbar, crank_angle)
    r = _rates(lp, crank_speed(fourbar, rpm))
    A = lp.M + lp.z1
    B = A + lp.z3
    P = A + lp.k * lp.z3
    vA = 1j * r.omega * lp.z1
    aA = -(r.omega**2) * lp.z1
    vB = vA + 1j * r.w3 * lp.z3
    aB = aA + (1j * r.a3 - r.w3**2) * lp.z3
    vP = vA + 1j * r.w3 * lp.k * lp.z3
    aP = aA + (1j * r.a3 - r.w3**2) * lp.k * lp.z3
    mu = np.abs(np.angle(-lp.z3 / -lp.z4))  # angle between B->A and B->Q
    return Kinematics(
        crank_angle=_as_angles(crank_angle), omega=r.omega,
        M=np.array([lp.M.real, lp.M.imag]), Q=np.array([lp.Q.real, lp.Q.imag]),
        A=_xy(A), B=_xy(B), P=_xy(P), vA=_xy(vA), vB=_xy(vB), vP=_xy(vP),
        aA=_xy(aA), aB=_xy(aB), aP=_xy(aP),
        coupler_angle=np.angle(lp.z3), follower_angle=np.angle(lp.z4),
        omega_coupler=r.w3, omega_follower=r.w4, alpha_coupler=r.a3, alpha_follower=r.a4,
        transmission_angle=mu,
    )


def coupler_point(fourbar: FourBar, crank_angle: np.ndarray | float) -> np.ndarray:
    """Rigid position of the coupler point P [m], (n, 2)."""
    lp = loop(fourbar, crank_angle)
    return _xy(lp.M + lp.z1 + lp.k * lp.z3)


def joint_positions(fourbar: FourBar, crank_angle: np.ndarray | float) -> dict[str, np.ndarray]:
    """Rigid positions [m] of M, A, B, Q (fixed ones broadcast) and P as (n, 2) arrays."""
    lp = loop(fourbar, crank_angle)
    A = lp.M + lp.z1
    n = A.shape[0]
    return {
        "M": np.tile([lp.M.real, lp.M.imag], (n, 1)), "A": _xy(A), "B": _xy(A + lp.z3),
        "Q": np.tile([lp.Q.real, lp.Q.imag], (n, 1)), "P": _xy(A + lp.k * lp.z3),
    }


def acceleration_field(fourbar: FourBar, lp: Loop, rpm: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rigid acceleration field of each link, in :data:`LINKS` order, as complex (n, 4) arrays:
    root position, root acceleration and c = i alpha - omega^2, so that a(z) = a_root + c (z - root) [m/s^2]
    for any point z of that link (exact: a rigid body's acceleration field is affine in position)."""
    r = _rates(lp, crank_speed(fourbar, rpm))
    A = lp.M + lp.z1
    aA = -(r.omega**2) * lp.z1
    zero = np.zeros_like(aA)
    root = np.stack([lp.M + zero, A, A, lp.Q + zero], axis=1)
    a_root = np.stack([zero, aA, aA, zero], axis=1)
    c = np.stack([-(r.omega**2) + zero, 1j * r.a3 - r.w3**2, 1j * r.a3 - r.w3**2, 1j * r.a4 - r.w4**2], axis=1)
    return root, a_root, c


def link_point_kinematics(
    fourbar: FourBar, crank_angle: np.ndarray | float, rpm: float, link: str, s: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Position [m] and acceleration [m/s^2] of points at fractions ``s`` along ``link``.

    Fractions are measured from the link's root: crank from M, coupler and extender from A, follower
    from Q.  Returns two (n_angles, n_points, 2) arrays.
    """
    if link not in LINKS:
        raise ValueError(f"link must be one of {', '.join(LINKS)}; got {link!r}")
    s = np.atleast_1d(np.asarray(s, dtype=float))
    lp = loop(fourbar, crank_angle)
    root, a_root, c = acceleration_field(fourbar, lp, rpm)
    i = LINKS.index(link)
    vec = np.stack([lp.z1, lp.z3, lp.k * lp.z3, lp.z4], axis=1)[:, i]
    off = vec[:, None] * s[None, :]
    return _xy(root[:, i, None] + off), _xy(a_root[:, i, None] + c[:, i, None] * off)
