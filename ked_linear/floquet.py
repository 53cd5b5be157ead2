"""Floquet multipliers of the homogeneous system M u'' + C(theta) u' + K(theta) u = 0 over one cycle.

State x = (u, du/dt), x' = A(t) x, A = [[0, I], [-M^-1 K, -M^-1 C]] at theta = speed * t.  The
monodromy matrix Phi (x(T) = Phi x(0), T = 2 pi / |speed|) is the product of one step matrix per time
step, by a propagator chosen by the structure of the system:

* **undamped** (C = 0, A Hamiltonian for the form [[0, M], [-M, 0]]): the two-stage Gauss-Legendre
  method (fourth order, symplectic; A at the two Gauss points t_j + (1/2 -+ sqrt(3)/6) h).  Every step
  matrix is symplectic, so the multipliers of a stable undamped system stay on the unit circle to
  round-off at every step count: no numerical damping (the L-stable SDIRK2 pulled them to 1e-128 at 1 rpm
  on the thesis Case I) and no spurious growth at resolved steps;
* **damped**: the two-stage L-stable SDIRK method (Alexander 1977; gamma = 1 - 1/sqrt(2), second order,
  stiffly accurate).  The links' axial modes, stiff and overdamped under stiffness-proportional damping,
  get multipliers ~0 as they should (Gauss-Legendre would give them ~1).  Its numerical damping of the
  lightly damped modes is an error like any other: :func:`floquet` refines until the change between levels
  is in the asymptotic range and reports it as the error.  Per step, with R(t) = (I - gamma h A(t))^-1
  (from the n x n matrix M + a C + a^2 K, a = gamma h): x_{j+1} = R(t_j + h) [(1 - alpha) I + alpha
  R(t_j + gamma h)] x_j, alpha = (1 - gamma) / gamma.

Measured and not used: the fourth-order Magnus method (its series diverges when h |A| is hundreds of
radians, i.e. thousands of frozen oscillations per crank cycle at low speed: overflow on Case I at 1 rpm,
16 to 4096 steps); the exponential of the frozen step-averaged coefficients (exact for frozen
coefficients, but its coefficient jumps cause spurious parametric resonances when undamped, max |mu| - 1
up to 11 on the joints model at 1 rpm even at 32768 steps, and, damped, kick energy into the damped stiff
modes: less accurate than SDIRK2 at equal steps, and 4 to 35 times slower on the larger models).

The step matrices are built vectorized over the steps (in chunks of bounded memory; SDIRK2's by blocks,
two n x n solves per stage, never forming the 2n x 2n resolvents) from stage coefficients evaluated on two
whole-turn grids per level (interpolated, :data:`COEFFICIENT_BYTES`), and multiplied in a balanced tree.
The eigenvalues of Phi are the multipliers; the periodic steady state is asymptotically stable iff all
|mu| < 1.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .periodic import Coefficients, PeriodicSystem

GAUSS = 0.5 + np.array([-1.0, 1.0]) * np.sqrt(3.0) / 6.0
"""The two Gauss-Legendre nodes on [0, 1] (fractions of a step)."""

ROUND_OFF_FLOOR = 1e-10
"""Changes of max |mu| below this between two step levels are round-off (the products of a few thousand
step matrices), not discretization error: the estimate is then this floor."""


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


def undamped(system: PeriodicSystem) -> bool:
    """C(theta) = 0 (probed at 8 angles over the cycle): the system is Hamiltonian."""
    return not np.any(system.coefficients(np.linspace(0.0, 2.0 * np.pi, 8, endpoint=False)).damping)


def _stage_offsets(damped: bool, h: float) -> np.ndarray:
    """Stage times within a step (2,) [s]: Gauss-Legendre nodes, or SDIRK2's gamma h and h."""
    return np.array([SDIRK_GAMMA * h, h]) if damped else GAUSS * h


def _stage_coefficients(system: PeriodicSystem, steps: int, first: int, count: int, damped: bool) -> Coefficients:
    """The coefficients at the two stage angles of steps first .. first + count - 1: the first stage's
    (count,) then the second's; with first = 0 and count = steps two uniform full-turn grids (interpolated
    when the coefficients are sampled, see ``periodic.SampledCoefficients``)."""
    h = system.period / steps
    t = (first + np.arange(count)) * h
    c = _stage_offsets(damped, h)
    return system.coefficients(system.speed * np.concatenate([t + c[0], t + c[1]]))


def _steps_from(system: PeriodicSystem, co: Coefficients, lo: int, hi: int, count: int, h: float,
                damped: bool) -> np.ndarray:
    """Step matrices of the steps whose stage coefficients are rows lo .. hi - 1 (first stage) and
    count + lo .. count + hi - 1 (second stage) of ``co``."""
    K1, K2 = co.stiffness[lo:hi], co.stiffness[count + lo:count + hi]
    C1, C2 = co.damping[lo:hi], co.damping[count + lo:count + hi]
    if damped:
        return _sdirk_steps_from(system.mass, K1, C1, K2, C2, h)
    a = _state_matrices(system, Coefficients(stiffness=np.concatenate([K1, K2]), damping=np.concatenate([C1, C2]),
                                             load=np.zeros((2 * (hi - lo), system.mass.size))))
    return _gauss_steps(a[:hi - lo], a[hi - lo:], h)


def step_matrices(system: PeriodicSystem, steps: int, first: int = 0, count: int | None = None) -> np.ndarray:
    """The step matrices (count, 2n, 2n) of steps first .. first + count - 1 of ``steps`` per cycle
    (default: all), step 0 starting at theta = 0: Gauss-Legendre (symplectic) if the system is undamped
    (:func:`undamped`), else SDIRK2 (L-stable)."""
    count = steps - first if count is None else count
    damped = not undamped(system)
    co = _stage_coefficients(system, steps, first, count, damped)
    return _steps_from(system, co, 0, count, count, system.period / steps, damped)


SDIRK_GAMMA = 1.0 - 1.0 / np.sqrt(2.0)


def _resolvent(system: PeriodicSystem, theta: np.ndarray, a: float) -> np.ndarray:
    """(I - a A(theta))^-1 for each angle, (m, 2n, 2n), via the n x n matrix Z = M + a C + a^2 K (the
    reference form of the resolvent; :func:`_sdirk_steps` applies it by blocks instead)."""
    co = system.coefficients(theta)
    m = system.mass
    Zi = np.linalg.inv(np.eye(m.size) * m + a * co.damping + a**2 * co.stiffness)
    ZK, ZM = Zi @ co.stiffness, Zi * m
    eye = np.broadcast_to(np.eye(m.size), ZK.shape)
    top = np.concatenate([eye - a**2 * ZK, a * ZM], axis=2)
    bottom = np.concatenate([-a * ZK, ZM], axis=2)
    return np.concatenate([top, bottom], axis=1)


def _sdirk_steps(system: PeriodicSystem, first: int, count: int, h: float) -> np.ndarray:
    """Step matrices of the two-stage L-stable SDIRK method (Alexander 1977), steps first .. first +
    count - 1 of length h (see :func:`_sdirk_steps_from`)."""
    co = _stage_coefficients(system, int(round(system.period / h)), first, count, True)
    return _sdirk_steps_from(system.mass, co.stiffness[:count], co.damping[:count], co.stiffness[count:],
                             co.damping[count:], h)


def _sdirk_steps_from(m: np.ndarray, K1: np.ndarray, C1: np.ndarray, K2: np.ndarray, C2: np.ndarray,
                      h: float) -> np.ndarray:
    """SDIRK2 step matrices x_{j+1} = R(t_j + h) [(1 - alpha) I + alpha R(t_j + gamma h)] x_j,
    R = (I - gamma h A)^-1, alpha = (1 - gamma) / gamma, from the coefficients at the stage angles (K1, C1
    at t_j + gamma h, K2, C2 at t_j + h).

    By blocks, never forming R: for x = (u, v), R x = (u + a y, y) with y = Z^-1 (M v - a K u),
    Z = M + a C + a^2 K, a = gamma h (the Z-form of :func:`_resolvent`), so a step costs two batched
    n x n solves with 2n right-hand sides and one n x n x 2n product instead of two inverses and 2n x 2n
    products (about half the flops, a fraction of the memory traffic)."""
    count, n = K1.shape[0], m.size
    a = SDIRK_GAMMA * h
    alpha = (1.0 - SDIRK_GAMMA) / SDIRK_GAMMA
    # stage 1 on X = I: y1 = Z1^-1 [-a K1, M]
    diag = np.arange(n)
    rhs = np.zeros((count, n, 2 * n))
    np.multiply(K1, -a, out=rhs[:, :, :n])
    rhs[:, diag, n + diag] = m
    Y1 = np.linalg.solve(_z_matrix(m, K1, C1, a), rhs)
    # B = (1 - alpha) I + alpha R1: Bu = [I, 0] + alpha a Y1, Bv = (1 - alpha) [0, I] + alpha Y1
    Bu = Y1 * (alpha * a)
    Bu[:, diag, diag] += 1.0
    Bv = np.multiply(Y1, alpha, out=Y1)
    Bv[:, diag, n + diag] += 1.0 - alpha
    # stage 2: S = R2 B = [Bu + a y2; y2], y2 = Z2^-1 (M Bv - a K2 Bu)
    rhs = K2 @ Bu
    rhs *= -a
    rhs += m[:, None] * Bv
    S = np.empty((count, 2 * n, 2 * n))
    S[:, n:] = np.linalg.solve(_z_matrix(m, K2, C2, a), rhs)
    np.multiply(S[:, n:], a, out=S[:, :n])
    S[:, :n] += Bu
    return S


def _z_matrix(m: np.ndarray, K: np.ndarray, C: np.ndarray, a: float) -> np.ndarray:
    """Z = M + a C + a^2 K per angle (count, n, n), with one temporary."""
    Z = K * (a * a)
    Z += a * C
    idx = np.arange(m.size)
    Z[:, idx, idx] += m
    return Z


CHUNK_BYTES = 64e6
"""Memory bound of the step matrices built at once [bytes] (the Gauss stage matrices are (4n)^2 each)."""


def _product(S: np.ndarray) -> np.ndarray:
    """S[-1] ... S[1] S[0] by pairwise products (balanced tree)."""
    while S.shape[0] > 1:
        odd = S[-1:] if S.shape[0] % 2 else S[:0]
        S = np.concatenate([S[1:S.shape[0] - odd.shape[0]:2] @ S[0:S.shape[0] - odd.shape[0]:2], odd])
    return S[0]


COEFFICIENT_BYTES = 160e6
"""Memory bound of the stage coefficients (K and C at both stage angles of every step) evaluated at once
[bytes]: within it they are evaluated on two uniform full-turn grids (interpolated, see
``periodic.SampledCoefficients``), beyond it chunk by chunk (partial turns: the direct frame condensation)."""


def monodromy(system: PeriodicSystem, steps: int) -> np.ndarray:
    """Phi = S_{steps-1} ... S_1 S_0 (2n, 2n), by pairwise products (balanced tree)."""
    if np.any(system.mass <= 0.0):
        raise ValueError("Floquet analysis needs every mass > 0 (a massless coordinate has no dynamics)")
    n = system.mass.size
    chunk = max(8, int(CHUNK_BYTES / (8.0 * (4 * n) ** 2)))
    damped = not undamped(system)
    h = system.period / steps
    whole = 8.0 * 2 * steps * (2 * n * n + 4 * n) <= COEFFICIENT_BYTES
    co = _stage_coefficients(system, steps, 0, steps, damped) if whole else None
    phi = np.eye(2 * n)
    for first in range(0, steps, chunk):
        count = min(chunk, steps - first)
        if whole:
            S = _steps_from(system, co, first, first + count, steps, h, damped)
        else:
            S = _steps_from(system, _stage_coefficients(system, steps, first, count, damped), 0, count, count, h,
                            damped)
        phi = _product(S) @ phi
    return phi


def multipliers(system: PeriodicSystem, steps: int) -> np.ndarray:
    """Floquet multipliers (2n,) complex, largest modulus first."""
    mu = np.linalg.eigvals(monodromy(system, steps))
    return mu[np.argsort(-np.abs(mu))]


def _settled(changes: list[float], tops: list[float], tolerance: float) -> bool:
    """Three levels or more, and: the last change at round-off (a spurious resonance of a coarse level
    does not repeat at the next one), or the last two changes both below ``tolerance`` (three levels agree),
    or the verdict settled in the asymptotic range: the last two changes each below a quarter of the
    distance of their level to 1 and the last two ratios of successive changes below 1/2.  Coarse levels
    of these highly oscillatory systems show spurious resonances or extra dissipation, and two levels can
    agree by chance while far off (joints at 210 rpm, exponential midpoint: 0.111, 0.127 at 128, 256
    steps, 0.230 converged), hence three levels."""
    if len(changes) < 2:
        return False
    if changes[-1] <= ROUND_OFF_FLOOR or (changes[-1] < tolerance and changes[-2] < tolerance):
        return True
    if len(changes) < 3 or not (changes[-1] < 0.5 * changes[-2] and changes[-2] < 0.5 * changes[-3]):
        return False
    return all(c < 0.25 * abs(1.0 - t) for c, t in zip(changes[-2:], tops[-2:]))


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
    the error of the finer level is about 1 / (2^p - 1) of it, a third for SDIRK2
    (damped), a fifteenth for Gauss-Legendre (undamped)), at least :data:`ROUND_OFF_FLOOR`."""
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
