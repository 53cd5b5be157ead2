"""The Radau IIA method (s stages, order 2 s - 1) for q'' + C(t) q' + K(t) q = F(t) with unit mass.

Collocation at the right Radau points: L-stable and stiffly accurate (the new state is the last stage), so
the stiff, overdamped directions of a reduced system are damped to their quasi-static value.  The step maps
of one pass over a cycle (:func:`radau_steps`), homogeneous or affine, are what the reduced Floquet ladder
(:mod:`ked_linear.reduction`) and the co-rotating periodic steady state (:mod:`ked_linear.corotating`)
multiply into their one-cycle maps.
"""

from __future__ import annotations

import numpy as np
from numpy.polynomial import legendre, polynomial


def radau_tableau(stages: int) -> tuple[np.ndarray, np.ndarray]:
    """Nodes c (s,) and matrix A (s, s) of the s-stage Radau IIA method (collocation at the right Radau
    points, the zeros of P_s(2x - 1) - P_{s-1}(2x - 1); weights = last row of A: stiffly accurate)."""
    series = np.zeros(stages + 1)
    series[stages], series[stages - 1] = 1.0, -1.0
    c = (np.sort(np.real(legendre.legroots(series))) + 1.0) / 2.0
    c[-1] = 1.0
    A = np.empty((stages, stages))
    for j in range(stages):
        others = np.delete(c, j)
        integral = polynomial.polyint(polynomial.polyfromroots(others) / np.prod(c[j] - others))
        A[:, j] = polynomial.polyval(c, integral) - polynomial.polyval(0.0, integral)
    return c, A


RADAU_STAGES = 3
"""Stages of the reduced propagator (order 2 s - 1 = 5).  More stages need fewer steps (five, order 9: per
step an amplitude error on an undamped oscillation of 2e-6 at h omega = 2, three stages 7e-3), but a step
costs ~ (s r)^3: measured on the thesis models at 100 and 300 rpm, five stages at a quarter of the steps
were no faster, four about as fast as three."""

_TABLEAUX = {RADAU_STAGES: radau_tableau(RADAU_STAGES)}
RADAU_C, RADAU_A = radau_tableau(3)
"""Butcher tableau of the three-stage Radau IIA method (order 5)."""


def tableau(stages: int) -> tuple[np.ndarray, np.ndarray]:
    """:func:`radau_tableau` of ``stages``, the propagator's (:data:`RADAU_STAGES`) built once."""
    return _TABLEAUX[stages] if stages in _TABLEAUX else radau_tableau(stages)


def radau_steps(K: np.ndarray, C: np.ndarray, h: float, a: np.ndarray = RADAU_A,
                F: np.ndarray | None = None) -> np.ndarray:
    """Step maps of q'' + C q' + K q = F by the Radau IIA method with matrix ``a`` (s, s), with K, C
    (s, m, r, r) and F (s, m, r) at the s stage times of each of the m steps (step h, any sign): without
    ``F`` (F = 0) the step matrices (m, 2r, 2r) of x = (q, q'), with it the affine step maps
    (m, 2r + 1, 2r + 1) of x = (q, q', 1).

    Stage values Q_i = q + h sum_j a_ij P_j, P_i = p + h sum_j a_ij (F_j - K_j Q_j - C_j P_j); eliminating Q:
    [delta_ik I + h a_ik C_k + h^2 sum_j a_ij a_jk K_j] P_k = p - h sum_j a_ij K_j q + h sum_j a_ij F_j, one
    s r x s r solve per step; the new state is the last stage (Q_s, P_s: stiffly accurate)."""
    s, m, r, _ = K.shape
    cols = 2 * r if F is None else 2 * r + 1
    # blocks (i, k) = h^2 sum_j a_ij a_jk K_j + h a_ik C_k: one (s^2 x s) product over the flattened K
    blocks = ((np.einsum("ij,jk->ikj", a, a) * (h * h)).reshape(s * s, s) @ K.reshape(s, -1)).reshape(s, s, m, r, r)
    for k in range(s):
        blocks[:, k] += (h * a[:, k])[:, None, None, None] * C[k]
    L = np.ascontiguousarray(blocks.transpose(2, 0, 3, 1, 4)).reshape(m, s * r, s * r)
    L.reshape(m, -1)[:, ::s * r + 1] += 1.0
    rhs = np.zeros((m, s, r, cols))
    rhs[..., :r] = ((-h * a) @ K.reshape(s, -1)).reshape(s, m, r, r).transpose(1, 0, 2, 3)
    idx = np.arange(r)
    rhs[:, :, idx, r + idx] = 1.0
    if F is not None:
        rhs[..., 2 * r] = ((h * a) @ F.reshape(s, -1)).reshape(s, m, r).transpose(1, 0, 2)
    P = np.linalg.solve(L, rhs.reshape(m, s * r, cols)).reshape(m, s, r, cols)
    S = np.zeros((m, cols, cols))
    S[:, r:2 * r] = P[:, -1]
    last = a[-1, 0] * P[:, 0]
    for j in range(1, s):
        last = last + a[-1, j] * P[:, j]
    S[:, :r] = h * last
    S[:, idx, idx] += 1.0
    if F is not None:
        S[:, 2 * r, 2 * r] = 1.0
    return S


def radau_affine_steps(K: np.ndarray, C: np.ndarray, F: np.ndarray, h: float) -> np.ndarray:
    """Affine step maps (m, 2r + 1, 2r + 1) of x = (q, q', 1) for q'' + C q' + K q = F by the three-stage
    method: :func:`radau_steps` with ``F`` (3, m, r)."""
    return radau_steps(K, C, h, RADAU_A, F)
