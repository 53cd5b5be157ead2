"""Floquet multipliers of a linkage's linear model on a reduced system: co-rotating link frames and a constant basis.

The coordinates u of :mod:`ked_linear.linkage` are absolute x, y displacements of the lumps, so the low
frozen modes turn with the links over the cycle and no constant low-dimensional basis holds them (measured:
the lowest frozen modes at 16 angles, compressed, gave max |mu| = 0 on the distributed model).  Here:

1. **Co-rotating frames (exact).**  u = R(t) v, R block diagonal with the 2 x 2 rotation by the angle phi of
   the link each lump belongs to (crank, coupler body = coupler + extender + the joints A, B, follower).
   The mass of a lump is isotropic (M R = R M), so with R^T R' = phi' J and R^T R'' = phi'' J - phi'^2 I
   per lump (J the rotation by 90 degrees, phi', phi'' the link's angular rate and acceleration from the
   loop kinematics)

       M v'' + (R^T C R + 2 M phi' J) v' + (R^T K R + R^T C R phi' J + M (phi'' J - phi'^2)) v = 0,

   the same multipliers (R is periodic: the monodromy is only conjugated by R(0)).
2. **A constant M-orthonormal basis V in v (Galerkin).**  Built greedily on a uniform grid of angles (the
   reduced-basis method for parametric eigenproblems): start with the lowest ``modes`` frozen modes of
   (M, R^T K R) at one angle; while the Ritz values of V at some grid angle differ from the frozen
   eigenvalues (the ``modes`` lowest) by more than ``ritz_tolerance`` (relative), add that angle's frozen
   modes.  An amplitude-weighted compression (SVD of the modes of many angles) converges poorly: a low mode
   has tiny components along the links' stiff axial directions which carry much of its energy; the greedy
   choice keeps the Ritz values exact to the tolerance on the whole grid.  The richer bases add the
   **static corrections** of their modes (:func:`static_corrections`): the frame terms apply forces
   M J v to a mode (Coriolis 2 M phi' J v', M phi'' J v, C phi' J v), which the links' stiff directions
   answer quasi-statically; frozen modes alone span that response only slowly (at high speed a basis of
   4 modes, 24 columns, was 3e-4 off the full model at 500 rpm; with 2 correction columns 6e-5), which
   is why without them the reduction did not vouch above ~450 rpm on the distributed model.
3. **The reduced system** of each basis is the periodic steady state's
   (:class:`ked_linear.reducedsystem._Reduced`, :meth:`Reductions.reduced`):
   the modal-acceleration (Petrov-Galerkin, test functions K^-1 M W) projection,
   with unit reduced mass after dividing out A2; its coefficients sampled on 128-512 uniform angles (until
   the interpolant of the even samples matches the odd ones within :data:`INTERPOLATION_TOLERANCE` of the
   peak) and interpolated trigonometrically, propagated over one cycle by the three-stage **Radau IIA**
   method (order 5, L-stable and stiffly accurate: the reduced system keeps stiff, overdamped Ritz modes,
   which it damps to ~0 like the SDIRK2 propagator of the full model), from the level with
   h omega <= 2 for the lowest frozen mode: 64-512 steps where SDIRK2 needs 1024-4096.  One pass of affine
   step maps per rung and level (:meth:`ked_linear.reducedsystem._Reduced.propagate`, remembered) gives the
   multipliers here and the periodic state to the steady state.  The plain Galerkin projection
   (:func:`projection`, :func:`radau_multipliers`: the reference form, kept for the tests) gave the same
   multipliers as well or worse (module docstring of :mod:`ked_linear.corotating`).

**Error estimate and fallback** (:func:`reduced_floquet`). A ladder of bases (:data:`BASES`: 2 frozen modes
kept exact; 4, 6, 8 with their static corrections); the answer is a rung's, its error the estimate from its
step levels plus twice the change to the next rung (at equal steps) plus :data:`BASIS_SHARED`. When no rung
vouches for half the Floquet tolerance, or the answer is within its error of :data:`FULL_NEAR_ONE` (a verdict
near the stability boundary is decided on the full model), or anything cannot be built (undamped system;
coefficients not interpolable: the tip model's stiffness spike, linkages near toggle), it returns None and the
caller uses the full model.

Measured (thesis source linkage, 2 % damping, against the full SDIRK2 model at 4096 and 8192 steps,
tests/test_floquet_reduction.py; the modal-acceleration systems): distributed (40 coordinates; r = 14
checked against 22, at 500-600 rpm r = 24-26 against 30-32) at 30-600 rpm, source and cognate, within
2.4e-4 of the full model's max |mu| (source 300 rpm; estimate 4.9e-4) and within the estimate; extender
(10; r = 6 against 10) within 9e-6; generated atlas linkages 1, 4, 5 (distributed, r = 0.2, 0.2, 0.5)
within the estimate (2.1e-4 at most).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .floquet import FloquetResult, _product
from .linkframes import (  # noqa: F401  (link_frames re-exported where it was defined)
    LinkFrames,
    _in_frames,
    _turn,
    link_frames,
    rotate_columns,
)
from .periodic import Coefficients, PeriodicSystem, error_estimate, spectrum
from .radau import (  # noqa: F401  (RADAU_A, RADAU_C, radau_tableau re-exported where they were defined)
    RADAU_A,
    RADAU_C,
    RADAU_STAGES,
    radau_steps,
    radau_tableau,
    tableau,
)
from .reducedsystem import (  # noqa: F401  (INTERPOLATION_TOLERANCE re-exported where it was defined)
    COEFFICIENT_TOLERANCE as INTERPOLATION_TOLERANCE,
)
from .reducedsystem import _Forcing, _Reduced
from .sampled import TrigInterpolant

REDUCE_FROM = 8
"""Damped four-bar systems with at least this many coordinates (extender, distributed) get their Floquet
multipliers from the reduced system (:mod:`ked_linear.reduction`) when it vouches for the tolerance;
smaller ones (tip, joints: the full propagator is as fast), undamped ones and a fixed ``floquet_steps``
use the full propagator (:func:`ked_linear.floquet.floquet`)."""

FULL_NEAR_ONE = 0.9
"""A reduced max |mu| + error at or above this goes to the full model (the weakly damped threshold of the
result flags: a verdict near the stability boundary is decided on the unreduced system)."""

BASES = ((2, 1e-4, None), (4, 1e-6, 1e-5), (6, 1e-7, 1e-5), (8, 1e-7, 1e-5))
"""The ladder of bases, each (frozen modes kept exact, relative Ritz-value tolerance, threshold of the
static corrections or None: :func:`static_corrections`), each checked against the next
(:func:`reduced_floquet`)."""

BASIS_FACTOR = 2.0
"""The basis error of a rung: this times its difference to the next rung, plus :data:`BASIS_SHARED`."""

BASIS_SHARED = 1e-5
"""The part of the basis error that consecutive rungs share (both miss the same higher modes), which their
difference cannot show.  Measured against the unreduced model (thesis distributed at 30-600 rpm, source
and cognate, and 8 generated atlas linkages, extender and distributed at r = 0.05, 0.2, 0.5): twice the
difference alone was exceeded once, by 3e-6 (2.4e-5 against 2.1e-5)."""

ESTIMATE_FLOOR = 1e-6
"""Least error reported for a reduced max |mu|: below it the step levels and the basis check no longer see
the error of the interpolated coefficients (1e-8 of each field's peak; measured on a generated atlas
linkage, distributed, r = 0.5: 1.9e-7 against the full model where the levels and bases agreed to 4e-9)."""

TRAINING_ANGLES = 64
"""Uniform grid of crank angles on which the basis is built and checked."""

RADAU_LEVELS = (64, 128, 256, 512, 1024, 2048)
"""Step counts per cycle of the reduced propagator, tried in turn from the first with h omega <= 2 for the
lowest mode (:func:`reduced_floquet`)."""


def corotated(system: PeriodicSystem, frames: LinkFrames, theta: np.ndarray) -> Coefficients:
    """The coefficients of the exact co-rotating system in v (u = R v) at ``theta``: (m, n, n) each (the
    reference form; :func:`reduced_system` projects without forming them)."""
    co = system.coefficients(theta)
    phi, rate, acc = frames.of_lumps(theta)
    eye = np.broadcast_to(np.eye(system.mass.size), co.stiffness.shape)
    R = rotate_columns(eye, phi)
    Rt = np.swapaxes(R, 1, 2)
    K, C = Rt @ co.stiffness @ R, Rt @ co.damping @ R
    m = system.mass
    Jw = np.repeat(rate, 2, axis=1)[:, None, :] * _turn(eye)  # phi' J (block diagonal; columns scaled)
    Ja = np.repeat(acc, 2, axis=1)[:, None, :] * _turn(eye)
    spin = np.repeat(rate, 2, axis=1) ** 2
    stiffness = K + C @ Jw + m[:, None] * Ja - eye * (m * spin)[:, None, :]
    return Coefficients(stiffness=stiffness, damping=C + 2.0 * m[:, None] * Jw, load=np.zeros(co.load.shape))


def frozen_stiffness(system: PeriodicSystem, frames: LinkFrames, theta: np.ndarray) -> np.ndarray:
    """R^T K R at ``theta`` (m, n, n): the frozen structure in the link frames."""
    return _in_frames(system.coefficients(theta).stiffness, frames.of_lumps(theta)[0])


def greedy_basis(Ks: np.ndarray, modes: int, ritz_tolerance: float, max_size: int,
                 eigen: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray | None:
    """An orthonormal basis W (n, r) whose Ritz values on every matrix of ``Ks`` (m, n, n, symmetric:
    mass-scaled stiffnesses) match the ``modes`` lowest eigenvalues within ``ritz_tolerance`` (relative);
    None if that needs more than ``max_size`` columns.  ``eigen``: ``np.linalg.eigh(Ks)`` if at hand."""
    lam, X = np.linalg.eigh(Ks) if eigen is None else eigen
    lam, X = lam[:, :modes], X[:, :, :modes]
    n = Ks.shape[1]
    W = np.zeros((n, 0))
    j = 0
    while True:
        new = X[j] - W @ (W.T @ X[j])
        new -= W @ (W.T @ new)  # twice: orthogonal to round-off
        U, S, _ = np.linalg.svd(new, full_matrices=False)
        if not np.any(S > 1e-8):  # the worst angle's modes are spanned, its Ritz values still off: no progress
            return None
        W = np.concatenate([W, U[:, S > 1e-8]], axis=1)
        ritz = np.linalg.eigvalsh(W.T @ Ks @ W)[:, :modes]
        with np.errstate(divide="ignore", invalid="ignore"):  # a zero eigenvalue: NaN, never accepted
            err = np.max(np.abs(ritz - lam) / np.abs(lam), axis=1)
        if err.max() <= ritz_tolerance:
            return W
        if W.shape[1] >= max_size:
            return None
        j = int(np.argmax(err))


def static_corrections(Ks: np.ndarray, eigen: tuple[np.ndarray, np.ndarray], W: np.ndarray, modes: int,
                       threshold: float) -> np.ndarray:
    """W (n, r) extended by the static responses to the Coriolis and frame forces of the ``modes`` lowest
    frozen modes (the quasi-static correction vectors of modal truncation): lambda_k Ks^-1 J x_k at every
    angle of ``Ks`` (m, n, n, mass-scaled; J x the per-lump turn by 90 degrees, which the frame terms
    2 M phi' J v', M phi'' J v and C phi' J v apply to the modes: M is isotropic per lump, so in mass-scaled
    coordinates the force direction is J x itself), orthogonalized against W and compressed by an SVD
    keeping the directions whose RMS amplitude over the angles exceeds ``threshold`` (a mode itself has
    amplitude 1).  A Galerkin basis of frozen modes alone converges slowly with their number at high speed
    (measured, thesis distributed model at 500 rpm against the unreduced system: 14, 24, 28 columns of
    frozen modes 7e-4, 3e-4, 3e-5 off; 14 modes + 5 corrections 2e-5): the links' stiff directions respond
    quasi-statically to the gyroscopic forcing of the low modes, which no low frozen mode spans."""
    lam, X = eigen
    Z = lam[:, None, :modes] * np.linalg.solve(Ks, _turn(X[:, :, :modes]))
    Z = np.concatenate(list(Z), axis=1)
    Z -= W @ (W.T @ Z)
    Z -= W @ (W.T @ Z)  # twice: orthogonal to round-off
    U, S, _ = np.linalg.svd(Z, full_matrices=False)
    return np.concatenate([W, U[:, S / np.sqrt(Z.shape[1]) > threshold]], axis=1)


def projection(co: Coefficients, lumps: tuple[np.ndarray, np.ndarray, np.ndarray], mass: np.ndarray,
               V: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(K_r, C_r) (m, r, r) at the angles of ``co`` (the full coefficients) and ``lumps`` (their frame
    angles, rates and accelerations per lump): the Galerkin projection of the co-rotating system on the
    constant basis V (n, r), V^T M V = I, without forming R^T K R:

        K_r = W^T K W + W^T C (phi' J W) + sum_lumps m (phi'' V^T J V - phi'^2 V^T V),
        C_r = W^T C W + 2 sum_lumps m phi' V^T J V,       W = R V."""
    phi, rate, acc = lumps
    N = mass.size // 2
    V2, JV2 = V.reshape(N, 2, -1), _turn(V).reshape(N, 2, -1)
    gram = np.einsum("j,jai,jak->jik", mass[0::2], V2, V2)  # m V^T V per lump
    skew = np.einsum("j,jai,jak->jik", mass[0::2], V2, JV2)  # m V^T J V per lump
    W = rotate_columns(V, phi)
    Wt = np.swapaxes(W, 1, 2)
    Y = _turn(W) * np.repeat(rate, 2, axis=1)[:, :, None]  # R phi' J V = phi' J R V
    K = Wt @ (co.stiffness @ W) + Wt @ (co.damping @ Y) + np.einsum("mj,jik->mik", acc, skew) \
        - np.einsum("mj,jik->mik", rate**2, gram)
    C = Wt @ (co.damping @ W) + 2.0 * np.einsum("mj,jik->mik", rate, skew)
    return K, C


class InterpolatedCoefficients:
    """Reduced coefficients (K, C; no load) from samples on a uniform full-turn grid, trigonometric
    interpolation (:class:`ked_linear.sampled.TrigInterpolant`: one inverse FFT per uniform grid asked for,
    direct summation elsewhere)."""

    def __init__(self, K: np.ndarray, C: np.ndarray):
        self.size = K.shape[1]
        self.interpolant = TrigInterpolant(np.concatenate([K.reshape(K.shape[0], -1), C.reshape(C.shape[0], -1)],
                                                          axis=1))

    def __call__(self, theta: np.ndarray) -> Coefficients:
        theta = np.atleast_1d(np.asarray(theta, dtype=float))
        flat = self.interpolant.evaluate(theta)
        r = self.size
        return Coefficients(stiffness=flat[:, :r * r].reshape(-1, r, r), damping=flat[:, r * r:].reshape(-1, r, r),
                            load=np.zeros((theta.size, r)))


# --------------------------------------------------------------------------------------------------
# The ladder's Radau levels (the method: ked_linear.radau)

RESOLVED_H_OMEGA = 1.0
"""h omega of the lowest frozen mode (at its highest frequency over the cycle) from which a level counts
as resolved: its step changes the amplitude of an undamped oscillation by 1.3e-4, the phase by 2e-5 (the
three-stage stability function); coarser levels of a low-speed cycle damp the mode numerically and agree
with each other near 0.  The levels start at twice this step (h omega <= 2)."""

PROBE_AT = 0.5
"""The richer rung is propagated at the first level with at least this fraction of the resolved steps
(h omega <= 2), against the smaller one at the same steps: their discretization errors then nearly cancel."""

FIRST_CHANGE_RATIO = 8.0
"""With two levels (the coarser at h omega <= 2, the finer at <= 1), the finer one's error is estimated as
their change / 8: it assumes the error falls 9-fold per halving, where the three-stage method's amplitude
and phase errors per cycle fall 26 and 57-fold from h omega = 2 to 1 (order 5: 32-fold asymptotically).
From three levels on, the estimate of :func:`ked_linear.periodic.error_estimate` (the last change, or
the tail of a geometric series)."""

def radau_multipliers(system: PeriodicSystem, steps: int, stages: int = RADAU_STAGES) -> np.ndarray:
    """Floquet multipliers (2r,) of a unit-mass system by the ``stages``-stage Radau IIA method with
    ``steps`` per cycle, largest first."""
    if not np.allclose(system.mass, 1.0):
        raise ValueError("radau_multipliers: needs a unit-mass system (a reduced system)")
    c, a = tableau(stages)
    h = system.period / steps
    t = np.arange(steps) * h
    stage = [system.coefficients(system.speed * (t + ci * h)) for ci in c]  # one uniform grid each
    K, C = np.stack([co.stiffness for co in stage]), np.stack([co.damping for co in stage])
    phi = _product(radau_steps(K, C, h, a))
    mu = np.linalg.eigvals(phi)
    return mu[np.argsort(-np.abs(mu))]


@dataclass(frozen=True)
class Reduction:
    """A reduced Floquet analysis: ``result`` (the smaller basis; error = the step levels' estimate + twice
    the change to the richer basis + :data:`BASIS_SHARED`), the basis sizes (smaller, richer), the richer
    basis's max |mu| (at fewer steps, see :func:`reduced_floquet`), the change and the step levels'
    estimate."""

    result: FloquetResult
    sizes: tuple[int, int]
    richer_max_abs: float
    basis_change: float
    step_error: float


class Reductions:
    """The reduced systems of the ladder :data:`BASES` on one system, each built when first asked for
    (:meth:`system`): the full coefficients on a uniform grid, the frozen stiffness in the link frames and
    its eigendecomposition on the training angles are shared.

    ``usable``: False if the system is undamped (C = 0 on the grid: Hamiltonian, the full model's
    symplectic propagator decides); ``omega_kept``: the largest frozen angular frequency of the lowest
    mode over the cycle [rad/s] (with stiffness-proportional damping the least damped one)."""

    def __init__(self, system: PeriodicSystem, frames: LinkFrames):
        self.full, self.frames = system, frames
        G = 2 * TRAINING_ANGLES
        theta = np.arange(G) * (2.0 * np.pi / G)
        co = system.coefficients(theta)
        self.usable = bool(np.any(co.damping))
        self._systems: dict[int, _Reduced | None] = {}
        self._forcing: _Forcing | None = None
        self._bases: dict[tuple, np.ndarray | None] = {}
        self.grid_coefficients = co
        """The full coefficients on the uniform grid of 2 :data:`TRAINING_ANGLES` angles from 0 (shared with
        the periodic steady state, :func:`ked_linear.corotating.four_bar_steady_state`)."""
        if not self.usable:
            return
        lumps = frames.of_lumps(theta)
        self.grid_lumps = lumps
        """The frame angles, rates and accelerations per lump on that grid."""
        self._grids: dict[int, tuple[Coefficients, tuple[np.ndarray, np.ndarray, np.ndarray]]] = {G: (co, lumps)}
        train = slice(0, G, G // TRAINING_ANGLES)
        K = _in_frames(co.stiffness[train], lumps[0][train])  # R^T K R
        w = 1.0 / np.sqrt(system.mass)
        Ks = w[:, None] * K * w[None, :]
        self._Ks = 0.5 * (Ks + np.swapaxes(Ks, 1, 2))
        self._eigen = np.linalg.eigh(self._Ks)
        self.omega_kept = float(np.sqrt(np.max(np.abs(self._eigen[0][:, 0]))))

    def basis(self, i: int) -> np.ndarray | None:
        """The M-orthonormal basis V (n, r) of rung ``i`` of :data:`BASES` in v (None: not smaller than n);
        built once (the Floquet ladder and the periodic steady state ask for the same rungs)."""
        return self.basis_of(*BASES[i])

    def basis_of(self, modes: int, ritz_tolerance: float, correction: float | None) -> np.ndarray | None:
        """The M-orthonormal basis V (n, r) keeping ``modes`` frozen modes within ``ritz_tolerance`` with their
        static corrections above ``correction`` (None: none; :func:`static_corrections`), built once."""
        key = (modes, ritz_tolerance, correction)
        if key not in self._bases:
            W = self._orthonormal(modes, ritz_tolerance)
            if W is not None and correction is not None:
                W = static_corrections(self._Ks, self._eigen, W, modes, correction)
            self._bases[key] = None if W is None else W / np.sqrt(self.full.mass)[:, None]
        return self._bases[key]

    def _orthonormal(self, modes: int, ritz_tolerance: float) -> np.ndarray | None:
        """The greedy basis (orthonormal in mass-scaled coordinates) before corrections, built once."""
        key = (modes, ritz_tolerance, "greedy")
        if key not in self._bases:
            self._bases[key] = greedy_basis(self._Ks, modes, ritz_tolerance, self.full.mass.size, self._eigen)
        return self._bases[key]

    def _grid(self, G: int) -> tuple[Coefficients, tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """The full coefficients and frame angles at the midpoints of the G / 2 grid (G > the first grid)."""
        if G not in self._grids:
            mid = (np.arange(G // 2) + 0.5) * (4.0 * np.pi / G)
            self._grids[G] = (self.full.coefficients(mid), self.frames.of_lumps(mid))
        return self._grids[G]

    def reduced(self, i: int) -> _Reduced | None:
        """The reduced system of rung ``i`` (:class:`ked_linear.reducedsystem._Reduced`: the modal-acceleration
        (Petrov-Galerkin) projection, interpolated), or None if its basis or an interpolation within
        :data:`INTERPOLATION_TOLERANCE` on at most 512 angles cannot be had.  The one reduced system of that
        basis: its Radau passes (remembered by step count) give the Floquet ladder its multipliers and the
        periodic steady state its solution."""
        if i not in self._systems:
            self._systems[i] = self._build(i)
        return self._systems[i]

    def _build(self, i: int) -> _Reduced | None:
        V = self.basis(i)
        if V is None:
            return None
        if self._forcing is None:  # the frozen solution K^-1 f on the grid, as a spectrum: B q shared by the rungs
            co = self.grid_coefficients
            self._forcing = _Forcing(self.full, spectrum(np.linalg.solve(co.stiffness, co.load[..., None])[..., 0]))
        try:
            return _Reduced(self.full, self.frames.of_lumps, V, self._forcing.q_hat, self.grid_coefficients,
                            self.grid_lumps, self._grid, self._forcing)
        except (ValueError, np.linalg.LinAlgError):  # not interpolable, or the reduced mass singular
            return None


def ladder_levels(red: Reductions) -> tuple[tuple[int, ...], float, int | None]:
    """The Radau levels of the reduced Floquet ladder on ``red`` (:data:`RADAU_LEVELS` from the first with
    h omega <= 2 for the lowest frozen mode), the steps resolving that mode (h omega = 1) and the level at
    which a rung is checked against the next (:data:`PROBE_AT`; None if no level qualifies)."""
    resolved = red.omega_kept * red.full.period / RESOLVED_H_OMEGA
    levels = tuple(n for n in RADAU_LEVELS if n >= 0.5 * resolved)
    return levels, resolved, next((n for n in levels if n >= PROBE_AT * resolved), None)


class _BasisFails(Exception):
    """Raised by a level probe of :func:`_levels`: the basis change alone exceeds what the rung may have."""


def _levels(propagate: Callable[[int], np.ndarray], levels: tuple[int, ...], resolved: float, tolerance: float,
            probe: Callable[[int, float], None] | None = None) -> tuple[list[float], int, float, np.ndarray] | None:
    """Radau levels (``levels``; ``propagate(steps)``: the multipliers) until, with at least ``resolved``
    steps, the step error estimate is below ``tolerance`` / 8: (max |mu| per level, steps, estimate,
    multipliers).  ``probe(steps, max |mu|)`` is called after each level (it may raise
    :class:`_BasisFails`)."""
    tops: list[float] = []
    changes: list[float] = []
    for steps in levels:
        mu = propagate(steps)
        tops.append(float(np.abs(mu[0])))
        if probe is not None:
            probe(steps, tops[-1])
        if len(tops) >= 2:
            changes.append(abs(tops[-1] - tops[-2]))
        if changes and steps >= resolved:
            est = error_estimate(changes) if len(changes) >= 2 else changes[0] / FIRST_CHANGE_RATIO
            if est < 0.125 * tolerance:
                return tops, steps, est, mu
    return None


def reduced_floquet(system: PeriodicSystem, frames: LinkFrames, tolerance: float,
                    reductions: Reductions | None = None) -> Reduction | None:
    """max |mu| of ``system`` from its reductions (module docstring), or None when they cannot vouch for
    ``tolerance`` / 2 (or the answer is near instability, or the system is undamped): use the full model.

    A rung of :data:`BASES` is propagated at :data:`RADAU_LEVELS` steps from the first with h omega <= 2
    for the lowest frozen mode (at its highest frequency over the cycle); once a level resolves it
    (h omega <= 1, :data:`RESOLVED_H_OMEGA`) the error of the last level is estimated from the changes
    between levels (two levels: :data:`FIRST_CHANGE_RATIO`; more: as in the periodic solve,
    :func:`ked_linear.periodic.error_estimate`), and the levels stop once it is below ``tolerance`` / 8.
    The next rung is propagated once, at the first level with h omega <= 2 (:data:`PROBE_AT`), against
    this one at the same steps (their discretization errors then nearly cancel); twice their difference
    plus :data:`BASIS_SHARED` is the basis error. If the sum is not below ``tolerance`` / 2 the next rung is
    tried against the one after it; the richer rung is propagated as soon as the smaller one reaches that
    level, and when the basis error alone exceeds ``tolerance`` / 2 the smaller rung stops there and the
    next is tried (its further levels could only add to its estimate).  ``reductions``: the
    :class:`Reductions` of ``system`` on ``frames`` if already built (the periodic steady state shares it)."""
    red = Reductions(system, frames) if reductions is None else reductions
    if not red.usable:
        return None
    levels, resolved, first = ladder_levels(red)  # from twice the step resolving the lowest mode
    if not levels:
        return None
    runs: dict[tuple[int, int], np.ndarray] = {}  # (rung, steps): multipliers (a failed rung's probe is the
    # next rung's first level)

    def propagate(i: int, steps: int) -> np.ndarray:
        if (i, steps) not in runs:
            runs[(i, steps)] = red.reduced(i).propagate(steps).multipliers  # type: ignore[union-attr]
        return runs[(i, steps)]

    for i in range(len(BASES) - 1):
        small, rich = red.reduced(i), red.reduced(i + 1)
        if small is None or rich is None:
            return None
        # the richer rung at the first level resolving the lowest mode within h omega <= 2, computed as soon as
        # the smaller one reaches it: a basis change alone above what this rung may have ends the rung there
        # (its remaining levels could only add to the estimate)
        seen: dict[int, float] = {}

        def probe(steps: int, top: float, i: int = i, first: int | None = first, seen: dict[int, float] = seen) -> None:
            if steps == first:
                seen[steps] = float(np.abs(propagate(i + 1, steps)[0]))
                if BASIS_FACTOR * abs(seen[steps] - top) + BASIS_SHARED > 0.5 * tolerance:
                    raise _BasisFails

        try:
            done = _levels(lambda steps, i=i: propagate(i, steps), levels, resolved, tolerance, probe)
        except _BasisFails:
            continue
        if done is None:
            return None
        tops, steps, step_est, mu = done
        check = min(first, steps) if first is not None else steps
        other = seen[check] if check in seen else float(np.abs(propagate(i + 1, check)[0]))
        basis_change = abs(other - tops[levels.index(check)])
        est = max(step_est + BASIS_FACTOR * basis_change + BASIS_SHARED, ESTIMATE_FLOOR)
        if not np.isfinite(tops[-1]) or tops[-1] + est >= FULL_NEAR_ONE:
            return None
        if est <= 0.5 * tolerance:
            result = FloquetResult(max_abs=tops[-1], error_estimate=est, steps=steps, multipliers=mu, reduced=True)
            return Reduction(result=result, sizes=(small.r, rich.r), richer_max_abs=other,
                             basis_change=basis_change, step_error=step_est)
    return None
