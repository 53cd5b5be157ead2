"""The reduced system of one constant basis in co-rotating frames: sampled, interpolated, marched by Radau IIA.

With ' = d/dtheta, sigma the speed, B = sigma C d/dtheta + sigma^2 M d^2/dtheta^2 and q = K^-1 f the frozen
solution, the basis W(theta) = R(theta) V (V (n, r) constant, V^T M V = I, R the per-lump rotation by the
frame angles: :mod:`ked_linear.linkframes`) and the modal-acceleration (Petrov-Galerkin) projection
W^T M K^-1 give (Z = K^-T M W)

    A2 a'' + A1 a' + (I + A0) a = -Z^T B q,
    A0 = Z^T (sigma C W' + sigma^2 M W''),  A1 = Z^T (sigma C W + 2 sigma^2 M W'),  A2 = sigma^2 Z^T M W

(docs/linear_model.md; the module docstring of :mod:`ked_linear.corotating` says why this projection).
:class:`_Reduced` holds it with A2 divided out, its coefficients sampled on :data:`SAMPLES` angles (more
until the interpolant of the even samples matches the odd ones) and interpolated trigonometrically;
:meth:`_Reduced.propagate` marches one Radau IIA pass of affine step maps (:func:`ked_linear.radau.radau_steps`)
over the cycle, which gives both the Floquet multipliers of its homogeneous part (the reduced Floquet ladder,
:func:`ked_linear.reduction.reduced_floquet`) and the periodic solution (the co-rotating steady state,
:func:`ked_linear.corotating.steady_state_on`).  The bases and frames come from the callers
(:class:`ked_linear.reduction.Reductions` for a four-bar).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .floquet import _product
from .linkframes import FrameAngles, _turn, rotate_columns
from .periodic import Coefficients, PeriodicSystem, _apply, series
from .radau import RADAU_C, radau_affine_steps
from .sampled import TrigInterpolant, interleave, midpoint_errors

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

COEFFICIENT_TOLERANCE = 1e-8
"""The same for Ke and Ce (each field's peak): the reduced Floquet analysis's tolerance (re-exported there as
:data:`ked_linear.reduction.INTERPOLATION_TOLERANCE`), whose multipliers come from the same system; the
grid doubles from :data:`SAMPLES` (2 :data:`ked_linear.reduction.TRAINING_ANGLES`) up to
:data:`MAX_SAMPLES` angles until it holds."""


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
        limits = np.array([COEFFICIENT_TOLERANCE, COEFFICIENT_TOLERANCE, INTERPOLATION_TOLERANCE])
        while np.any((errors := midpoint_errors(flat, (k, c, f))) > limits):
            if 2 * G > MAX_SAMPLES or not np.all(np.isfinite(errors)):  # refining keeps a non-finite sample
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
        stage = self.interpolant.grids(RADAU_C * h, sign, steps)
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

