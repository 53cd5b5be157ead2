"""Floquet multipliers of the homogeneous system M u'' + C(theta) u' + K(theta) u = 0 over one cycle.

State x = (u, du/dt), x' = A(t) x, A = [[0, I], [-M^-1 K, -M^-1 C]] at theta = speed * t.  The
monodromy matrix Phi (x(T) = Phi x(0), T = 2 pi / |speed|) is built from the step matrices of the
two-stage L-stable SDIRK method (Alexander 1977; gamma = 1 - 1/sqrt(2), second order, stiffly
accurate): stiff, heavily damped modes (the axial modes of the links) get multipliers ~0 as they
should, instead of ~1 (trapezoid, Gauss), and under-resolved modes are damped, never amplified.
Per step, with R(t) = (I - gamma h A(t))^-1 (done on the n x n matrix M + a C + a^2 K, a = gamma h):

    x_{j+1} = R(t_j + h) [(1 - alpha) I + alpha R(t_j + gamma h)] x_j,   alpha = (1 - gamma) / gamma.

The step matrices are built vectorized over the steps and multiplied in a balanced tree.  The
eigenvalues of Phi are the multipliers; the periodic steady state is asymptotically stable iff all
|mu| < 1.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .periodic import PeriodicSystem

GAMMA = 1.0 - 1.0 / np.sqrt(2.0)


def _resolvent(system: PeriodicSystem, theta: np.ndarray, a: float) -> np.ndarray:
    """(I - a A(theta))^-1 for each angle, (m, 2n, 2n), via the n x n matrix Z = M + a C + a^2 K."""
    co = system.coefficients(theta)
    m = system.mass
    Zi = np.linalg.inv(np.eye(m.size) * m + a * co.damping + a**2 * co.stiffness)
    ZK, ZM = Zi @ co.stiffness, Zi * m
    eye = np.broadcast_to(np.eye(m.size), ZK.shape)
    top = np.concatenate([eye - a**2 * ZK, a * ZM], axis=2)
    bottom = np.concatenate([-a * ZK, ZM], axis=2)
    return np.concatenate([top, bottom], axis=1)


def step_matrices(system: PeriodicSystem, steps: int) -> np.ndarray:
    """The SDIRK2 step matrices (steps, 2n, 2n) over one cycle, starting at theta = 0."""
    h = system.period / steps
    t = np.arange(steps) * h
    theta = system.speed * np.concatenate([t + GAMMA * h, t + h])
    R = _resolvent(system, theta, GAMMA * h)
    R1, R2 = R[:steps], R[steps:]
    alpha = (1.0 - GAMMA) / GAMMA
    return R2 @ ((1.0 - alpha) * np.eye(R.shape[-1]) + alpha * R1)


def monodromy(system: PeriodicSystem, steps: int) -> np.ndarray:
    """Phi = S_{steps-1} ... S_1 S_0 (2n, 2n), by pairwise products (balanced tree)."""
    if np.any(system.mass <= 0.0):
        raise ValueError("Floquet analysis needs every mass > 0 (a massless coordinate has no dynamics)")
    S = step_matrices(system, steps)
    while S.shape[0] > 1:
        odd = S[-1:] if S.shape[0] % 2 else S[:0]
        S = np.concatenate([S[1:S.shape[0] - odd.shape[0]:2] @ S[0:S.shape[0] - odd.shape[0]:2], odd])
    return S[0]


def multipliers(system: PeriodicSystem, steps: int) -> np.ndarray:
    """Floquet multipliers (2n,) complex, largest modulus first."""
    mu = np.linalg.eigvals(monodromy(system, steps))
    return mu[np.argsort(-np.abs(mu))]


@dataclass(frozen=True)
class FloquetResult:
    """max_abs: largest |multiplier|; error_estimate: |max_abs(steps) - max_abs(steps / 2)|;
    steps: propagator steps per cycle; multipliers: all of them at ``steps`` (largest first)."""

    max_abs: float
    error_estimate: float
    steps: int
    multipliers: np.ndarray


def floquet(system: PeriodicSystem, tolerance: float, steps: int | None = None,
            max_steps: int = 4096) -> FloquetResult:
    """Multipliers with ``steps`` per cycle or, if None, doubling from 64 (<= ``max_steps``).  The
    automatic choice stops once the change of max |mu| between the last two levels is below
    ``tolerance`` or below a quarter of its distance to 1 (the stability verdict is then settled),
    but only in the asymptotic range of the propagator: at least three levels, the last change less
    than half the one before (the dissipative SDIRK2 steps pull |mu| of a lightly damped system below 1
    at coarse steps, where two levels can agree while both are far off)."""
    plan = [max(8, steps // 2), steps] if steps is not None else [64 * 2**k for k in range(7) if 64 * 2**k <= max_steps]
    tops: list[float] = []
    est, mu, n = float("nan"), np.array([np.nan]), plan[0]
    for n in plan:
        mu = multipliers(system, n)
        tops.append(float(np.abs(mu[0])))
        if len(tops) < 2:
            continue
        est = abs(tops[-1] - tops[-2])
        asymptotic = len(tops) >= 3 and est < 0.5 * abs(tops[-2] - tops[-3])
        if steps is None and asymptotic and (est < tolerance or est < 0.25 * abs(1.0 - tops[-1])):
            break
    return FloquetResult(max_abs=float(np.abs(mu[0])), error_estimate=est, steps=n, multipliers=mu)
