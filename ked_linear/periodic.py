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
  2H + 1 per coordinate): (I + Pi_H K^-1 B E) c = -Pi_H K^-1 B q, of size (2H + 1) n, block Toeplitz in
  the harmonics: dense up to :data:`DENSE_LIMIT` unknowns, else GMRES preconditioned by its bands;
* the solution at any angle is u = K^-1 (f - sigma C z' - sigma^2 M z''), z = q + Pi_H w (a trigonometric
  polynomial): with M and C zero it is the quasi-static solution exactly, and every harmonic of a
  constant-coefficient system up to H gets its exact frequency response.

The coefficients of a :class:`PeriodicSystem` may be any callable; :class:`ked_linear.sampled.SampledCoefficients` makes
them cheap on uniform grids (sampled once, trigonometric interpolation, error-checked).

The truncation error is that of treating harmonics above H of w with one quasi-static iteration,
~ (k sigma / omega)^4 |q_k|; it is estimated by comparing H with the level below it (:func:`steady_state`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .blockband import BlockBandedLU


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
    correction: np.ndarray | None = None
    """c = Pi_H w (2H + 1, n), real trigonometric coefficients [1, cos, sin, ...] (a start for the next level)."""
    banded: bool = False
    """The iterative solve needed the banded preconditioner (the next level then starts with it)."""


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


def solve_periodic(system: PeriodicSystem, harmonics: int, points: int | None = None,
                   start: PeriodicSolution | None = None) -> PeriodicSolution:
    """Steady state with ``harmonics`` dynamic harmonics H on ``points`` collocation points N (> 2H;
    default :func:`collocation_points`); ``start``: a solution at fewer harmonics of the same system,
    the first guess of the iterative solve (the answer does not depend on it)."""
    H = int(harmonics)
    N = collocation_points(H) if points is None else int(points)
    if H < 1 or N <= 2 * H:
        raise ValueError(f"need harmonics >= 1 and points > 2 * harmonics; got harmonics={H}, points={N}")
    return _solve_on(_Collocation(system, N), H, start)


class _Collocation:
    """What every level of the periodic solve on the same N collocation points shares: the
    coefficients there, K^-1, the quasi-static solution's spectrum, the right-hand side -K^-1 B q, X = K^-1 C,
    Y = K^-1 M and (on first use) their DFTs and the dense operator of the largest H asked for."""

    def __init__(self, system: PeriodicSystem, N: int):
        self.system, self.N = system, N
        self.theta = np.arange(N) * (2.0 * np.pi / N)
        co = system.coefficients(self.theta)
        s, m = system.speed, system.mass
        Kinv = np.linalg.inv(co.stiffness)
        self.q_hat = spectrum(_apply(Kinv, co.load))
        self.rhs = -_apply(Kinv, s * _apply(co.damping, _on_grid(self.q_hat, N, 1))
                           + s**2 * m * _on_grid(self.q_hat, N, 2))
        self.rhs_hat = np.fft.rfft(self.rhs, axis=0) / N
        self.X, self.Y = Kinv @ co.damping, Kinv * m  # K^-1 C, K^-1 M
        self._dft: tuple[np.ndarray, np.ndarray] | None = None
        self._dense: np.ndarray | None = None

    def projected_rhs(self, H: int) -> np.ndarray:
        """c0 = Pi_H rhs, real coefficients (2H + 1, n) [mean, 2 Re, -2 Im of the DFT: weight * E^T rhs]."""
        c0 = np.empty((2 * H + 1, self.rhs.shape[1]))
        c0[0] = self.rhs_hat[0].real
        c0[1::2], c0[2::2] = 2.0 * self.rhs_hat[1:H + 1].real, -2.0 * self.rhs_hat[1:H + 1].imag
        return c0

    def dft(self) -> tuple[np.ndarray, np.ndarray]:
        if self._dft is None:
            self._dft = (np.fft.fft(self.X, axis=0) / self.N, np.fft.fft(self.Y, axis=0) / self.N)
        return self._dft

    def dense(self, H: int, largest: int) -> np.ndarray:
        """I + G (P n, P n), P = 2H + 1: the leading block of the operator of ``largest`` harmonics (built
        once; its real coefficients are ordered by harmonic, so every smaller H is its leading block)."""
        if self._dense is None or self._dense.shape[0] < 2 * H + 1:
            n = self.X.shape[1]
            top = max(H, largest)
            G = _dense_operator(self.system.speed, self.X, self.Y, top, self.dft())
            G.reshape((2 * top + 1) * n, -1)[np.diag_indices((2 * top + 1) * n)] += 1.0
            self._dense = G
        P = 2 * H + 1
        G = self._dense[:P, :, :P, :]
        return G.reshape(P * G.shape[1], -1)


def _solve_on(col: _Collocation, H: int, start: PeriodicSolution | None = None,
              largest: int = 0) -> PeriodicSolution:
    """The level H on the collocation points of ``col`` (``largest``: the largest H that will be asked of
    ``col``, whose dense operator then serves the smaller ones)."""
    s, N = col.system.speed, col.N
    c0 = col.projected_rhs(H)
    banded = False
    if c0.size <= DENSE_LIMIT:
        if (2 * max(H, largest) + 1) * c0.shape[1] > DENSE_LIMIT:
            largest = H
        c = np.linalg.solve(col.dense(H, largest), c0.ravel()).reshape(c0.shape)
    else:
        E, E1, E2 = trig_basis(col.theta, H)
        weight = np.r_[1.0, np.full(2 * H, 2.0)] / N  # Pi_H: c_b = weight_b sum_j E[j, b] x_j
        c, banded = _solve_krylov(s, E, E1, E2, weight, col.X, col.Y, c0, _first_guess(start, c0.shape),
                                  cheap=not (start is not None and start.banded))
    z_hat = col.q_hat.astype(complex)
    z_hat[0] += c[0]
    z_hat[1:H + 1] += 0.5 * (c[1::2] - 1j * c[2::2])
    return PeriodicSolution(system=col.system, harmonics=H, points=N, kinematic=z_hat, correction=c,
                            banded=banded)


def _on_grid(coefficients: np.ndarray, N: int, derivative: int) -> np.ndarray:
    """:func:`series` on the N-point grid theta_j = 2 pi j / N of its own spectrum, by inverse FFT."""
    k = np.arange(coefficients.shape[0]).reshape((-1,) + (1,) * (coefficients.ndim - 1))
    return np.fft.irfft(coefficients * (1j * k) ** derivative, n=N, axis=0) * N


def _first_guess(start: PeriodicSolution | None, shape: tuple[int, int]) -> np.ndarray | None:
    """The correction of ``start`` padded with zero harmonics to ``shape`` (None if there is none)."""
    if start is None or start.correction is None or start.correction.shape[0] > shape[0]:
        return None
    guess = np.zeros(shape)
    guess[:start.correction.shape[0]] = start.correction
    return guess.ravel()


DENSE_LIMIT = 640
"""Correction systems with more unknowns ((2H + 1) n) are solved by preconditioned GMRES, matrix-free."""

SHARED_GRID = True
"""The automatic levels of :func:`steady_state` share the collocation points of the largest when it is
solved dense (see there); False: each level on its own :func:`collocation_points`."""


def _solve_dense(s, E, E1, E2, weight, X, Y, c0) -> np.ndarray:
    """(I + G) c = c0 with G[b, a] = weight_b sum_j E[j, b] (s E1[j, a] X_j + s^2 E2[j, a] Y_j), dense,
    built from the DFT of X and Y (:func:`_dense_operator`)."""
    P, n = c0.shape
    G = _dense_operator(s, X, Y, (P - 1) // 2).reshape(P * n, P * n)
    G[np.diag_indices_from(G)] += 1.0
    return np.linalg.solve(G, c0.ravel()).reshape(P, n)


def _dense_operator(s: float, X: np.ndarray, Y: np.ndarray, H: int,
                    dft: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """G (2H + 1, n, 2H + 1, n) on the real coefficients [1, cos, sin, ...]: the complex blocks
    G^[k, l] = (i l s) X^_{k-l} - (l s)^2 Y^_{k-l} (X^_d the DFT of X on the N collocation points:
    block Toeplitz), combined for an input cos(l theta) = (e^{il} + e^{-il}) / 2 and sin(l theta) =
    -i (e^{il} - e^{-il}) / 2, and read out as 2 Re (cos), -2 Im (sin), Re (mean) of harmonic k.
    ``dft``: (X^, Y^) if already at hand."""
    N, n = X.shape[0], X.shape[1]
    Xh, Yh = (np.fft.fft(X, axis=0) / N, np.fft.fft(Y, axis=0) / N) if dft is None else dft
    k, l = np.arange(H + 1)[:, None], np.arange(1, H + 1)[None, :]

    def blocks(lv: np.ndarray) -> np.ndarray:  # G^[k, lv], (H + 1, H, n, n), in place (few large temporaries)
        d = (k - lv) % N
        out = Xh[d]
        out *= (1j * s * lv)[..., None, None]
        y = Yh[d]
        y *= ((s * lv) ** 2)[..., None, None]
        out -= y
        return out

    plus, minus = blocks(l), blocks(-l)
    # by cos l: (plus + minus) / 2, by sin l: -i (plus - minus) / 2, read out as 2 Re, -2 Im (Re for the
    # mean): written straight from the sum's and difference's real and imaginary parts (the factors are
    # powers of 2, so the entries are those of the halved and doubled forms to the bit)
    Q = plus - minus
    P = plus
    P += minus  # (k, l, i, j)
    G = np.empty((2 * H + 1, n, 2 * H + 1, n))
    G[:, :, 0, :] = 0.0  # the mean of the input has no dynamic term
    cos, sin = slice(1, None, 2), slice(2, None, 2)
    G[0, :, cos, :] = 0.5 * P[0].real.transpose(1, 0, 2)
    G[0, :, sin, :] = 0.5 * Q[0].imag.transpose(1, 0, 2)
    G[1::2, :, cos, :] = P[1:].real.transpose(0, 2, 1, 3)
    np.negative(P[1:].imag.transpose(0, 2, 1, 3), out=G[2::2, :, cos, :])
    G[1::2, :, sin, :] = Q[1:].imag.transpose(0, 2, 1, 3)
    G[2::2, :, sin, :] = Q[1:].real.transpose(0, 2, 1, 3)
    return G


def _solve_krylov(s, E, E1, E2, weight, X, Y, c0, x0=None, cheap: bool = True) -> tuple[np.ndarray, bool]:
    """The same system by GMRES, matrix-free (O(N n^2) per product).  Preconditioned first by the
    operator's theta-averaged part, block diagonal in the harmonics (I + i k s mean X - (k s)^2 mean Y,
    exact when K and C do not vary: cheap, enough for slowly varying coefficients); if that has not
    converged in :data:`CHEAP_ITERATIONS` iterations, on from there with the operator truncated to
    the coefficients' harmonics |k - l| <= :data:`PRECONDITIONER_BANDS` (block banded: its block LU,
    :class:`ked_linear.blockband.BlockBandedLU`).  ``cheap``: False skips the first stage.  Returns c and
    whether the banded stage was needed."""
    P, n = c0.shape
    H = (P - 1) // 2

    XY = np.concatenate([s * X, s**2 * Y], axis=2)  # one batched product per matvec: [s X, s^2 Y] [E1 c; E2 c]

    def apply(x: np.ndarray) -> np.ndarray:
        c = x.reshape(P, n)
        g = (XY @ np.concatenate([E1 @ c, E2 @ c], axis=1)[..., None])[..., 0]
        return (c + weight[:, None] * (E.T @ g)).ravel()

    k = np.arange(1, H + 1)[:, None, None]
    blocks = np.linalg.inv(np.eye(n) + 1j * k * s * X.mean(0) - (k * s) ** 2 * Y.mean(0))  # (H, n, n)

    def averaged(x: np.ndarray) -> np.ndarray:
        c = x.reshape(P, n)
        z = np.einsum("kij,kj->ki", blocks, c[1::2] - 1j * c[2::2])  # cos - i sin: the e^{ik theta} amplitude
        out = np.empty_like(c)
        out[0] = c[0]  # the mean has no dynamic term
        out[1::2], out[2::2] = z.real, -z.imag
        return out.ravel()

    b = c0.ravel()
    tol = KRYLOV_TOLERANCE * np.linalg.norm(b)
    x = np.zeros_like(b) if x0 is None else np.asarray(x0, dtype=float)
    if cheap and CHEAP_ITERATIONS > 0:
        x, done = _gmres(apply, averaged, b, x, tol, CHEAP_ITERATIONS, 1)
        if done:
            return x.reshape(P, n), False
    try:
        lu = _banded_operator(s, X, Y, H, PRECONDITIONER_BANDS)
    except np.linalg.LinAlgError:  # a (nearly) singular pivot block: no damping, a harmonic at a frozen resonance
        return _solve_dense(s, E, E1, E2, weight, X, Y, c0), True

    def banded(x: np.ndarray) -> np.ndarray:
        c = x.reshape(P, n)
        a = np.empty((H + 1, n), dtype=complex)  # the amplitudes of e^{ik theta}, k = 0 .. H
        a[0] = c[0]
        a[1:] = 0.5 * (c[1::2] - 1j * c[2::2])
        a = lu.solve(a.ravel()).reshape(H + 1, n)
        out = np.empty((P, n))
        out[0] = a[0].real
        out[1::2], out[2::2] = 2.0 * a[1:].real, -2.0 * a[1:].imag
        return out.ravel()

    x, done = _gmres(apply, banded, b, x, tol, 200, 5)
    if not done:
        return _solve_dense(s, E, E1, E2, weight, X, Y, c0), True
    return x.reshape(P, n), True


def _gmres(apply: Callable[[np.ndarray], np.ndarray], precondition: Callable[[np.ndarray], np.ndarray],
           b: np.ndarray, x: np.ndarray, tol: float, restart: int, cycles: int) -> tuple[np.ndarray, bool]:
    """GMRES preconditioned on the right (A M y = b, x = M y: its residual is that of A x = b) from ``x``,
    at most ``cycles`` cycles of ``restart`` iterations, until |b - A x| <= ``tol``; returns x and whether
    it got there.  The Krylov basis is orthogonalized by classical Gram-Schmidt applied twice (two matrix
    products per iteration), the small least-squares problem by Givens rotations.

    Why not ``scipy.sparse.linalg.gmres``: scipy 1.17's loops in Python over the basis vectors in every
    iteration.  Measured (solve_periodic, thesis source linkage, medians of 5 on a loaded 2-core machine,
    /tmp script swapping in scipy's gmres with the same preconditioner, restart and absolute tolerance;
    answers equal within 3e-12 of the peak): extender 300 rpm H = 32 5.4 ms against 10.7 ms, distributed
    100 and 300 rpm H = 32 74 and 85 ms against 81 and 98 ms, H = 16 10 and 34 ms against 12 and 35 ms.
    Tested against a dense solve (tests/test_linear_speed.py)."""
    for _ in range(cycles):
        r = b - apply(x)
        beta = float(np.linalg.norm(r))
        if beta <= tol:
            return x, True
        V = np.empty((restart + 1, b.size))
        R = np.zeros((restart + 1, restart))  # the Hessenberg matrix, rotated to upper triangular
        g = np.zeros(restart + 1)
        cs, sn = np.zeros(restart), np.zeros(restart)
        V[0], g[0] = r / beta, beta
        j = 0
        for j in range(restart):
            w = apply(precondition(V[j]))
            h = V[:j + 1] @ w
            w -= h @ V[:j + 1]
            h2 = V[:j + 1] @ w  # the second pass: orthogonal to rounding whatever the first lost
            w -= h2 @ V[:j + 1]
            h += h2
            norm = float(np.linalg.norm(w))
            for i in range(j):  # the earlier rotations on the new column
                h[i], h[i + 1] = cs[i] * h[i] + sn[i] * h[i + 1], -sn[i] * h[i] + cs[i] * h[i + 1]
            d = float(np.hypot(h[j], norm))
            cs[j], sn[j] = (1.0, 0.0) if d == 0.0 else (h[j] / d, norm / d)
            R[:j + 1, j], R[j, j] = h, d
            g[j + 1], g[j] = -sn[j] * g[j], cs[j] * g[j]
            if abs(g[j + 1]) <= tol or norm == 0.0:
                break
            V[j + 1] = w / norm
        m = j + 1
        y = _upper_solve(R[:m, :m], g[:m])
        x = x + precondition(y @ V[:m])
    r = b - apply(x)
    return x, bool(np.linalg.norm(r) <= tol)


def _upper_solve(R: np.ndarray, g: np.ndarray) -> np.ndarray:
    """R^-1 g for the upper triangular R of :func:`_gmres` (m <= its restart): numpy's LU solve, whose
    partial pivoting keeps the diagonal pivots of a triangular matrix (its multipliers are zero), so this is
    back substitution; not ``scipy.linalg.solve_triangular``, whose import (scipy.linalg clones numpy's
    namespace for the array API) costs a fresh ``ked check`` process ~0.1 s."""
    return np.linalg.solve(R, g)


CHEAP_ITERATIONS = 20
"""GMRES iterations with the theta-averaged preconditioner before the banded one is built."""

PRECONDITIONER_BANDS = 2
"""Coefficient harmonics kept in the preconditioner of the iterative periodic solve (the operator's
bands |k - l| <= this; a few GMRES iterations where the theta-average alone needs hundreds)."""

KRYLOV_TOLERANCE = 1e-11
"""Relative residual at which the iterative periodic solve stops."""


def _banded_operator(s: float, X: np.ndarray, Y: np.ndarray, H: int, bands: int) -> BlockBandedLU:
    """Block LU (:class:`ked_linear.blockband.BlockBandedLU`) of the collocation operator in complex
    amplitudes of the nonnegative harmonics (k, l = 0 .. H) kept to the bands |k - l| <= ``bands``: block
    (k, l) = delta_kl I + (i l s) X^_{k-l} - (l s)^2 Y^_{k-l}, X^_d the DFT of X on the N collocation points
    (the operator's coupling, block Toeplitz in the harmonics).  A real solution's amplitudes of -k are the
    conjugates of those of k; the coupling of k to the conjugates, |k + l| <= ``bands`` (the lowest
    harmonics, where the operator is near the identity), is left out: half the size of the system on all
    harmonics -H .. H, for a preconditioner."""
    N, n = X.shape[0], X.shape[1]
    d = np.arange(-bands, bands + 1)  # band[k, bands + e] is block (k, l = k + e): coupled by X^_{-e}, Y^_{-e}
    Xh = np.fft.fft(X, axis=0)[-d % N] / N  # only the bands' coefficients
    Yh = np.fft.fft(Y, axis=0)[-d % N] / N
    l = (np.arange(H + 1)[:, None] + d[None, :]).astype(float)
    band = (1j * s * l)[..., None, None] * Xh[None] - ((s * l) ** 2)[..., None, None] * Yh[None]
    band[:, bands] += np.eye(n)
    return BlockBandedLU(band)


def evaluate(solution: PeriodicSolution, theta: np.ndarray,
             coefficients: Coefficients | None = None) -> tuple[np.ndarray, np.ndarray | None]:
    """u (m, n) at the angles ``theta`` [rad] and the output (m, p) if the coefficients have an output
    map (else None); ``coefficients``: the system's coefficients at ``theta`` if already at hand."""
    co = solution.system.coefficients(theta) if coefficients is None else coefficients
    return _Evaluator(solution.system, theta, co)(solution)


class _Evaluator:
    """:func:`evaluate` at fixed angles for several solutions of one system (the levels of
    :func:`steady_state`): the phases e^{i k theta} at the angles computed once."""

    def __init__(self, system: PeriodicSystem, theta: np.ndarray, co: Coefficients, points: int = 0):
        """``points``: the most collocation points of the solutions to come (their phases made at once)."""
        self.system, self.co = system, co
        self.theta = np.asarray(theta, dtype=float)
        self._phase = np.empty((self.theta.size, 0), dtype=complex)
        self.phase(points // 2 + 1)

    def phase(self, count: int) -> np.ndarray:
        """e^{i k theta} (m, count), k = 0 .. count - 1 (the table grows to the largest asked for)."""
        if self._phase.shape[1] < count:
            self._phase = np.exp(1j * np.outer(self.theta, np.arange(count)))
        return self._phase[:, :count]

    def __call__(self, solution: PeriodicSolution) -> tuple[np.ndarray, np.ndarray | None]:
        co, s, Z = self.co, self.system.speed, solution.kinematic
        k = np.arange(Z.shape[0])
        # z' and z'' of the series (as :func:`series`) in one product: weights 2 i k and -2 k^2 (k > 0)
        both = np.concatenate([(2j * k)[:, None] * Z, (-2.0 * k**2)[:, None] * Z], axis=1)
        z12 = (self.phase(k.size) @ both).real
        z1, z2 = z12[:, :Z.shape[1]], z12[:, Z.shape[1]:]
        rhs = co.load - s * _apply(co.damping, z1) - s**2 * self.system.mass * z2
        u = np.linalg.solve(co.stiffness, rhs[..., None])[..., 0]  # not K^-1 once: near toggle K is ill-conditioned
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
    diff = new - old
    for g in groups or (slice(None),):  # the norms' maxima as the square roots of the largest squares
        peak = float(np.sqrt(np.max(np.einsum("ij,ij->i", new[:, g], new[:, g]))))
        if peak > 0.0:
            out = max(out, float(np.sqrt(np.max(np.einsum("ij,ij->i", diff[:, g], diff[:, g])))) / peak)
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
    :func:`error_estimate`; a fixed H is compared with the level below it.

    When the largest level is solved dense (:data:`DENSE_LIMIT`, :data:`SHARED_GRID`) every level uses its
    collocation points: one :class:`_Collocation` (coefficients, K^-1, q, X, Y) for all, the operator of the
    largest H built once from the first level reaching a third of it (the smaller ones are its leading
    blocks).  The last level's answer is that of :func:`solve_periodic` at its H; a lower one differs from
    its own on fewer points by their aliasing (up to 5e-6 of the peak on the thesis grid at 30 rpm, H = 8),
    and the change between levels measures the truncation at H alone."""
    co = system.coefficients(theta)
    if harmonics is not None:
        below = [h for h in harmonic_levels(harmonics) if h < harmonics]
        levels = [below[-1], harmonics] if below else [harmonics]
    else:
        levels = harmonic_levels(max_harmonics)
    previous, changes, est, sol = None, [], float("nan"), None
    grids: dict[int, _Collocation] = {}  # the levels on the same collocation points share their setup
    # every level's evaluation at theta shares its phases
    at = _Evaluator(system, theta, co, max(collocation_points(H) for H in levels))
    largest = {collocation_points(H): H for H in levels}
    shared = SHARED_GRID and (2 * levels[-1] + 1) * system.mass.size <= DENSE_LIMIT
    for H in levels:
        N = collocation_points(levels[-1] if shared else H)
        if N not in grids:
            grids = {N: _Collocation(system, N)}  # a finer grid: the coarser one is not needed again
        sol = _solve_on(grids[N], H, start=sol, largest=(levels[-1] if 3 * H >= levels[-1] else H) if shared
                        else largest[N])
        u, y = at(sol)
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
