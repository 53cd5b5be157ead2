"""Floquet multipliers of the homogeneous system M u'' + C(theta) u' + K(theta) u = 0 over one cycle.

State x = (u, du/dt), x' = A(t) x, A = [[0, I], [-M^-1 K, -M^-1 C]] at theta = speed * t.  The
monodromy matrix Phi (x(T) = Phi x(0), T = 2 pi / |speed|) is the product of one step matrix per time
step, all built from A at the two Gauss points of the step, t_j + c_i h, c_{1,2} = 1/2 -+ sqrt(3)/6,
by a propagator without numerical damping:

* **damped** (C != 0): the exponential of the frozen, step-averaged coefficients,
  S_j = expm(h (A_1 + A_2) / 2) (exponential midpoint rule, second order).  Exact for frozen
  coefficients, so a stiff, heavily damped mode (the axial modes of the links under stiffness-
  proportional damping) decays exactly as it should (multiplier ~0, however large h |A|), and a lightly
  damped mode keeps its physical decay (no numerical damping to hide a weakly damped or unstable case);
* **undamped** (C = 0, A Hamiltonian for the form [[0, M], [-M, 0]]): the two-stage Gauss-Legendre
  method (fourth order, symplectic): every S_j is symplectic, so the multipliers of a stable undamped
  system stay on the unit circle up to round-off at every step count (no numerical damping, none of
  the spurious growth a dissipative or an exponential-midpoint staircase shows at coarse steps of
  these highly oscillatory systems).

The fourth-order Magnus method with the commutator term is no option here: at low speeds h |A| is
hundreds of radians per step (thousands of frozen oscillations per crank cycle), where the Magnus series
diverges and its exponent turns hyperbolic (overflow on the thesis tip model at 1 rpm, 16 to 4096 steps).

The exponentials are computed for all steps at once (stacked matrices): scaling and squaring with the
[13/13] Pade approximant (Higham 2005), each matrix scaled by its own power of 2.  The step matrices
are multiplied in a balanced tree.  The eigenvalues of Phi are the multipliers; the periodic steady
state is asymptotically stable iff all |mu| < 1.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .periodic import Coefficients, PeriodicSystem

GAUSS = 0.5 + np.array([-1.0, 1.0]) * np.sqrt(3.0) / 6.0
"""The two Gauss-Legendre nodes on [0, 1] (fractions of a step)."""

_PADE13 = (64764752532480000.0, 32382376266240000.0, 7771770303897600.0, 1187353796428800.0,
           129060195264000.0, 10559470521600.0, 670442572800.0, 33522128640.0, 1323241920.0, 40840800.0,
           960960.0, 16380.0, 182.0, 1.0)
_THETA13 = 5.371920351148152
"""Coefficients of the [13/13] Pade approximant of exp and the 1-norm up to which it is accurate to unit
round-off (Higham, SIAM J. Matrix Anal. Appl. 26 (2005) 1179, Table 2.3)."""

ROUND_OFF_FLOOR = 1e-10
"""Changes of max |mu| below this between two step levels are round-off (the products of a few thousand
step matrices), not discretization error: the estimate is then this floor."""


def expm_stack(a: np.ndarray) -> np.ndarray:
    """exp of each matrix of a stack (m, k, k): scaling and squaring with the [13/13] Pade approximant,
    each matrix scaled by its own power of 2 (norm / 2^s <= theta13)."""
    norm = np.abs(a).sum(axis=-2).max(axis=-1)
    with np.errstate(divide="ignore"):
        s = np.maximum(0, np.ceil(np.log2(np.maximum(norm, 1e-300) / _THETA13))).astype(int)
    a = a * np.ldexp(1.0, -s)[:, None, None]
    b = _PADE13
    eye = np.broadcast_to(np.eye(a.shape[-1]), a.shape)
    a2 = a @ a
    a4 = a2 @ a2
    a6 = a4 @ a2
    u = a @ (a6 @ (b[13] * a6 + b[11] * a4 + b[9] * a2) + b[7] * a6 + b[5] * a4 + b[3] * a2 + b[1] * eye)
    v = a6 @ (b[12] * a6 + b[10] * a4 + b[8] * a2) + b[6] * a6 + b[4] * a4 + b[2] * a2 + b[0] * eye
    e = np.linalg.solve(v - u, v + u)
    for k in range(int(s.max(initial=0))):
        sel = s > k
        e[sel] = e[sel] @ e[sel]
    return e


def _state_matrices(system: PeriodicSystem, co: Coefficients) -> np.ndarray:
    """A (m, 2n, 2n) of the first-order form x = (u, du/dt) from the coefficients at m angles."""
    m = system.mass
    n = m.size
    a = np.zeros((co.stiffness.shape[0], 2 * n, 2 * n))
    a[:, :n, n:] = np.eye(n)
    a[:, n:, :n] = -co.stiffness / m[:, None]
    a[:, n:, n:] = -co.damping / m[:, None]
    return a


_GAUSS_A = np.array([[0.25, 0.25 - np.sqrt(3.0) / 6.0], [0.25 + np.sqrt(3.0) / 6.0, 0.25]])
"""Butcher matrix of the two-stage Gauss-Legendre method (weights 1/2, 1/2)."""


def _gauss_steps(a1: np.ndarray, a2: np.ndarray, h: float) -> np.ndarray:
    """Step matrices of the two-stage Gauss-Legendre method for x' = A(t) x: stages k_i = A_i (x + h sum_j
    a_ij k_j) solved for all steps at once, S = I + h (k_1 + k_2) / 2 per unit x."""
    m, k = a1.shape[0], a1.shape[-1]
    eye = np.eye(k)
    lhs = np.empty((m, 2 * k, 2 * k))
    lhs[:, :k, :k] = eye - h * _GAUSS_A[0, 0] * a1
    lhs[:, :k, k:] = -h * _GAUSS_A[0, 1] * a1
    lhs[:, k:, :k] = -h * _GAUSS_A[1, 0] * a2
    lhs[:, k:, k:] = eye - h * _GAUSS_A[1, 1] * a2
    stages = np.linalg.solve(lhs, np.concatenate([a1, a2], axis=1))
    return eye + 0.5 * h * (stages[:, :k] + stages[:, k:])


def step_matrices(system: PeriodicSystem, steps: int, first: int = 0, count: int | None = None) -> np.ndarray:
    """The step matrices (count, 2n, 2n) of steps first .. first + count - 1 of ``steps`` per cycle
    (default: all), step 0 starting at theta = 0: exponential midpoint where the system is damped,
    Gauss-Legendre (symplectic) where it is undamped (C = 0 at both Gauss points)."""
    count = steps - first if count is None else count
    h = system.period / steps
    t = (first + np.arange(count)) * h
    theta = system.speed * np.concatenate([t + GAUSS[0] * h, t + GAUSS[1] * h])
    co = system.coefficients(theta)
    a = _state_matrices(system, co)
    a1, a2 = a[:count], a[count:]
    if not np.any(co.damping):
        return _gauss_steps(a1, a2, h)
    return expm_stack(0.5 * h * (a1 + a2))


CHUNK_BYTES = 64e6
"""Memory bound of the step matrices built at once [bytes] (the Gauss stage matrices are (4n)^2 each)."""


def _product(S: np.ndarray) -> np.ndarray:
    """S[-1] ... S[1] S[0] by pairwise products (balanced tree)."""
    while S.shape[0] > 1:
        odd = S[-1:] if S.shape[0] % 2 else S[:0]
        S = np.concatenate([S[1:S.shape[0] - odd.shape[0]:2] @ S[0:S.shape[0] - odd.shape[0]:2], odd])
    return S[0]


def monodromy(system: PeriodicSystem, steps: int) -> np.ndarray:
    """Phi = S_{steps-1} ... S_1 S_0 (2n, 2n), by pairwise products (balanced tree)."""
    if np.any(system.mass <= 0.0):
        raise ValueError("Floquet analysis needs every mass > 0 (a massless coordinate has no dynamics)")
    chunk = max(8, int(CHUNK_BYTES / (8.0 * (4 * system.mass.size) ** 2)))
    phi = np.eye(2 * system.mass.size)
    for first in range(0, steps, chunk):
        phi = _product(step_matrices(system, steps, first, min(chunk, steps - first))) @ phi
    return phi


def multipliers(system: PeriodicSystem, steps: int) -> np.ndarray:
    """Floquet multipliers (2n,) complex, largest modulus first."""
    mu = np.linalg.eigvals(monodromy(system, steps))
    return mu[np.argsort(-np.abs(mu))]


def _settled(changes: list[float], tops: list[float], tolerance: float) -> bool:
    """Either the last change at round-off with three levels or more (two levels agree to round-off: a
    spurious resonance of a coarse level does not repeat at the next one), or the propagator in its
    asymptotic range, the last two ratios of successive changes below 1/2 (coarse levels of these highly
    oscillatory systems show spurious resonances, or dissipate by kicking energy into damped stiff modes
    at each coefficient jump, and two levels can agree by chance while far off: thesis joints at 210 rpm,
    0.111, 0.127 at 128, 256 steps, 0.230 converged), with the last two changes each below ``tolerance``
    or a quarter of the distance of their level to 1 (the verdict is settled)."""
    if len(changes) < 2:
        return False
    if changes[-1] <= ROUND_OFF_FLOOR:
        return True
    if len(changes) < 3 or not (changes[-1] < 0.5 * changes[-2] and changes[-2] < 0.5 * changes[-3]):
        return False
    return all(c < tolerance or c < 0.25 * abs(1.0 - t) for c, t in zip(changes[-2:], tops[-2:]))


@dataclass(frozen=True)
class FloquetResult:
    """max_abs: largest |multiplier|; error_estimate: |max_abs(steps) - max_abs(steps / 2)| (at least
    :data:`ROUND_OFF_FLOOR`), an upper bound once the levels converge at the method's fourth order;
    steps: propagator steps per cycle; multipliers: all of them at ``steps`` (largest first)."""

    max_abs: float
    error_estimate: float
    steps: int
    multipliers: np.ndarray


def floquet(system: PeriodicSystem, tolerance: float, steps: int | None = None,
            max_steps: int = 16384) -> FloquetResult:
    """Multipliers with ``steps`` per cycle or, if None, doubling from 64 (<= ``max_steps``).  The
    automatic choice stops once the changes of max |mu| between the last three levels are settled
    (:func:`_settled`).  The estimate is the last change itself (Richardson: at order p
    the error of the finer level is about 1 / (2^p - 1) of it, a third for the exponential midpoint
    rule, a fifteenth for Gauss-Legendre), at least :data:`ROUND_OFF_FLOOR`."""
    plan = [max(8, steps // 2), steps] if steps is not None else [64 * 2**k for k in range(9) if 64 * 2**k <= max_steps]
    tops: list[float] = []
    changes: list[float] = []
    est, mu, n = float("nan"), np.array([np.nan]), plan[0]
    for n in plan:
        mu = multipliers(system, n)
        tops.append(float(np.abs(mu[0])))
        if len(tops) < 2:
            continue
        changes.append(max(abs(tops[-1] - tops[-2]), ROUND_OFF_FLOOR))
        est = changes[-1]
        if steps is None and _settled(changes, tops, tolerance):
            break
    return FloquetResult(max_abs=float(np.abs(mu[0])), error_estimate=est, steps=n, multipliers=mu)
