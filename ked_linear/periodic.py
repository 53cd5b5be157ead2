"""Periodic steady state of M u'' + C(theta) u' + K(theta) u = f(theta), theta = theta0 + speed * t.

Generic linear time-periodic (LTP) systems, 2 pi periodic in theta, with a constant diagonal mass
(entries may be 0: then those inertia terms vanish).  With ' = d/dtheta and sigma = dtheta/dt the
equation reads K u + sigma C u' + sigma^2 M u'' = f.

Method (Fourier collocation with a quasi-static split, docs/linear_model.md):

* q(theta) = K(theta)^-1 f(theta), the frozen (quasi-static) solution, exact at every angle;
* u = q + w; the correction solves K w + B w = -B q, B = sigma C d/dtheta + sigma^2 M d^2/dtheta^2;
* the dynamic operator acts on all harmonics of q (spectral derivatives on N collocation points) but,
  on the correction w, only on its first H crank harmonics (Pi_H); the rest of w follows quasi-statically.
  Collocation at the N points: K w + B Pi_H w = -B q.  With c = Pi_H w (real trigonometric coefficients,
  2H + 1 per coordinate): (I + Pi_H K^-1 B E) c = -Pi_H K^-1 B q, one dense solve of size (2H + 1) n;
* the solution at any angle is u = K^-1 (f - sigma C z' - sigma^2 M z''), z = q + Pi_H w (a trigonometric
  polynomial): with M and C zero it is the quasi-static solution exactly, and every harmonic of a
  constant-coefficient system up to H gets its exact frequency response.

The truncation error is that of treating harmonics above H of w with one quasi-static iteration,
~ (k sigma / omega)^4 |q_k|; it is estimated by comparing H with the level below it (:func:`steady_state`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.sparse import linalg as spla


@dataclass(frozen=True)
class Coefficients:
    """The coefficients at m angles: stiffness K (m, n, n) [N/m], damping C (m, n, n) [N s/m], load f
    (m, n) [N], and optionally an output map (m, p, n) (output y = output @ u, any unit per m)."""

    stiffness: np.ndarray
    damping: np.ndarray
    load: np.ndarray
    output: np.ndarray | None = None


@dataclass(frozen=True)
class PeriodicSystem:
    """M u'' + C(theta) u' + K(theta) u = f(theta) with theta = theta0 + speed * t, 2 pi periodic.

    mass (n,) [kg]: the constant diagonal mass (>= 0); speed: dtheta/dt [rad/s], signed, nonzero;
    coefficients: theta (m,) [rad] -> :class:`Coefficients` at those angles (any real angles).
    """

    mass: np.ndarray
    speed: float
    coefficients: Callable[[np.ndarray], Coefficients]

    def __post_init__(self) -> None:
        m = np.atleast_1d(np.asarray(self.mass, dtype=float))
        if m.ndim != 1 or not np.all(np.isfinite(m)) or np.any(m < 0.0):
            raise ValueError(f"PeriodicSystem.mass: must be a 1-D array of finite masses >= 0 kg; got {self.mass!r}")
        object.__setattr__(self, "mass", m)
        if not (np.isfinite(self.speed) and self.speed != 0.0):
            raise ValueError(f"PeriodicSystem.speed: must be a finite nonzero dtheta/dt in rad/s; got {self.speed!r}")

    @property
    def period(self) -> float:
        """Duration of one cycle [s]."""
        return 2.0 * np.pi / abs(self.speed)


@dataclass(frozen=True)
class PeriodicSolution:
    """The steady state on H harmonics and N collocation points: ``kinematic`` (N//2 + 1, n) complex
    Fourier coefficients of z = q + Pi_H w (numpy rfft / N normalization, Nyquist term zero), from which
    u follows at any angle (:func:`evaluate`)."""

    system: PeriodicSystem
    harmonics: int
    points: int
    kinematic: np.ndarray


def collocation_points(harmonics: int) -> int:
    """Collocation points N used with H harmonics: 4 H, at least 32 (the quasi-static solution and the
    coefficients are sampled to twice the dynamic band, so their derivatives and products are exact to
    the spectral tail of the frozen structure's response)."""
    return max(32, 4 * harmonics)


def trig_basis(theta: np.ndarray, harmonics: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Real trigonometric basis [1, cos t, sin t, ..., cos Ht, sin Ht] and its first and second
    derivatives at the angles ``theta``, each (m, 2H + 1)."""
    k = np.arange(1, harmonics + 1)
    c, s = np.cos(np.outer(theta, k)), np.sin(np.outer(theta, k))
    E, E1, E2 = (np.zeros((theta.size, 2 * harmonics + 1)) for _ in range(3))
    E[:, 0] = 1.0
    E[:, 1::2], E[:, 2::2] = c, s
    E1[:, 1::2], E1[:, 2::2] = -k * s, k * c
    E2[:, 1::2], E2[:, 2::2] = -(k**2) * c, -(k**2) * s
    return E, E1, E2


def spectrum(samples: np.ndarray) -> np.ndarray:
    """Fourier coefficients (N//2 + 1, ...) of samples (N, ...) on a uniform full-turn grid, rfft / N,
    Nyquist term dropped (its derivative is undefined on the grid)."""
    n = samples.shape[0]
    X = np.fft.rfft(samples, axis=0) / n
    if n % 2 == 0:
        X[-1] = 0.0
    return X


def series(coefficients: np.ndarray, theta: np.ndarray, derivative: int = 0) -> np.ndarray:
    """The ``derivative``-th theta-derivative at ``theta`` (m,) of the real series with rfft / N
    ``coefficients`` (K, ...): sum_k w_k Re((i k)^d X_k e^{i k theta}), w_0 = 1, w_k = 2."""
    k = np.arange(coefficients.shape[0])
    weight = np.where(k == 0, 1.0, 2.0) * (1j * k) ** derivative
    phase = np.exp(1j * np.outer(theta, k)) * weight
    return (phase @ coefficients.reshape(k.size, -1)).real.reshape((theta.size,) + coefficients.shape[1:])


def _apply(matrices: np.ndarray, vectors: np.ndarray) -> np.ndarray:
    return np.einsum("mij,mj->mi", matrices, vectors)


def solve_periodic(system: PeriodicSystem, harmonics: int, points: int | None = None) -> PeriodicSolution:
    """Steady state with ``harmonics`` dynamic harmonics H on ``points`` collocation points N (> 2H;
    default :func:`collocation_points`)."""
    H = int(harmonics)
    N = collocation_points(H) if points is None else int(points)
    if H < 1 or N <= 2 * H:
        raise ValueError(f"need harmonics >= 1 and points > 2 * harmonics; got harmonics={H}, points={N}")
    theta = np.arange(N) * (2.0 * np.pi / N)
    co = system.coefficients(theta)
    s, m = system.speed, system.mass
    Kinv = np.linalg.inv(co.stiffness)
    q_hat = spectrum(_apply(Kinv, co.load))
    rhs = -_apply(Kinv, s * _apply(co.damping, series(q_hat, theta, 1)) + s**2 * m * series(q_hat, theta, 2))
    E, E1, E2 = trig_basis(theta, H)
    weight = np.r_[1.0, np.full(2 * H, 2.0)] / N  # Pi_H: c_b = weight_b sum_j E[j, b] x_j
    X, Y = Kinv @ co.damping, Kinv * m  # K^-1 C, K^-1 M
    c0 = weight[:, None] * (E.T @ rhs)
    if c0.size <= DENSE_LIMIT:
        c = _solve_dense(s, E, E1, E2, weight, X, Y, c0)
    else:
        c = _solve_krylov(s, E, E1, E2, weight, X, Y, c0)
    z_hat = q_hat.astype(complex)
    z_hat[0] += c[0]
    z_hat[1:H + 1] += 0.5 * (c[1::2] - 1j * c[2::2])
    return PeriodicSolution(system=system, harmonics=H, points=N, kinematic=z_hat)


DENSE_LIMIT = 640
"""Correction systems with more unknowns ((2H + 1) n) are solved by preconditioned GMRES, matrix-free."""


def _solve_dense(s, E, E1, E2, weight, X, Y, c0) -> np.ndarray:
    """(I + G) c = c0 with G[b, a] = weight_b sum_j E[j, b] (s E1[j, a] X_j + s^2 E2[j, a] Y_j), dense."""
    G = s * np.tensordot(E[:, :, None] * E1[:, None, :], X, axes=(0, 0))
    G += s**2 * np.tensordot(E[:, :, None] * E2[:, None, :], Y, axes=(0, 0))  # (b, a, i, l)
    P, n = c0.shape
    G = (weight[:, None, None, None] * G).transpose(0, 2, 1, 3).reshape(P * n, P * n)
    return np.linalg.solve(np.eye(P * n) + G, c0.ravel()).reshape(P, n)


def _solve_krylov(s, E, E1, E2, weight, X, Y, c0) -> np.ndarray:
    """The same system by GMRES, matrix-free (O(N n^2) per product), preconditioned per harmonic by its
    constant-coefficient part I + i k s mean(X) - k^2 s^2 mean(Y) (exact when K, C do not vary)."""
    P, n = c0.shape
    H = (P - 1) // 2

    def apply(x: np.ndarray) -> np.ndarray:
        c = x.reshape(P, n)
        g = _apply(X, s * (E1 @ c)) + _apply(Y, s**2 * (E2 @ c))
        return (c + weight[:, None] * (E.T @ g)).ravel()

    k = np.arange(1, H + 1)[:, None, None]
    blocks = np.linalg.inv(np.eye(n) + 1j * k * s * X.mean(0) - (k * s) ** 2 * Y.mean(0))  # (H, n, n)

    def precondition(x: np.ndarray) -> np.ndarray:
        c = x.reshape(P, n)
        z = np.einsum("kij,kj->ki", blocks, c[1::2] - 1j * c[2::2])  # cos - i sin: the e^{ik theta} amplitude
        out = np.empty_like(c)
        out[0] = c[0]  # the mean has no dynamic term
        out[1::2], out[2::2] = z.real, -z.imag
        return out.ravel()

    op = spla.LinearOperator((P * n, P * n), matvec=apply, dtype=float)
    pre = spla.LinearOperator((P * n, P * n), matvec=precondition, dtype=float)
    x, info = spla.gmres(op, c0.ravel(), M=pre, rtol=1e-11, atol=0.0, restart=200, maxiter=5)
    if info != 0:
        return _solve_dense(s, E, E1, E2, weight, X, Y, c0)
    return x.reshape(P, n)


def evaluate(solution: PeriodicSolution, theta: np.ndarray,
             coefficients: Coefficients | None = None) -> tuple[np.ndarray, np.ndarray | None]:
    """u (m, n) at the angles ``theta`` [rad] and the output (m, p) if the coefficients have an output
    map (else None); ``coefficients``: the system's coefficients at ``theta`` if already at hand."""
    sys_ = solution.system
    co = sys_.coefficients(theta) if coefficients is None else coefficients
    s = sys_.speed
    z1, z2 = series(solution.kinematic, theta, 1), series(solution.kinematic, theta, 2)
    rhs = co.load - s * _apply(co.damping, z1) - s**2 * sys_.mass * z2
    u = np.linalg.solve(co.stiffness, rhs[..., None])[..., 0]
    return u, None if co.output is None else _apply(co.output, u)


@dataclass(frozen=True)
class SteadyState:
    """Output of :func:`steady_state`: the solution, u (m, n) and output y (m, p) (or None) at the
    requested angles, and ``error_estimate``: max |y_H - y_prev| / max |y_H| (prev: the level below H;
    u if no output)."""

    solution: PeriodicSolution
    displacement: np.ndarray
    output: np.ndarray | None
    error_estimate: float


def relative_change(new: np.ndarray, old: np.ndarray, groups: tuple[slice, ...] | None = None) -> float:
    """max over ``groups`` of columns of max_k |new_k - old_k| / max_k |new_k| (Euclidean over a group's
    columns); one group of all columns by default."""
    out = 0.0
    for g in groups or (slice(None),):
        peak = np.max(np.linalg.norm(new[:, g], axis=1))
        if peak > 0.0:
            out = max(out, float(np.max(np.linalg.norm(new[:, g] - old[:, g], axis=1)) / peak))
    return out


def harmonic_levels(max_harmonics: int) -> list[int]:
    """The automatic sequence of H: 4, 8, 12, 20, 32, 48, ... (each ~1.5x the last, a multiple of 4),
    capped at ``max_harmonics``.  Steps of 1.5 rather than 2 keep the change between levels a close
    estimate once the series converges geometrically (a 2x step measures the error of H/2, which can
    be far larger than that of H when a frozen higher mode resonates with harmonics between them)."""
    levels = [min(4, max_harmonics)]
    while levels[-1] < max_harmonics:
        step = max(4, levels[-1] // 2)
        levels.append(min(-(-(levels[-1] + step) // 4) * 4, max_harmonics))
    return levels


def steady_state(system: PeriodicSystem, theta: np.ndarray, tolerance: float, harmonics: int | None = None,
                 max_harmonics: int = 32, groups: tuple[slice, ...] | None = None) -> SteadyState:
    """Steady state at ``theta`` with H = ``harmonics`` or, if None, the first H of
    :func:`harmonic_levels` (<= ``max_harmonics``) whose change from the previous level is below
    ``tolerance`` (relative to the peak, per column group of the output), judged by
    :func:`error_estimate`; a fixed H is compared with the level below it."""
    co = system.coefficients(theta)
    if harmonics is not None:
        below = [h for h in harmonic_levels(harmonics) if h < harmonics]
        levels = [below[-1], harmonics] if below else [harmonics]
    else:
        levels = harmonic_levels(max_harmonics)
    previous, changes, est = None, [], float("nan")
    for H in levels:
        sol = solve_periodic(system, H)
        u, y = evaluate(sol, theta, co)
        current = u if y is None else y
        if previous is not None:
            changes.append(relative_change(current, previous, groups))
            est = error_estimate(changes)
            if harmonics is None and est < tolerance:
                break
        previous = current
    return SteadyState(solution=sol, displacement=u, output=y, error_estimate=est)


def error_estimate(changes: list[float]) -> float:
    """Error of the last level from the changes between successive levels: the last change d, reduced
    to d rho / (1 - rho) when the last two changes fall geometrically fast (rho = d / d_before < 1/2:
    the tail of a geometric series); otherwise d itself (no evidence of fast convergence)."""
    d = changes[-1]
    if len(changes) >= 2 and changes[-2] > 0.0 and d / changes[-2] < 0.5:
        rho = d / changes[-2]
        return d * rho / (1.0 - rho)
    return d
