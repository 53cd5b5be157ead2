"""Periodic steady state on a constant basis in co-rotating frames, by Radau IIA shooting (modal acceleration).

Why: the Fourier collocation of :mod:`ked_linear.periodic` treats the correction w = u - q in absolute
coordinates on its first H crank harmonics.  On the thesis's distributed model (5 lumps per link, 40
coordinates) the frozen modes ring: their frequencies sweep over the cycle (modes 1-4 at 100 rpm: crank
harmonics 14-22, 23-37, 38-45, 56-59), every lightly damped mode rings at its own sweeping frequency once a
cycle, and w carries harmonics up to ~60 at a few tenths of a percent of its peak each.  Measured (thesis
source, default settings, against the same collocation at H = 96): the default H = 32 misses 7.1e-3 of the
peak at 100 rpm (the level estimate says 5.9e-3: honest) and 1.9e-4 at 300 rpm (estimate 7.4e-3:
pessimistic); H = 48 / 64 reach 1.0e-3 / 3e-6 at 100 rpm (5160 unknowns at 64).  A ringing mode is broad in
harmonics but smooth in time, and few modes ring: so here the ringing part is marched in time on a few
coordinates.

Method (docs/linear_model.md).  With ' = d/dtheta, sigma the speed and B = sigma C d/dtheta + sigma^2 M
d^2/dtheta^2 (as in :mod:`ked_linear.periodic`), q = K^-1 f the frozen solution:

* u = K^-1 (f - B z), z = q + W a: one quasi-static iteration from z (exact for the static part; with M = C
  = 0 the quasi-static solution at every angle);
* W(theta) = R(theta) V: V (n, r) a constant basis with V^T M V = I in co-rotating frames, R the block
  diagonal 2 x 2 rotation of each coordinate pair by its frame angle phi (the link's angle); W' = phi' J W,
  W'' = phi'' J W - phi'^2 W (J the rotation by 90 degrees; derivatives in theta);
* the reduced coordinates a follow from the condition that z's dynamic part is the projection of u's:
  W^T M (u - q) = a, i.e. (Z = K^-T M W, A_i = Z^T [B W]_i)

      A2 a'' + A1 a' + (I + A0) a = -Z^T B q,
      A0 = Z^T (sigma C W' + sigma^2 M W''),  A1 = Z^T (sigma C W + 2 sigma^2 M W'),  A2 = sigma^2 Z^T M W:

  on frozen modes the Galerkin modal equations, and with V spanning everything the exact system;
* its coefficients are sampled on :data:`SAMPLES` angles and interpolated trigonometrically; the periodic
  solution is found by shooting: Radau IIA steps (three stages, order 5, L-stable: the stiff Ritz
  directions of V are damped to their quasi-static value) marched in the direction of time give the affine
  map x(2 pi) = Phi x(0) + d of the state x = (a, a'), and x(0) = (I - Phi)^-1 d.

**Error estimate.**  Step levels :data:`STEP_LEVELS` on the smaller basis until the change of the history
(relative to its peak, per output group) gives an estimate (:func:`ked_linear.periodic.error_estimate`)
below half the tolerance; the richer basis is solved at one level (``check``; for a four-bar the reduced
Floquet ladder's probe level, at least :data:`CHECK_FROM` steps), the smaller one there too: the answer is the smaller
basis's at the last level, its error the step estimate plus twice the change between the bases at
``check``.  None when that does not reach the tolerance or anything cannot be built (A2 singular,
coefficients not interpolable): the caller then uses the Fourier collocation.

**One reduced system per basis, one pass per level.**  The homogeneous part of each one-cycle map Phi is
the reduced system's monodromy: its eigenvalues are Floquet multipliers, which the reduced Floquet ladder
(:func:`ked_linear.reduction.reduced_floquet`) takes from the same reduced systems
(:meth:`ked_linear.reduction.Reductions.reduced`, :meth:`_Reduced.propagate`): a four-bar's steady state and
its Floquet analysis share the systems of the ladder's rungs and every Radau pass they both need.  The
projection is this module's (W^T M K^-1, modal acceleration: a Petrov-Galerkin projection of the equation
of motion), for both: for the steady state the plain Galerkin projection W^T was far less accurate on
the ladder's first basis (thesis distributed, 300 rpm: 1.2e-2 of the peak against 4.3e-4; 3.2e-4 on 20
coordinates), and for the multipliers this one is as good (max |mu| at 1024 steps against the full SDIRK2
model, first / second rung, Galerkin -> this: thesis distributed 200 rpm 1.2e-4 -> 4.9e-5 / 1.3e-5 ->
4.8e-6, 300 rpm 1.6e-4 -> 2.4e-4 / 2.5e-5 -> 4e-7, 500 rpm 7.1e-4 -> 8.0e-4 / 6.2e-5 -> 2.6e-5, cognate
450 rpm 5.9e-4 -> 4.0e-4 / 2.7e-5 -> 1.1e-5; extender 300 rpm 1.2e-5 -> 7.8e-6; generated atlas linkage
1, distributed, r = 0.2: 2.6e-3 -> 4.3e-4 / 2.7e-5 -> 1.3e-5), and twice the change between consecutive
rungs covered the first rung's error in each of these.

This module is generic (no linkage): the caller supplies the bases and the frame angles
(:func:`ked_linear.reduction.link_frames` and :func:`ked_linear.reduction.greedy_basis` for a four-bar).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .floquet import _product
from .periodic import (
    Coefficients,
    PeriodicSystem,
    _apply,
    error_estimate,
    relative_change,
    series,
    spectrum,
    steady_state,
)
from .reduction import (
    BASES,
    BASIS_FACTOR,
    RADAU_A,
    RADAU_C,
    TRAINING_ANGLES,
    Reductions,
    _turn,
    ladder_levels,
    link_frames,
    rotate_columns,
)
from .reduction import INTERPOLATION_TOLERANCE as REDUCED_TOLERANCE
from .sampled import TrigInterpolant, interleave, midpoint_error

FrameAngles = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray, np.ndarray]]
"""theta (m,) [rad] -> (phi [rad], phi_dot [rad/s], phi_ddot [rad/s^2]), each (m, n/2): the frame angle of
each coordinate pair (x, y), its rate and acceleration at the system's speed."""

STEP_LEVELS = (128, 256, 512)
"""Radau IIA steps per cycle, tried in turn (the richer basis is solved at the first)."""

SAMPLES = 128
"""Angles on which the reduced coefficients are sampled first (doubled up to :data:`MAX_SAMPLES` until the
interpolant of the even samples matches the odd ones within :data:`INTERPOLATION_TOLERANCE`; the full
coefficients on this grid also give the frozen solution's spectrum).  Measured on the thesis extender and
distributed models at 100 and 300 rpm: 64 samples never passed the check (1.3e-4 to 5.5e-4), 128 always."""

MAX_SAMPLES = 512

INTERPOLATION_TOLERANCE = 1e-6
"""Largest error, relative to its peak, of the interpolant of the even samples of the reduced load Fe at the
odd ones (a bound of the coarser interpolant: the one used, of all samples, is far closer; measured on the
thesis distributed model: 1.5e-8 with 64 samples against 128, 3e-11 with 128)."""

COEFFICIENT_TOLERANCE = REDUCED_TOLERANCE
"""The same for Ke and Ce: the reduced Floquet analysis's (:data:`ked_linear.reduction.INTERPOLATION_TOLERANCE`),
whose multipliers come from the same system."""


@dataclass(frozen=True)
class ReducedSteadyState:
    """Output of :func:`corotating_steady_state`: u (m, n) and output y (m, p) (or None) at the requested
    angles; ``error_estimate``: the step levels' estimate plus the change between the bases (fraction of
    the peak, per output group); ``steps``: Radau steps per cycle; ``sizes``: (smaller, richer) basis sizes;
    ``step_error`` and ``basis_change``: the two parts of the estimate."""

    displacement: np.ndarray
    output: np.ndarray | None
    error_estimate: float
    steps: int
    sizes: tuple[int, int]
    step_error: float
    basis_change: float


def _frames(angles: FrameAngles, V: np.ndarray, theta: np.ndarray, speed: float,
            known: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """W = R V and its theta-derivatives W', W'' (m, n, r) at ``theta`` (``known``: angles(theta) if at hand)."""
    phi, rate, acc = angles(theta) if known is None else known
    W = rotate_columns(V, phi)
    p1 = np.repeat(rate / speed, 2, axis=1)[:, :, None]  # dphi/dtheta
    p2 = np.repeat(acc / speed**2, 2, axis=1)[:, :, None]
    JW = _turn(W)
    return W, p1 * JW, p2 * JW - p1**2 * W


@dataclass(frozen=True)
class Propagation:
    """One Radau IIA pass of a reduced system (:meth:`_Reduced.propagate`): ``multipliers`` (2r,) of its
    homogeneous one-cycle map, largest first; ``states`` (steps, 2r): the periodic solution x = (a, a') at
    theta_j = 2 pi j / steps, or None if not asked for."""

    multipliers: np.ndarray
    states: np.ndarray | None


@dataclass(frozen=True)
class _AtAngles:
    """What :meth:`_Reduced.evaluate` needs at the output angles that depends on them alone: the frame
    angles (``angles(theta)``) and the frozen solution's first two theta-derivatives q', q'' (m, n)."""

    angles: tuple[np.ndarray, np.ndarray, np.ndarray]
    q1: np.ndarray
    q2: np.ndarray

    @staticmethod
    def of(reduced: _Reduced, theta: np.ndarray) -> _AtAngles:
        return _AtAngles(angles=reduced.angles(theta), q1=series(reduced.q_hat, theta, 1),
                         q2=series(reduced.q_hat, theta, 2))


class _Forcing:
    """What the reduced systems of every basis of one system need at given angles, remembered per angle
    array (the rungs of a ladder share one): B q (m, n) of the frozen solution q (spectrum ``q_hat``) and
    M K^-1 (m, n, n) (K symmetric)."""

    def __init__(self, system: PeriodicSystem, q_hat: np.ndarray):
        self.system, self.q_hat = system, q_hat
        self._known: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}

    def at(self, theta: np.ndarray, co: Coefficients) -> tuple[np.ndarray, np.ndarray]:
        key = theta.tobytes()
        if key not in self._known:
            s, m = self.system.speed, self.system.mass
            Bq = s * _apply(co.damping, series(self.q_hat, theta, 1)) + s**2 * m * series(self.q_hat, theta, 2)
            # (K^-T M)^T = M K^-1: the rows of the test functions' transpose
            self._known[key] = (Bq, np.swapaxes(np.linalg.solve(np.swapaxes(co.stiffness, 1, 2),
                                                                np.broadcast_to(np.diag(m), co.stiffness.shape)),
                                                1, 2))
        return self._known[key]


class _Reduced:
    """The reduced equation a'' + Ce a' + Ke a = Fe (A2 divided out) of one basis, sampled and interpolated:
    the one reduced system of that basis for both the periodic steady state and the Floquet multipliers
    (:meth:`propagate`: one Radau IIA pass of affine step maps gives both; :class:`Propagation`)."""

    def __init__(self, system: PeriodicSystem, angles: FrameAngles, V: np.ndarray, q_hat: np.ndarray,
                 co_grid: Coefficients | None = None,
                 angles_grid: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
                 midpoints: Callable[[int], tuple[Coefficients, tuple[np.ndarray, np.ndarray, np.ndarray]]]
                 | None = None, forcing: _Forcing | None = None):
        self.system, self.angles, self.V, self.q_hat = system, angles, V, q_hat
        self._forcing = _Forcing(system, q_hat) if forcing is None else forcing
        self.r = V.shape[1]
        self._at: tuple | None = None  # (the _AtAngles, fields, frames) of the last evaluate
        self._runs: dict[int, Propagation] = {}
        G = SAMPLES
        # co_grid, angles_grid: the coefficients and frame angles on the first grid, if known; midpoints(G):
        # those at the midpoints of the G / 2 grid, if known; forcing: B q of the frozen solution, if shared
        flat = self._flat(np.arange(G) * (2.0 * np.pi / G), co_grid, angles_grid)
        k, c, f = self._layout()
        while midpoint_error(flat, (k, c)) > COEFFICIENT_TOLERANCE or midpoint_error(flat, (f,)) > \
                INTERPOLATION_TOLERANCE:
            if 2 * G > MAX_SAMPLES:
                raise ValueError("reduced coefficients not interpolable")
            mid = (np.arange(G) + 0.5) * (2.0 * np.pi / G)
            flat = interleave(flat, self._flat(mid) if midpoints is None else self._flat(mid, *midpoints(2 * G)))
            G *= 2
        self.interpolant = TrigInterpolant(flat)

    def _layout(self) -> tuple[slice, slice, slice]:
        r = self.r
        return slice(0, r * r), slice(r * r, 2 * r * r), slice(2 * r * r, 2 * r * r + r)

    def _flat(self, theta: np.ndarray, co: Coefficients | None = None,
              known: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None) -> np.ndarray:
        """[Ke, Ce, Fe] flattened (m, 2 r^2 + r) at ``theta`` (``co``, ``known``: the full coefficients and
        the frame angles there, if known)."""
        sys_ = self.system
        s, m, r = sys_.speed, sys_.mass, self.r
        co = sys_.coefficients(theta) if co is None else co
        W, W1, W2 = _frames(self.angles, self.V, theta, s, known)
        Bq, MKinv = self._forcing.at(theta, co)
        Zt = np.swapaxes(W, 1, 2) @ MKinv  # W^T M K^-1
        ZtC, ZtM = Zt @ co.damping, Zt * m
        A0 = s * (ZtC @ W1) + s**2 * (ZtM @ W2)
        A1 = s * (ZtC @ W) + 2.0 * s**2 * (ZtM @ W1)
        A2 = s**2 * (ZtM @ W)
        rhs = np.concatenate([A0 + np.eye(r), A1, -_apply(Zt, Bq)[..., None]], axis=2)
        X = np.linalg.inv(A2) @ rhs  # A2 symmetric positive definite, condition <= 7e5 measured (rungs 0-2 of
        # the thesis extender and distributed models): as accurate as a solve here, and a third cheaper
        return np.concatenate([X[..., :r].reshape(-1, r * r), X[..., r:2 * r].reshape(-1, r * r), X[..., 2 * r]],
                              axis=1)

    def fields(self, flat: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        r = self.r
        k, c, f = self._layout()
        return flat[:, k].reshape(-1, r, r), flat[:, c].reshape(-1, r, r), flat[:, f]

    def propagate(self, steps: int, states: bool = False) -> Propagation:
        """One Radau IIA pass over the cycle at ``steps`` steps (in the direction of time), remembered: the
        Floquet multipliers of the homogeneous part of its one-cycle map and, with ``states``, the periodic
        solution x = (a, a') at theta_j = sign 2 pi j / steps (the step maps are not kept: a pass asked for
        its states after one without them is marched again)."""
        known = self._runs.get(steps)
        if known is not None and (known.states is not None or not states):
            return known
        r = self.r
        sign = 1.0 if self.system.speed > 0 else -1.0  # march in the direction of time
        h = sign * 2.0 * np.pi / steps
        stage = uniform_grids(self.interpolant, RADAU_C * h, sign, steps)
        K, C, F = self.fields(stage)
        S = radau_affine_steps(K.reshape(3, steps, r, r), C.reshape(3, steps, r, r), F.reshape(3, steps, r), h)
        Phi = _product(S)
        mu = np.linalg.eigvals(Phi[:2 * r, :2 * r])  # the same in t and theta: a Runge-Kutta step commutes
        # with rescaling time, which only scales a'
        mu = mu[np.argsort(-np.abs(mu))]
        X = None
        if states:
            X = np.empty((steps, 2 * r))
            X[0] = np.linalg.solve(np.eye(2 * r) - Phi[:2 * r, :2 * r], Phi[:2 * r, 2 * r])
            for j in range(steps - 1):
                X[j + 1] = S[j, :2 * r, :2 * r] @ X[j] + S[j, :2 * r, 2 * r]
            if sign < 0:  # samples at -2 pi j / steps: reorder to the increasing grid the interpolant expects
                X = np.concatenate([X[:1], X[:0:-1]])
        self._runs[steps] = Propagation(multipliers=mu, states=X)
        return self._runs[steps]

    def periodic(self, steps: int) -> TrigInterpolant:
        """The periodic solution: the interpolant of x = (a, a') at theta_j = 2 pi j / steps."""
        return TrigInterpolant(self.propagate(steps, states=True).states)

    def evaluate(self, steps: int, theta: np.ndarray, co: Coefficients,
                 at: _AtAngles | None = None) -> tuple[np.ndarray, np.ndarray | None]:
        """u (m, n) and the output (or None) at ``theta`` from the solution at ``steps`` Radau steps; ``co``:
        the full coefficients at ``theta``; ``at``: the parts that depend on ``theta`` alone, if at hand."""
        sys_ = self.system
        s, m, r = sys_.speed, sys_.mass, self.r
        at = _AtAngles.of(self, theta) if at is None else at
        x = self.periodic(steps).at(theta)
        a, a1 = x[:, :r], x[:, r:]
        if self._at is None or self._at[0] is not at:  # this basis's fields and frames at theta: once per basis
            K, C, F = self.fields(self.interpolant.at(theta))
            self._at = (at, (K, C, F), _frames(self.angles, self.V, theta, s, at.angles))
        _, (K, C, F), (W, W1, W2) = self._at
        a2 = F - _apply(K, a) - _apply(C, a1)
        z1 = at.q1 + _apply(W1, a) + _apply(W, a1)
        z2 = at.q2 + _apply(W2, a) + 2.0 * _apply(W1, a1) + _apply(W, a2)
        rhs = co.load - s * _apply(co.damping, z1) - s**2 * m * z2
        u = np.linalg.solve(co.stiffness, rhs[..., None])[..., 0]
        return u, None if co.output is None else _apply(co.output, u)


def uniform_grids(interpolant: TrigInterpolant, theta0: np.ndarray, sign: float, m: int) -> np.ndarray:
    """Values (g m, F) of ``interpolant`` (of real samples) on the g uniform full-turn grids
    theta0[i] + sign 2 pi j / m (grid by grid): what g calls of :meth:`TrigInterpolant.uniform` give, from
    the one-sided spectrum (the real form sum_f Re(c_f e^{i f theta}), f = 0 .. G/2) folded modulo m by
    slices and one real inverse FFT."""
    G = interpolant.points
    half = G // 2
    c = 2.0 * interpolant.spectrum[:, half:]  # f = 0 .. G/2 (the Nyquist term was halved at each end)
    c[:, 0] *= 0.5
    terms = c[None] * np.exp(1j * np.outer(np.asarray(theta0, dtype=float), np.arange(half + 1)))[:, None, :]
    if sign < 0:
        terms = np.conj(terms)  # Re sum_f t_f e^{-i f s} = Re sum_f conj(t_f) e^{i f s}
    if m > G:  # no two frequencies share a residue, none reaches m/2: the Hermitian part, zero-padded by irfft
        hermitian = 0.5 * terms
        hermitian[..., 0] = terms[..., 0].real
    else:
        b = np.zeros(terms.shape[:2] + (m,), dtype=complex)
        for start in range(0, half + 1, m):  # m consecutive frequencies have distinct residues
            stop = min(start + m, half + 1)
            b[..., :stop - start] += terms[..., start:stop]
        # Re ifft(b) = irfft of the Hermitian part (b_k + conj(b_-k)) / 2, k = 0 .. m/2
        hermitian = 0.5 * (b[..., :m // 2 + 1] + np.conj(b[..., (-np.arange(m // 2 + 1)) % m]))
    out = np.fft.irfft(hermitian, n=m, axis=2) * m  # (g, F, m)
    return np.swapaxes(out, 1, 2).reshape(-1, out.shape[1])


def radau_affine_steps(K: np.ndarray, C: np.ndarray, F: np.ndarray, h: float) -> np.ndarray:
    """Affine step maps (m, 2r + 1, 2r + 1) of x = (q, q', 1) for q'' + C q' + K q = F, with K, C (3, m, r, r)
    and F (3, m, r) at the three stage points of each step (step h, any sign).

    Stage values Q_i = q + h sum_j a_ij P_j, P_i = p + h sum_j a_ij (F_j - K_j Q_j - C_j P_j); eliminating Q:
    [delta_ik I + h a_ik C_k + h^2 sum_j a_ij a_jk K_j] P_k = p - h sum_j a_ij K_j q + h sum_j a_ij F_j; the
    new state is the last stage (stiffly accurate)."""
    _, m, r, _ = K.shape
    a = RADAU_A
    blocks = ((np.einsum("ij,jk->ikj", a, a) * (h * h)).reshape(9, 3) @ K.reshape(3, -1)).reshape(3, 3, m, r, r)
    for k in range(3):
        blocks[:, k] += (h * a[:, k])[:, None, None, None] * C[k]
    L = np.ascontiguousarray(blocks.transpose(2, 0, 3, 1, 4)).reshape(m, 3 * r, 3 * r)
    diag = np.arange(3 * r)
    L[:, diag, diag] += 1.0
    rhs = np.zeros((m, 3, r, 2 * r + 1))
    rhs[..., :r] = ((-h * a) @ K.reshape(3, -1)).reshape(3, m, r, r).transpose(1, 0, 2, 3)
    idx = np.arange(r)
    rhs[:, :, idx, r + idx] = 1.0
    rhs[..., 2 * r] = ((h * a) @ F.reshape(3, -1)).reshape(3, m, r).transpose(1, 0, 2)
    P = np.linalg.solve(L, rhs.reshape(m, 3 * r, 2 * r + 1)).reshape(m, 3, r, 2 * r + 1)
    S = np.zeros((m, 2 * r + 1, 2 * r + 1))
    S[:, r:2 * r] = P[:, 2]
    S[:, :r] = h * (a[2, 0] * P[:, 0] + a[2, 1] * P[:, 1] + a[2, 2] * P[:, 2])
    S[:, idx, idx] += 1.0
    S[:, 2 * r, 2 * r] = 1.0
    return S


def corotating_steady_state(system: PeriodicSystem, angles: FrameAngles, bases: tuple[np.ndarray, np.ndarray],
                            theta: np.ndarray, tolerance: float,
                            groups: tuple[slice, ...] | None = None,
                            on_grid: tuple[Coefficients, tuple[np.ndarray, np.ndarray, np.ndarray]] | None = None,
                            ) -> ReducedSteadyState | None:
    """Steady state at ``theta`` on the co-rotating bases (smaller, richer), each (n, r) with V^T M V = I, in
    the frames of ``angles``; None when the estimate does not reach ``tolerance`` (relative to the peak per
    column group of the output) or the reduced system cannot be built (see the module docstring).
    ``on_grid``: the full coefficients and ``angles`` on the :data:`SAMPLES` uniform angles from 0, if known."""
    if np.any(system.mass <= 0.0):
        return None
    G = SAMPLES
    grid = np.arange(G) * (2.0 * np.pi / G)
    co_grid, angles_grid = (system.coefficients(grid), None) if on_grid is None else on_grid
    q_hat = spectrum(np.linalg.solve(co_grid.stiffness, co_grid.load[..., None])[..., 0])
    try:
        forcing = _Forcing(system, q_hat)
        small = _Reduced(system, angles, bases[0], q_hat, co_grid, angles_grid, forcing=forcing)
        rich = _Reduced(system, angles, bases[1], q_hat, co_grid, angles_grid, forcing=forcing)
    except (ValueError, np.linalg.LinAlgError):
        return None
    return steady_state_on(small, rich, theta, tolerance, groups)


def steady_state_on(small: _Reduced, rich: _Reduced, theta: np.ndarray, tolerance: float,
                    groups: tuple[slice, ...] | None = None, check: int = STEP_LEVELS[0],
                    steps_failed: Callable[[], None] | None = None) -> ReducedSteadyState | None:
    """:func:`corotating_steady_state` on two built reduced systems of one system (smaller, richer): the
    smaller at :data:`STEP_LEVELS`, the basis change between the two at ``check`` steps (their
    discretization errors nearly cancel at equal steps).  ``steps_failed``: called (and its value
    returned) when the step levels alone do not vouch."""
    system = small.system
    if np.any(system.mass <= 0.0):
        return None
    theta = np.atleast_1d(np.asarray(theta, dtype=float))
    co = system.coefficients(theta)
    try:
        at = _AtAngles.of(small, theta)
        outputs: dict[int, tuple[np.ndarray, np.ndarray | None]] = {}
        changes, est = [], float("inf")
        for level, steps in enumerate(STEP_LEVELS):
            u, y = small.evaluate(steps, theta, co, at)
            outputs[steps] = (u, y)
            if level:
                changes.append(relative_change(_out(u, y), _out(*outputs[STEP_LEVELS[level - 1]]), groups))
                est = error_estimate(changes)
                if est < 0.5 * tolerance:
                    break
        if not est < 0.5 * tolerance:
            return None if steps_failed is None else steps_failed()
        base = outputs[check] if check in outputs else small.evaluate(check, theta, co, at)
        u_rich, y_rich = rich.evaluate(check, theta, co, at)
    except (ValueError, np.linalg.LinAlgError):
        return None
    change = relative_change(_out(u_rich, y_rich), _out(*base), groups)
    # the basis error as twice the change to the richer basis, as the reduced Floquet analysis counts it:
    # the change alone fell short of the true error by up to 1.97x (68 scenes of 8 generated atlas
    # linkages, extender and distributed at r = 0.1-0.3, against the 64-harmonic collocation)
    total = est + BASIS_FACTOR * change
    if not (np.isfinite(total) and total < tolerance):
        return None
    return ReducedSteadyState(displacement=u, output=y, error_estimate=float(total), steps=steps,
                              sizes=(small.r, rich.r), step_error=float(est),
                              basis_change=float(change))


def _out(u: np.ndarray, y: np.ndarray | None) -> np.ndarray:
    return u if y is None else y


CHECK_FROM = 128
"""Least steps at which :func:`four_bar_steady_state` compares two rungs' steady states (the ladder's probe
level where that is finer, sharing its passes).  The forced response needs it: at 64 steps the change
between the first two rungs' steady states was 3.9e-4 / 6.0e-3 of the peak (thesis extender 300 rpm /
distributed 100 rpm) against 2.9e-6 / 1.9e-5 at 128 and 256 steps alike.  The ladder itself keeps its
probe level (64 steps at high speed), so a Floquet-only evaluation does not pay the finer pass."""


class _StepsFail(Exception):
    """The step levels of a rung do not vouch: a richer rung would not either (the step error is the
    dynamics', not the basis's)."""


def _raise_steps_fail() -> None:
    raise _StepsFail


def four_bar_steady_state(scene: object, system: PeriodicSystem, theta: np.ndarray, tolerance: float,
                          groups: tuple[slice, ...] | None = None,
                          reductions: Reductions | None = None) -> ReducedSteadyState | None:
    """:func:`steady_state_on` of a four-bar's linear model on its link frames
    (:func:`ked_linear.reduction.link_frames`) on the rungs of the reduced Floquet ladder
    (:data:`ked_linear.reduction.BASES`), their reduced systems and Radau passes shared with it: a rung
    checked against the next at the ladder's probe level (:func:`ked_linear.reduction.ladder_levels`),
    where the ladder propagates both rungs too, or at :data:`CHECK_FROM` steps if that is finer; where
    that does not vouch, the next pair of rungs (as the ladder does).  None if the system is undamped, a
    basis cannot be built or no pair vouches for ``tolerance``.  ``reductions``: the
    :class:`ked_linear.reduction.Reductions` of ``system`` if already built (shared with the reduced Floquet
    analysis).

    The richer basis was the smaller one with its static corrections (r = 14 -> 17-18 on the thesis
    distributed model) before the two analyses shared their systems; on generated atlas linkage 1
    (distributed, r = 0.2, source) its change covered the error only by a thin margin (estimate 9.46e-4 for
    a true error of 9.38e-4 against the 64-harmonic collocation), where the ladder's second rung shows
    9.1e-4 (estimate 1.85e-3: the pair declines) and the next pair (r = 23 against 26) vouches with 1.8e-4
    for a true 2.5e-5 (cognate: 6.1e-4 / 1.16e-3 / 3.5e-4 for a true 6.1e-4, 6.1e-4, 1.5e-4)."""
    red = Reductions(system, link_frames(scene)) if reductions is None else reductions
    if not red.usable or 2 * TRAINING_ANGLES != SAMPLES:
        return None
    probe = ladder_levels(red)[2]
    check = STEP_LEVELS[0] if probe is None else max(probe, CHECK_FROM)
    for i in range(len(BASES) - 1):
        small, rich = red.reduced(i), red.reduced(i + 1)
        if small is None or rich is None:
            return None
        try:
            got = steady_state_on(small, rich, theta, tolerance, groups, check, _raise_steps_fail)
        except _StepsFail:
            return None
        if got is not None:
            return got
    return None


FIRST_HARMONICS = 8
"""Crank harmonics the collocation tries first (levels 4, 8) in :func:`periodic_steady_state`: where it
converges there (low speeds: the thesis extender at 100 rpm, the distributed model at 30 rpm) it is the
cheaper answer (measured, loaded machine: 1 ms extender, 7 ms distributed at 30 rpm; the co-rotating
path 20 and 100 ms); its answer is then the one solve_linear gave before the co-rotating path existed."""


@dataclass(frozen=True)
class PeriodicAnswer:
    """The periodic steady state solve_linear reports: ``output`` (m, p) at the scene's angles, its
    ``error_estimate`` (fraction of the peak per output group), ``harmonics`` H and ``points`` N of the
    collocation (both 0 when the co-rotating basis answered), ``radau_steps`` the co-rotating basis's Radau
    IIA steps per cycle (0 when the collocation answered)."""

    output: np.ndarray
    error_estimate: float
    harmonics: int
    points: int
    radau_steps: int = 0


def periodic_steady_state(scene: object, system: PeriodicSystem, theta: np.ndarray, tolerance: float,
                          harmonics: int | None, max_harmonics: int, groups: tuple[slice, ...] | None,
                          reduce: bool, reductions: Callable[[], Reductions] | None = None) -> PeriodicAnswer:
    """A four-bar's periodic steady state: with a fixed ``harmonics`` or without ``reduce`` the collocation
    (:func:`ked_linear.periodic.steady_state`); else the collocation up to :data:`FIRST_HARMONICS`, if that
    does not reach ``tolerance`` the co-rotating basis (:func:`four_bar_steady_state`), and if that does not
    vouch for it the collocation up to ``max_harmonics``.  ``reductions``: gives the
    :class:`ked_linear.reduction.Reductions` of ``system`` (called only when the co-rotating basis is
    tried; the caller shares it with the reduced Floquet analysis)."""
    def collocation(top: int) -> PeriodicAnswer:
        ss = steady_state(system, theta, tolerance, harmonics, top, groups)
        return PeriodicAnswer(output=ss.output, error_estimate=ss.error_estimate, harmonics=ss.solution.harmonics,
                              points=ss.solution.points)

    if harmonics is not None or not reduce:
        return collocation(max_harmonics)
    first = collocation(min(FIRST_HARMONICS, max_harmonics))
    if first.error_estimate < tolerance:
        return first
    co = four_bar_steady_state(scene, system, theta, tolerance, groups,
                               None if reductions is None else reductions())
    if co is not None:
        return PeriodicAnswer(output=co.output, error_estimate=co.error_estimate, harmonics=0, points=0,
                              radau_steps=co.steps)
    return first if max_harmonics <= FIRST_HARMONICS else collocation(max_harmonics)
