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

The step matrices are built vectorized over the steps, in chunks small enough to stay in the cache
(:data:`CHUNK_BYTES`); SDIRK2's by blocks, never forming the 2n x 2n resolvents, from the inverses of
the n x n stage matrices Z (by Cholesky when they are positive definite, both stages in one call).  The
stage coefficients of sampled coefficients come straight from their trigonometric series (one matrix
product per chunk, or inverse real FFTs when a whole turn is one chunk; Z itself being linear in K and C);
others are evaluated on two whole-turn grids per level (:data:`COEFFICIENT_BYTES`).  The chunks' matrices
are multiplied in a balanced tree.  The first three levels of the automatic plan are built together where
they fit in one chunk (:func:`_level_batch`).
The eigenvalues of Phi are the multipliers; the periodic steady state is asymptotically stable iff all
|mu| < 1.
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass, replace

import numpy as np

from .periodic import Coefficients, PeriodicSystem
from .sampled import SampledCoefficients, _bounds, _triangle_index, inverse

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
    """C(theta) = 0: the system is Hamiltonian.  Sampled coefficients with an interpolant: every sample of
    C (or of F C F in the flexibility form) is zero, read off the interpolant's spectrum without evaluating
    anything (the probe below costs ~0.25 ms of a 10 ms joints-model solve); else probed at 8 angles over
    the cycle."""
    co = system.coefficients
    if isinstance(co, SampledCoefficients) and co.interpolant is not None:
        bounds = _bounds(co.layout, co.symmetric)
        return not np.any(co.interpolant.spectrum[bounds[1]:bounds[2]])
    return not np.any(co(np.linspace(0.0, 2.0 * np.pi, 8, endpoint=False)).damping)


def _stage_offsets(damped: bool, h: float) -> np.ndarray:
    """Stage times within a step (2,) [s]: Gauss-Legendre nodes, or SDIRK2's gamma h and h."""
    return np.array([SDIRK_GAMMA * h, h]) if damped else GAUSS * h


def _stage_coefficients(system: PeriodicSystem, steps: int, first: int, count: int, damped: bool) -> Coefficients:
    """The coefficients at the two stage angles of steps first .. first + count - 1: the first stage's
    (count,) then the second's; with first = 0 and count = steps two uniform full-turn grids (interpolated
    when the coefficients are sampled, see ``sampled.SampledCoefficients``: then K and C only, the load
    zero, as the propagator needs no more)."""
    h = system.period / steps
    t = (first + np.arange(count)) * h
    c = _stage_offsets(damped, h)
    theta = system.speed * np.concatenate([t + c[0], t + c[1]])
    if isinstance(system.coefficients, SampledCoefficients):  # K and C only
        K, C = system.coefficients.stiffness_damping(theta)
        return Coefficients(stiffness=K, damping=C, load=np.zeros((theta.size, system.mass.size)))
    return system.coefficients(theta)


@dataclass(frozen=True)
class _Series:
    """K and C of a sampled system as one real trigonometric series: the value (2, n, n) at theta is
    ``(basis(theta) @ rows)[expand]``, basis [1, cos t, sin t, ..., cos Ht, sin Ht], rows (2H + 1,
    columns) from the interpolant's spectrum (the interpolant ``SampledCoefficients`` evaluates by
    inverse FFTs on whole-turn grids, here by one matrix product per chunk of steps, for K and C only,
    straight into the chunk's layout; H at most G/2 of the G samples: see :data:`SERIES_TAIL`)."""

    harmonics: int
    rows: np.ndarray
    expand: np.ndarray
    """The column of ``rows`` of each entry of (K, C) (2 n^2,): a symmetric field's rows are its upper
    triangle's (as sampled)."""
    split: int
    """The columns of ``rows`` before this one are K's, the others C's."""
    form: str = "stiffness"
    """"stiffness": the fields are K and C; "flexibility": F = K^-1 and F C F (``SampledCoefficients``)."""

    def zk(self, mass: np.ndarray, a: float) -> _Series | None:
        """The series of (Z, K) instead of (K, C), Z = M + a C + a^2 K (SDIRK2's stage matrix, linear
        in the coefficients), when K and C have the same layout (else None)."""
        n = mass.size
        if 2 * self.split != self.rows.shape[1]:
            return None
        T = self.split
        rows = np.empty_like(self.rows)
        np.multiply(self.rows[:, :T], a * a, out=rows[:, :T])
        rows[:, :T] += a * self.rows[:, T:]
        rows[:, T:] = self.rows[:, :T]
        rows[0, self.expand[np.arange(n) * (n + 1)]] += mass  # the constant term's diagonal
        return replace(self, rows=rows)

    def basis(self, theta0: float | np.ndarray, step: float, steps: int, j: np.ndarray) -> np.ndarray:
        """The basis (j.size, 2H + 1) at theta0 + step * j, step = +-2 pi / steps (j integer: the
        phases k j are reduced modulo ``steps`` exactly); for several theta0 (r,), the r bases one after
        another, (r j.size, 2H + 1), from one table of the phases k j."""
        k = np.arange(1, self.harmonics + 1)
        offsets = np.atleast_1d(np.asarray(theta0, dtype=float))
        z = np.exp(1j * step * np.arange(steps))[np.outer(j, k) % steps]
        z = z[None] * np.exp(1j * np.outer(offsets, k))[:, None, :]  # (r, j, H)
        E = np.empty((offsets.size, j.size, 2 * self.harmonics + 1))
        E[..., 0] = 1.0
        E[..., 1::2], E[..., 2::2] = z.real, z.imag
        return E.reshape(-1, E.shape[-1])


def _series(system: PeriodicSystem) -> _Series | None:
    """K and C as a :class:`_Series` when the coefficients are sampled in the stiffness form, or the
    flexibility F = K^-1 and F C F in the flexibility form (``form``); None for a plain callable."""
    co = system.coefficients
    if not isinstance(co, SampledCoefficients) or co.form not in ("stiffness", "flexibility"):
        return None
    n = system.mass.size
    known = _SERIES.setdefault(co, {})
    if n not in known:
        known[n] = _series_of(co, n)
    return known[n]


_SERIES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
"""The series of each sampled coefficients object (by its size n), computed once (every level asks for
it), forgotten with the coefficients.  Keyed by the object itself (identity: its samples never change
once taken), its arrays read-only; two threads asking at once may both compute it, to the same value."""


def _series_of(co: SampledCoefficients, n: int) -> _Series | None:
    """:func:`_series` of sampled coefficients."""
    spectrum, G = co.interpolant.spectrum, co.interpolant.points  # (F, G/2 + 1): values 2 Re sum d_k e^{ikt}
    columns, start, sizes = [], 0, []
    for shape, sym in zip(co.layout[:2], co.symmetric[:2]):
        if shape != (n, n):
            return None
        columns.append(start + (_triangle_index(n) if sym else np.arange(n * n)))
        sizes.append(n * (n + 1) // 2 if sym else n * n)
        start += sizes[-1]
    d = spectrum[:start]  # K's and C's columns, frequencies 0 .. G/2: (columns, G/2 + 1)
    # 2 Re sum_k d_k e^{i k t} = 2 d_0 + sum_k 2 Re(d_k) cos kt - 2 Im(d_k) sin kt
    rows = np.empty((G + 1, d.shape[0]))
    rows[0] = 2.0 * d[:, 0].real
    rows[1::2], rows[2::2] = 2.0 * d[:, 1:].real.T, -2.0 * d[:, 1:].imag.T
    # the harmonics whose whole tail is round-off: at most SERIES_TAIL of each field's largest coefficient
    tail = np.zeros(G // 2 + 1)
    for f in (slice(0, sizes[0]), slice(sizes[0], sizes[0] + sizes[1])):
        peak = np.max(np.abs(rows[:, f]), initial=0.0)
        if peak > 0.0:
            size = np.max(np.abs(rows[1::2, f]) + np.abs(rows[2::2, f]), axis=1) / peak  # (G/2,)
            tail[:-1] = np.maximum(tail[:-1], np.cumsum(size[::-1])[::-1])
    # (none dropped in the flexibility form: K = F^-1 amplifies an error of F by F's condition number)
    H = int(np.argmax(tail <= SERIES_TAIL)) if co.form == "stiffness" else G // 2  # tail[H]: harmonics above H
    if start < SERIES_MIN_COLUMNS * H:  # a tiny system: whole-turn FFTs are cheaper than the basis
        return None
    rows, expand = np.ascontiguousarray(rows[:2 * H + 1]), np.concatenate(columns)
    rows.flags.writeable = expand.flags.writeable = False  # kept in _SERIES and shared by every level
    return _Series(harmonics=H, rows=rows, expand=expand, split=sizes[0], form=co.form)


SERIES_MIN_COLUMNS = 1.0
"""The series is used when K and C have at least this many sampled columns per harmonic (below it,
a 2-coordinate tip model, computing the basis costs more than the product it saves)."""

SERIES_TAIL = 1e-14
"""Harmonics of the coefficients' series dropped from the top while the sum of their amplitudes stays
below this fraction of the field's largest coefficient (the interpolant's round-off noise: the values
change by no more than the rounding of their own evaluation)."""


def _stage_fields(system: PeriodicSystem, series: _Series | None, steps: int, first: int, count: int,
                  damped: bool) -> tuple[np.ndarray, np.ndarray]:
    """K and C (2, count, n, n) at the two stage angles (first stage, second stage) of steps first ..
    first + count - 1 of ``steps`` per cycle: from the series if there is one, else from the system."""
    n = system.mass.size
    if series is None:
        co = _stage_coefficients(system, steps, first, count, damped)
        return co.stiffness.reshape(2, count, n, n), co.damping.reshape(2, count, n, n)
    c = _stage_offsets(damped, system.period / steps)
    if first == 0 and count == steps and 2 * series.harmonics < steps:
        values = _whole_turn_values(series, system.speed * c, np.sign(system.speed), steps)
    else:
        step = np.sign(system.speed) * 2.0 * np.pi / steps
        E = series.basis(system.speed * c, step, steps, first + np.arange(count))  # first stages, then second
        values = E @ series.rows
    fields = np.take(values, series.expand, axis=1).reshape(2, count, 2, n, n)
    return fields[:, :, 0], fields[:, :, 1]


def _whole_turn_values(series: _Series, offsets: np.ndarray, sign: float, steps: int) -> np.ndarray:
    """The series' rows' values (r steps, columns) on the r whole-turn grids offsets[i] + sign 2 pi j /
    steps, j = 0 .. steps - 1, one grid after the other (as ``series.basis(...) @ series.rows``), by one
    inverse real FFT per column: O(steps log steps) against the basis product's O(steps H) per column
    (needs 2 H < steps: no harmonic folds onto another on the grid)."""
    H, rows = series.harmonics, series.rows
    k = np.arange(H + 1)
    a = np.empty((H + 1, rows.shape[1]), dtype=complex)  # the e^{ik theta} amplitudes: rows = 2 Re, -2 Im
    a[0] = rows[0]
    a[1:].real, a[1:].imag = 0.5 * rows[1::2], -0.5 * rows[2::2]
    b = np.zeros((offsets.size, steps // 2 + 1, rows.shape[1]), dtype=complex)
    b[:, :H + 1] = a[None] * np.exp(1j * np.outer(offsets, k))[:, :, None]
    if sign < 0:  # sum_k Re(b_k e^{-ik t}) = sum_k Re(conj(b_k) e^{ik t})
        np.conjugate(b, out=b)
    return (np.fft.irfft(b, n=steps, axis=1) * steps).reshape(offsets.size * steps, -1)


def step_matrices(system: PeriodicSystem, steps: int, first: int = 0, count: int | None = None) -> np.ndarray:
    """The step matrices (count, 2n, 2n) of steps first .. first + count - 1 of ``steps`` per cycle
    (default: all), step 0 starting at theta = 0: Gauss-Legendre (symplectic) if the system is undamped
    (:func:`undamped`), else SDIRK2 (L-stable)."""
    count = steps - first if count is None else count
    return _step_source(system, steps, not undamped(system), whole=False)(first, count)


def _step_source(system: PeriodicSystem, steps: int, damped: bool, whole: bool = True):
    """A function (first, count) -> the step matrices (count, 2n, 2n) of steps first .. first + count - 1:
    damped with a series, from the stage matrices Z and K evaluated straight from their series; else from
    K and C (on whole-turn grids if ``whole`` and they fit, :func:`_whole_turn_fields`)."""
    h = system.period / steps
    series = _series(system)
    if series is not None and series.form == "flexibility":
        def from_flexibility(first: int, count: int) -> np.ndarray:
            # K = F^-1 and C = K (F C F) K per stage angle, as SampledCoefficients rebuilds them
            Fl, Cf = _stage_fields(system, series, steps, first, count, damped)
            K = _inverse(Fl)
            K = 0.5 * (K + np.swapaxes(K, -1, -2))
            return _steps(system, K, K @ Cf @ K, h, damped)

        return from_flexibility
    zk = series.zk(system.mass, SDIRK_GAMMA * h) if damped and series is not None else None
    if zk is not None:
        def from_zk(first: int, count: int) -> np.ndarray:
            Z, K = _stage_fields(system, zk, steps, first, count, damped)
            return _sdirk_steps_from(system.mass, K, None, h, Z=Z)

        return from_zk
    fields = _whole_turn_fields(system, series, steps, damped) if whole else None

    def from_kc(first: int, count: int) -> np.ndarray:
        K, C = fields(first, count) if fields is not None else _stage_fields(system, series, steps, first, count,
                                                                               damped)
        return _steps(system, K, C, h, damped)

    return from_kc


def _steps(system: PeriodicSystem, K: np.ndarray, C: np.ndarray, h: float, damped: bool) -> np.ndarray:
    """Step matrices (count, 2n, 2n) from K and C (2, count, n, n) at the two stage angles of each step."""
    if damped:
        return _sdirk_steps_from(system.mass, K, C, h)
    count = K.shape[1]
    a = _state_matrices(system, Coefficients(stiffness=K.reshape((2 * count,) + K.shape[2:]),
                                             damping=C.reshape((2 * count,) + C.shape[2:]),
                                             load=np.zeros((2 * count, system.mass.size))))
    return _gauss_steps(a[:count], a[count:], h)


SDIRK_GAMMA = 1.0 - 1.0 / np.sqrt(2.0)


def _resolvent(system: PeriodicSystem, theta: np.ndarray, a: float) -> np.ndarray:
    """(I - a A(theta))^-1 for each angle, (m, 2n, 2n), via the n x n matrix Z = M + a C + a^2 K (the
    reference form of the resolvent; :func:`_sdirk_steps_from` applies it by blocks instead)."""
    co = system.coefficients(theta)
    m = system.mass
    Zi = np.linalg.inv(np.eye(m.size) * m + a * co.damping + a**2 * co.stiffness)
    ZK, ZM = Zi @ co.stiffness, Zi * m
    eye = np.broadcast_to(np.eye(m.size), ZK.shape)
    top = np.concatenate([eye - a**2 * ZK, a * ZM], axis=2)
    bottom = np.concatenate([-a * ZK, ZM], axis=2)
    return np.concatenate([top, bottom], axis=1)


def _sdirk_steps_from(m: np.ndarray, K: np.ndarray, C: np.ndarray | None, h: float | np.ndarray,
                      Z: np.ndarray | None = None) -> np.ndarray:
    """SDIRK2 step matrices x_{j+1} = R(t_j + h) [(1 - alpha) I + alpha R(t_j + gamma h)] x_j,
    R = (I - gamma h A)^-1, alpha = (1 - gamma) / gamma, from K and C (2, count, n, n) at the stage
    angles (first stage t_j + gamma h, second t_j + h), or K and Z (below) if Z is given; ``h``: the step
    length, or one per step (count, 1, 1).

    By blocks, never forming R: for x = (u, v), R x = (u + a y, y) with y = W (M v - a K u),
    W = Z^-1, Z = M + a C + a^2 K, a = gamma h (the Z-form of :func:`_resolvent`).  With P = -a W K and
    Q = W M of each stage: stage 1 on X = I gives Y1 = [P1, Q1]; B = (1 - alpha) I + alpha R1 =
    [[I, 0] + alpha a Y1; (1 - alpha) [0, I] + alpha Y1]; stage 2, y2 = W2 (M Bv - a K2 Bu) =
    [P2, (1 - alpha) Q2] + alpha (Q2 + a P2) Y1, and S = [Bu + a y2; y2].  Per step: two n x n inverses
    (one batched call for both stages), W K (n^3) and one n x n x 2n product: cheaper than two batched
    solves with 2n right-hand sides."""
    count, n = K.shape[1], m.size
    a = SDIRK_GAMMA * h
    alpha = (1.0 - SDIRK_GAMMA) / SDIRK_GAMMA
    diag = np.arange(n)
    if Z is None:
        Z = K * (a * a)
        Z += a * C
        Z[:, :, diag, diag] += m
    W = _inverse(Z)
    Z = np.empty_like(W)
    P = np.matmul(W, K, out=Z)
    P *= -a
    Q = np.multiply(W, m, out=W)  # W diag(m): columns scaled
    Y1 = np.concatenate([P[0], Q[0]], axis=2)
    G2 = Q[1] + a * P[1]
    S = np.empty((count, 2 * n, 2 * n))
    y2 = S[:, n:]
    np.matmul(G2, Y1, out=y2)
    y2 *= alpha
    y2[:, :, :n] += P[1]
    y2[:, :, n:] += (1.0 - alpha) * Q[1]
    top = S[:, :n]
    np.multiply(y2, a, out=top)
    Y1 *= alpha * a
    top += Y1
    top[:, diag, diag] += 1.0
    return S


def _inverse(Z: np.ndarray) -> np.ndarray:
    """Z^-1 of symmetric matrices (..., n, n): by Cholesky (Z = L L^T, Z^-1 = L^-T L^-1, the triangular
    inverse by blocks, vectorized over the matrices) when every Z is positive definite (M > 0 and K, C
    positive semi-definite: unstressed, or prestressed short of buckling), else by LU (numpy's inv); for
    n <= 2 in closed form (:func:`ked_linear.sampled.inverse`)."""
    if Z.shape[-1] <= 2:
        return inverse(Z)
    try:
        L = np.linalg.cholesky(Z)
    except np.linalg.LinAlgError:
        return np.linalg.inv(Z)
    Li = _lower_inverse(L)
    # a contiguous transpose: numpy's matmul of stacked small matrices takes its BLAS path only for
    # contiguous operands (measured: 1024 6 x 6 products 0.16 ms from the swapped view, 0.05 from a copy)
    return np.matmul(np.ascontiguousarray(np.swapaxes(Li, -1, -2)), Li)


def _lower_inverse(L: np.ndarray) -> np.ndarray:
    """L^-1 of lower triangular matrices (..., n, n) with a positive diagonal: by halves,
    [[A, 0], [B, D]]^-1 = [[A^-1, 0], [-D^-1 B A^-1, D^-1]] (A and D in one call when of equal size),
    down to blocks of at most 10 solved by forward substitution row by row (each row one product over
    all the matrices at once)."""
    k = L.shape[-1]
    if k > 10:
        h = k // 2
        if 2 * h == k:
            both = _lower_inverse(np.stack([L[..., :h, :h], L[..., h:, h:]]))
            A, D = both[0], both[1]
        else:
            A, D = _lower_inverse(L[..., :h, :h]), _lower_inverse(L[..., h:, h:])
        out = np.zeros_like(L)
        out[..., :h, :h], out[..., h:, h:] = A, D
        out[..., h:, :h] = -(D @ (L[..., h:, :h] @ A))
        return out
    X = np.zeros_like(L)
    d = 1.0 / np.diagonal(L, axis1=-2, axis2=-1)
    for i in range(k):
        X[..., i, i] = d[..., i]
        if i:
            X[..., i, :i] = -np.einsum("...j,...jk->...k", L[..., i, :i], X[..., :i, :i]) * d[..., i, None]
    return X


CHUNK_BYTES = 4e6
"""Memory bound of the step matrices built at once [bytes] (the Gauss stage matrices are (4n)^2 each):
small, so that a chunk's work stays in the cache (measured on 1 MB of L2 per core: 20 steps at n = 40,
300 at n = 10 were the fastest; 4 times as many took 1.3-1.6 times as long)."""


def _product(S: np.ndarray) -> np.ndarray:
    """S[-1] ... S[1] S[0] by pairwise products (balanced tree)."""
    while S.shape[0] > 1:
        if S.shape[0] % 2:  # the last one waits for the next round
            S = np.concatenate([S[1:-1:2] @ S[0:-1:2], S[-1:]])
        else:
            S = S[1::2] @ S[0::2]
    return S[0]


COEFFICIENT_BYTES = 160e6
"""Memory bound of the stage coefficients (K and C at both stage angles of every step) evaluated at once
[bytes] when they are not a series (:func:`_series`): within it they are evaluated on two uniform
full-turn grids (interpolated, see ``sampled.SampledCoefficients``), beyond it chunk by chunk (partial
turns: the direct frame condensation)."""


def monodromy(system: PeriodicSystem, steps: int, damped: bool | None = None) -> np.ndarray:
    """Phi = S_{steps-1} ... S_1 S_0 (2n, 2n), by pairwise products (balanced tree); ``damped``: whether
    the system has damping (:func:`undamped`) if already known."""
    if np.any(system.mass <= 0.0):
        raise ValueError("Floquet analysis needs every mass > 0 (a massless coordinate has no dynamics)")
    n = system.mass.size
    chunk = max(8, int(CHUNK_BYTES / (8.0 * (4 * n) ** 2)))
    damped = not undamped(system) if damped is None else damped
    source = _step_source(system, steps, damped)
    phi = np.eye(2 * n)
    for first in range(0, steps, chunk):
        phi = _product(source(first, min(chunk, steps - first))) @ phi
    return phi


def _whole_turn_fields(system: PeriodicSystem, series: _Series | None, steps: int, damped: bool):
    """Without a series, if the stage coefficients of a whole turn fit in :data:`COEFFICIENT_BYTES`: a
    function (first, count) -> K, C (2, count, n, n) of those steps, from the system's coefficients
    evaluated once on the two uniform full-turn stage grids; else None."""
    if series is not None:  # evaluated chunk by chunk, cheaply
        return None
    n = system.mass.size
    if 8.0 * 2 * steps * (2 * n * n + 4 * n) > COEFFICIENT_BYTES:
        return None
    co = _stage_coefficients(system, steps, 0, steps, damped)
    K, C = co.stiffness.reshape(2, steps, n, n), co.damping.reshape(2, steps, n, n)
    return lambda first, count: (K[:, first:first + count], C[:, first:first + count])


def multipliers(system: PeriodicSystem, steps: int, damped: bool | None = None) -> np.ndarray:
    """Floquet multipliers (2n,) complex, largest modulus first (``damped``: as :func:`monodromy`)."""
    return _sorted_eigenvalues(monodromy(system, steps, damped))


def _sorted_eigenvalues(phi: np.ndarray) -> np.ndarray:
    mu = np.linalg.eigvals(phi)
    return mu[np.argsort(-np.abs(mu))]


def _level_batch(system: PeriodicSystem, levels: list[int], damped: bool) -> dict[int, np.ndarray]:
    """The multipliers of several step levels at once (steps -> multipliers, as :func:`multipliers`), or
    {} where that does not apply: damped coefficients with a stiffness-form series (the ``from_zk`` path of
    :func:`_step_source`) whose levels fit in one chunk together.  Each level's stage matrices come from its
    own series of (Z, K); the inverses and step matrices of all levels are built in one vectorized pass (the
    step length per step): the same numbers as level by level, for the fixed cost of one level (the
    automatic plan always runs its first three levels; ~0.15 ms a level on a 6-coordinate model)."""
    series = _series(system) if damped else None
    n = system.mass.size
    if series is None or series.form != "stiffness" or sum(levels) > max(8, int(CHUNK_BYTES / (8.0 * (4 * n) ** 2))):
        return {}
    if np.any(system.mass <= 0.0):
        raise ValueError("Floquet analysis needs every mass > 0 (a massless coordinate has no dynamics)")
    Zs, Ks = [], []
    for steps in levels:
        zk = series.zk(system.mass, SDIRK_GAMMA * system.period / steps)
        if zk is None:
            return {}
        Z, K = _stage_fields(system, zk, steps, 0, steps, damped)
        Zs.append(Z)
        Ks.append(K)
    h = np.concatenate([np.full(steps, system.period / steps) for steps in levels])[:, None, None]
    S = _sdirk_steps_from(system.mass, np.concatenate(Ks, axis=1), None, h, Z=np.concatenate(Zs, axis=1))
    ends = np.cumsum(levels)
    return {steps: _sorted_eigenvalues(_product(S[end - steps:end])) for steps, end in zip(levels, ends)}


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
    steps: propagator steps per cycle; multipliers: all of them at ``steps`` (largest first); reduced: True
    when they are those of a reduced system (:func:`ked_linear.reduction.reduced_floquet`), False for the
    full model's propagator."""

    max_abs: float
    error_estimate: float
    steps: int
    multipliers: np.ndarray
    reduced: bool = False


def floquet(system: PeriodicSystem, tolerance: float, steps: int | None = None,
            max_steps: int = 16384) -> FloquetResult:
    """Multipliers with ``steps`` per cycle or, if None, doubling from 64 (<= ``max_steps``).  The
    automatic choice stops once the changes of max |mu| between the last three levels are settled
    (:func:`_settled`).  The estimate is the last change itself (Richardson: at order p
    the error of the finer level is about 1 / (2^p - 1) of it, a third for SDIRK2
    (damped), a fifteenth for Gauss-Legendre (undamped)), at least :data:`ROUND_OFF_FLOOR`.

    Measured and not used: starting the levels at a count that resolves the first frozen mode.  The
    settled level is not tied to it (thesis grid of benchmarks/compare_linear_grid.py: settled steps 1.4
    to 380 times the first mode's oscillations per cycle; 256 steps at 30 rpm where that count is 74-181,
    2048 at 100 rpm where it is 22), so any start that keeps today's answers is 64 nearly everywhere,
    and the coarse levels cost at most half of the finest anyway."""
    plan = [max(8, steps // 2), steps] if steps is not None else [64 * 2**k for k in range(9) if 64 * 2**k <= max_steps]
    tops: list[float] = []
    changes: list[float] = []
    est, mu, n = float("nan"), np.array([np.nan]), plan[0]
    damped = not undamped(system)  # probed once for every level
    # the first three levels always run (_settled needs three): built together where they can be
    batch = _level_batch(system, plan[:3], damped) if steps is None and len(plan) >= 3 else {}
    for n in plan:
        mu = batch[n] if n in batch else multipliers(system, n, damped)
        tops.append(float(np.abs(mu[0])))
        if len(tops) < 2:
            continue
        changes.append(max(abs(tops[-1] - tops[-2]), ROUND_OFF_FLOOR))
        est = changes[-1]
        if steps is None and _settled(changes, tops, tolerance):
            break
    return FloquetResult(max_abs=float(np.abs(mu[0])), error_estimate=est, steps=n, multipliers=mu)
