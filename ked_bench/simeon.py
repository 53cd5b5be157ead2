"""Simeon's flexible slider-crank (Test Set for IVP solvers, problem "crank"): an independent reference.

B. Simeon, "Modelling a flexible slider crank mechanism by a mixed system of DAEs and PDEs", Math.
Modelling of Systems 2 (1996) 1-18.  Data sheet: ``shared/benchmarks/simeon_slider_crank.md``.

The mechanism: a rigid crank (angle phi1, prescribed phi1 = Omega t), a flexible connecting rod (angle
phi2 of its chord frame, elastic coordinates q), a slider (x3) on the line through the crank pivot.  The rod
is discretized with two lateral modal functions sin(pi xi), sin(2 pi xi) (q1 = lateral midspan
deflection, q2) and two axial nodes of a quadratic shape (q3 at midspan, q4 at the slider end).

Equations of motion (written here from the published model, position p = (phi1, phi2, x3), q (4,),
velocities v = (p', q'), all SI):

    M(p, q) w + G(p, q)^T lambda = f(p, q, v),     G(p, q) w = -gamma(p, q, v)

with the 7 x 7 mass matrix M, the force vector f (centrifugal, Coriolis, elastic -K q, damping -D q'),
and the three constraints (the rod end on the slider line, the slider at x3, phi1 = Omega t) and their
Jacobian G.  The index-1 form solves the saddle-point system for the accelerations w at every
evaluation and integrates (p, v) with a high-order explicit Runge-Kutta method (DOP853) at tight
tolerances: the constraint drift over 0.1 s stays far below the published digits.

The published matrices use PI = 3.1415927 (the model's own constant, kept as :data:`MODEL_PI`) and an
axial mass block rho b h L2 [[8, 1], [1, 2]] (15 times a consistent quadratic element): both are part of
the published reference and kept as written.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import solve_ivp

MODEL_PI = 3.1415927
"""The value of pi inside the published model's matrices (the Fortran constant)."""

COMPONENTS = ("phi1", "phi2", "x3", "q1", "q2", "q3", "q4",
              "phi1_dot", "phi2_dot", "x3_dot", "q1_dot", "q2_dot", "q3_dot", "q4_dot")
"""State components in the published order: positions [rad, rad, m, m x 4], then their time derivatives."""

PUBLISHED_T = 0.1
"""Time [s] of the published reference state."""

PUBLISHED = {
    "phi1": 15.00000000000010, "phi2": -0.3311734988256260, "x3": 0.1697373328427860,
    "q1": 1.893192899613509e-4, "q2": 2.375751249879174e-5, "q3": -5.323896770569702e-6,
    "q4": -8.363313279112129e-6,
    "phi1_dot": 150.0, "phi2_dot": 60.25346755138369, "x3_dot": -8.753116326670527,
    "q1_dot": -3.005541400289738e-2, "q2_dot": -5.500431812571696e-3, "q3_dot": 4.974111734266989e-4,
    "q4_dot": 1.105560003626645e-3,
}
"""The published state at t = 0.1 s (linear stiffness, no damping; MEBDFI at tolerance 1e-14)."""

INITIAL_STATE = (0.0, 0.0, 0.450016933, 0.0, 0.0, 0.103339863e-4, 0.169327969e-4,
                 150.0, -74.9957670, -0.268938672e-5, 0.444896105, 0.463434311e-2, -0.178591076e-5,
                 -0.268938672e-5)
"""The published initial values, set 1 ("close to smooth motion"), 9 digits, order of :data:`COMPONENTS`."""

DAMPING_MATRIX = ((5.0, 0.0, 0.0, 0.0), (0.0, 25.0, 0.0, 0.0),
                  (0.0, 0.0, 0.5 * 2.308375455264791e2, -0.5 * 2.62688487992052e2),
                  (0.0, 0.0, -0.5 * 2.626884879920526e2, 0.5 * 4.217421837156818e2))
"""The published damping matrix DQ [N s/m] of the elastic coordinates (its option "damping on")."""


STIFFNESS_MODELS = ("linear", "published_nonlinear", "full_quartic", "geometric")
"""The rod's elastic forces (w lateral, u axial deflection, the axial strain u' + w'^2 / 2).

* ``linear``: K q (the published default, no geometric stiffness).
* ``published_nonlinear``: the published option "nonlinear stiffness term" (Ex_crank.f, IPAR(1) = 1) as
  written: K q plus the gradient of the cubic energy (E A / 2) int u' w'^2 dx, without the quartic
  (E A / 8) int w'^4 dx.  Inconsistent: bending shortens the chord, q4 follows (q4 = -pi^2 q1^2 / (4 L2)
  on a rod free of axial load), and FACK q1 q4 then acts as a spurious compression E A q4 / L2 (about
  1 kN, 13.5 % of the Euler load, at a 1.7 mm midspan deflection): the rod softens.
* ``full_quartic``: the complete energy (E A / 2) int (u' + w'^2 / 2)^2 dx with the published shape
  functions.  The quadratic axial element (u' linear) cannot follow the cos^2 shape of w'^2 / 2: membrane
  locking, a spurious hardening FACK pi^2 q1^3 / (8 L2) on a rod free of axial load (half the published
  option's softening, opposite sign).
* ``geometric``: (E A / 2) int (u' + P[w'^2 / 2])^2 dx, P the L2 projection onto linear functions (the
  space of u'): the same cubic terms as the published option (u' is linear, so int u' P[s] = int u' s)
  plus the projected quartic term; locking-free (a rod free of axial load bends without axial force) and
  its bending force is int N w' dw'/dq dx with the element's axial force N = E A (u' + P[w'^2 / 2]):
  the rod's geometric stiffening by its axial force, the physics of the harness's geometrically
  nonlinear beams and prestressed linear tier."""


@dataclass(frozen=True)
class SimeonParameters:
    """The published parameters (SI).  Crank: length l1 [m], mass m1 [kg], inertia j1 [kg m^2] about its
    pivot; rod: length l2 [m], mass m2 [kg], inertia j2 [kg m^2] about its end, square section b x h [m],
    Young's modulus e [Pa], density rho [kg/m^3]; slider mass m3 [kg]; crank speed omega [rad/s];
    ``damped``: the published damping matrix on or off; ``consistent_axial_mass``: replace the published
    axial mass block rho b h L2 [[8, 1], [1, 2]] by the consistent quadratic element's, 1/15 of it (a
    variant, to measure what the published block changes; False: the published model); ``stiffness``: the
    rod's elastic forces, one of :data:`STIFFNESS_MODELS` ("linear": K q, the published default)."""

    l1: float = 0.15
    l2: float = 0.30
    m1: float = 0.36
    m2: float = 0.151104
    m3: float = 0.075552
    j1: float = 0.002727
    j2: float = 0.0045339259
    b: float = 0.008
    h: float = 0.008
    e: float = 0.20e12
    rho: float = 7870.0
    omega: float = 150.0
    damped: bool = False
    consistent_axial_mass: bool = False
    stiffness: str = "linear"

    def __post_init__(self) -> None:
        if self.stiffness not in STIFFNESS_MODELS:
            raise ValueError(f"SimeonParameters.stiffness: must be one of {', '.join(STIFFNESS_MODELS)}; "
                             f"got {self.stiffness!r}")
        for name in ("l1", "l2", "m1", "m2", "m3", "j1", "j2", "b", "h", "e", "rho"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"SimeonParameters.{name}: must be a finite number > 0; got {value!r}")
        if not (math.isfinite(self.omega) and self.omega != 0.0):
            raise ValueError(f"SimeonParameters.omega: must be a finite, nonzero crank speed [rad/s]; "
                             f"got {self.omega!r}")

    @property
    def first_bending_rad_s(self) -> float:
        """First bending frequency [rad/s] of the pinned-pinned rod, (pi/l2)^2 sqrt(E I / (rho A))."""
        return (math.pi / self.l2) ** 2 * math.sqrt(self.e * self.h**2 / 12.0 / self.rho)


@dataclass(frozen=True)
class RodMatrices:
    """The elastic rod's matrices (model pi): mass mq, stiffness kq, damping dq (4, 4); the skew coupling
    bq (4, 4) and the coupling vectors c1, c2, c12, c21 (4,) of the published model (all divided by rho
    where the model multiplies them by rho)."""

    mq: np.ndarray
    kq: np.ndarray
    dq: np.ndarray
    bq: np.ndarray
    c1: np.ndarray
    c2: np.ndarray
    c12: np.ndarray
    c21: np.ndarray


def rod_matrices(par: SimeonParameters) -> RodMatrices:
    """The published discretization of the rod (two lateral modes, a quadratic axial element)."""
    pi = MODEL_PI
    facm, fack, facb = par.rho * par.b * par.h * par.l2, par.e * par.b * par.h / par.l2, par.b * par.h * par.l2
    slender = (par.h / par.l2) ** 2
    axial = 1.0 / 15.0 if par.consistent_axial_mass else 1.0
    mq = facm * np.array([[0.5, 0, 0, 0], [0, 0.5, 0, 0], [0, 0, 8.0 * axial, axial], [0, 0, axial, 2.0 * axial]])
    kq = fack * np.array([[pi**4 / 24.0 * slender, 0, 0, 0], [0, pi**4 * 2.0 / 3.0 * slender, 0, 0],
                          [0, 0, 16.0 / 3.0, -8.0 / 3.0], [0, 0, -8.0 / 3.0, 7.0 / 3.0]])
    bq = np.zeros((4, 4))
    bq[0, 2], bq[0, 3], bq[1, 3] = -16.0 / pi**3, 8.0 / pi**3 - 1.0 / pi, 0.5 / pi
    bq = facb * (bq - bq.T)
    c1 = facb * np.array([0.0, 0.0, 2.0 / 3.0, 1.0 / 6.0])
    c2 = facb * np.array([2.0 / pi, 0.0, 0.0, 0.0])
    c12 = par.l2 * facb * np.array([0.0, 0.0, 1.0 / 3.0, 1.0 / 6.0])
    c21 = par.l2 * facb * np.array([1.0 / pi, -0.5 / pi, 0.0, 0.0])
    dq = np.array(DAMPING_MATRIX) if par.damped else np.zeros((4, 4))
    return RodMatrices(mq=mq, kq=kq, dq=dq, bq=bq, c1=c1, c2=c2, c12=c12, c21=c21)


@dataclass(frozen=True)
class SimeonModel:
    """The equations of motion of one parameter set (see the module docstring)."""

    par: SimeonParameters = field(default_factory=SimeonParameters)

    def __post_init__(self) -> None:
        object.__setattr__(self, "rod", rod_matrices(self.par))

    def mass_and_force(self, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """M (7, 7) [kg, kg m, kg m^2] and f (7,) [N, N m] at the state y (14,)."""
        par, rod, rho = self.par, self.rod, self.par.rho
        p1, p2 = y[0], y[1]
        q, v1, v2, qd = y[3:7], y[7], y[8], y[10:14]
        s12, c12 = math.sin(p1 - p2), math.cos(p1 - p2)
        c1q, c2q, c12q = rod.c1 @ q, rod.c2 @ q, rod.c12 @ q
        c1qd, c2qd, c12qd = rod.c1 @ qd, rod.c2 @ qd, rod.c12 @ qd
        mqq, bqqd = rod.mq @ q, rod.bq @ qd
        m = np.zeros((7, 7))
        m[0, 0] = par.j1 + par.m2 * par.l1**2
        m[0, 1] = 0.5 * par.l1 * par.l2 * par.m2 * c12 + rho * par.l1 * (s12 * c2q + c12 * c1q)
        m[1, 1] = par.j2 + q @ mqq + 2.0 * rho * c12q
        m[2, 2] = par.m3
        m[0, 3:] = rho * par.l1 * (-s12 * rod.c1 + c12 * rod.c2)
        m[1, 3:] = rho * rod.c21 + rho * (q @ rod.bq)
        m[3:, 3:] = rod.mq
        m = np.triu(m) + np.triu(m, 1).T
        f = np.empty(7)
        f[0] = (-0.5 * par.l1 * par.l2 * par.m2 * v2**2 * s12
                + rho * par.l1 * v2**2 * (-s12 * c1q + c12 * c2q) - 2.0 * rho * par.l1 * v2 * (c12 * c1qd + s12 * c2qd))
        f[1] = (0.5 * par.l1 * par.l2 * par.m2 * v1**2 * s12 + rho * par.l1 * v1**2 * (s12 * c1q - c12 * c2q)
                - 2.0 * rho * v2 * c12qd - 2.0 * v2 * (qd @ mqq) - rho * (qd @ bqqd))
        f[2] = 0.0
        f[3:] = (v2**2 * mqq + rho * (v2**2 * rod.c12 + par.l1 * v1**2 * (c12 * rod.c1 + s12 * rod.c2)
                                       + 2.0 * v2 * bqqd) - rod.kq @ q - rod.dq @ qd)
        if par.stiffness != "linear":
            f[3:] -= nonlinear_stiffness_force(par, q)
        return m, f

    def constraints(self, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Constraint Jacobian G (3, 7) and the velocity-product term gamma (3,): G w + gamma = 0."""
        par = self.par
        p1, p2, q4 = y[0], y[1], y[6]
        v1, v2, q4d = y[7], y[8], y[13]
        sp1, cp1, sp2, cp2 = math.sin(p1), math.cos(p1), math.sin(p2), math.cos(p2)
        g = np.zeros((3, 7))
        g[0, 0], g[0, 1], g[0, 6] = par.l1 * cp1, (par.l2 + q4) * cp2, sp2
        g[1, 0], g[1, 1], g[1, 2], g[1, 6] = par.l1 * sp1, (par.l2 + q4) * sp2, 1.0, -cp2
        g[2, 0] = 1.0
        gamma = np.array([-par.l1 * sp1 * v1**2 - (par.l2 + q4) * sp2 * v2**2 + 2.0 * v2 * cp2 * q4d,
                          par.l1 * cp1 * v1**2 + (par.l2 + q4) * cp2 * v2**2 + 2.0 * v2 * sp2 * q4d,
                          0.0])
        return g, gamma

    def accelerations(self, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Accelerations w (7,) and Lagrange multipliers lambda (3,) at the state y (index-1 solve)."""
        m, f = self.mass_and_force(y)
        g, gamma = self.constraints(y)
        sol = np.linalg.solve(_saddle(m, g), np.concatenate([f, -gamma]))
        return sol[:7], sol[7:]

    def rhs(self, t: float, y: np.ndarray) -> np.ndarray:
        """dy/dt of the index-1 system, y = (p, q, p', q') (14,)."""
        return np.concatenate([y[7:], self.accelerations(y)[0]])

    def velocity_residual(self, y: np.ndarray) -> np.ndarray:
        """The velocity constraints G v - (0, 0, Omega) (3,) [m/s, m/s, rad/s]."""
        g, _ = self.constraints(y)
        return g @ y[7:] - np.array([0.0, 0.0, self.par.omega])

    def project_velocities(self, y: np.ndarray) -> np.ndarray:
        """The state with its velocities projected (in the mass metric) onto the velocity constraint."""
        m, _ = self.mass_and_force(y)
        g, _ = self.constraints(y)
        dv = np.linalg.solve(_saddle(m, g), np.concatenate([np.zeros(7), -self.velocity_residual(y)]))[:7]
        return np.concatenate([y[:7], y[7:] + dv])

    def rigid_start(self) -> np.ndarray:
        """A consistent state at phi1 = 0 with the rod undeformed (q = q' = 0): the start of a run-up."""
        par = self.par
        y = np.zeros(14)
        y[2], y[7], y[8] = par.l1 + par.l2, par.omega, -par.l1 * par.omega / par.l2
        return y


def nonlinear_stiffness_force(par: SimeonParameters, q: np.ndarray) -> np.ndarray:
    """The rod's elastic force beyond K q [N] (4,) for ``par.stiffness`` (:data:`STIFFNESS_MODELS`; zero for
    "linear").  With w = q1 sin(pi xi) + q2 sin(2 pi xi), u = q3 4 xi (1 - xi) + q4 xi (2 xi - 1) (xi = x / L2):
    the gradient of the cubic energy (E A / 2) int u' w'^2 dx is the published term (Ex_crank.f, its
    constants FACK = E A pi^2 / (2 L2^2), FACB = 80 / (9 pi^2)); "full_quartic" adds the gradient of
    (E A / 8) int w'^4 dx = FACK pi^2 / (4 L2) (3/8 q1^4 + 6 q1^2 q2^2 + 6 q2^4); "geometric" that of the
    projected quartic (E A L2 / 2) (a0^2 + 12 a1^2), a0 = int s dxi = FACK / (E A) (q1^2 / 2 + 2 q2^2),
    a1 = int s (xi - 1/2) dxi = -20 q1 q2 / (9 L2^2), s = w'^2 / 2 (model pi)."""
    if par.stiffness == "linear":
        return np.zeros(4)
    q1, q2, q3, q4 = (float(v) for v in q)
    ea, length, pi = par.e * par.b * par.h, par.l2, MODEL_PI
    fack = 0.5 * ea / length**2 * pi**2
    facb = 80.0 / (pi**2 * 9.0)
    force = fack * np.array([q1 * q4 - facb * q2 * (-4.0 * q3 + 2.0 * q4),
                             4.0 * q2 * q4 - facb * q1 * (-4.0 * q3 + 2.0 * q4),
                             4.0 * facb * q1 * q2,
                             0.5 * q1**2 + 2.0 * q2**2 - 2.0 * facb * q1 * q2])
    if par.stiffness == "full_quartic":
        quartic = fack * pi**2 / (4.0 * length)
        force[0] += quartic * (1.5 * q1**3 + 12.0 * q1 * q2**2)
        force[1] += quartic * (24.0 * q2**3 + 12.0 * q1**2 * q2)
    elif par.stiffness == "geometric":
        a0 = fack / ea * (0.5 * q1**2 + 2.0 * q2**2)
        a1 = -20.0 * q1 * q2 / (9.0 * length**2)
        grad_a0 = fack / ea * np.array([q1, 4.0 * q2])
        grad_a1 = -20.0 / (9.0 * length**2) * np.array([q2, q1])
        force[:2] += ea * length * (a0 * grad_a0 + 12.0 * a1 * grad_a1)
    return force


def _saddle(m: np.ndarray, g: np.ndarray) -> np.ndarray:
    """The saddle-point matrix [[M, G^T], [G, 0]] (10, 10)."""
    kkt = np.zeros((10, 10))
    kkt[:7, :7], kkt[:7, 7:], kkt[7:, :7] = m, g.T, g
    return kkt


def integrate(model: SimeonModel, y0: np.ndarray, t_end: float, *, rtol: float = 1e-12, atol: float = 1e-15,
              t_eval: np.ndarray | None = None):
    """The index-1 system from y0 at t = 0 to ``t_end`` [s] (scipy DOP853); the solve_ivp result."""
    sol = solve_ivp(model.rhs, (0.0, t_end), np.asarray(y0, dtype=float), method="DOP853", rtol=rtol, atol=atol,
                    t_eval=t_eval)
    if not sol.success:
        raise RuntimeError(f"Simeon slider-crank integration failed at t = {sol.t[-1]:.6g} s: {sol.message}")
    return sol


@dataclass(frozen=True)
class Reproduction:
    """The published state and this implementation's at t = 0.1 s.  ``relative_error``: |reproduced -
    published| / |published| per component; ``max_relative_error`` over components 1-7 (the positions,
    as the test set scores them); ``velocity_residual`` of the initial state used [m/s, m/s, rad/s]."""

    published: dict[str, float]
    reproduced: dict[str, float]
    relative_error: dict[str, float]
    max_relative_error: float
    projected: bool
    velocity_residual: float


def reproduce(*, project: bool = True, rtol: float = 1e-10) -> Reproduction:
    """Integrate the published problem (linear stiffness, no damping, initial set 1) to t = 0.1 s.

    ``project``: project the 9-digit initial velocities onto the velocity constraint first (their
    residual is ~1e-8; without it the state agrees to ~3e-8 relative, with it to ~1e-10)."""
    model = SimeonModel()
    y0 = np.array(INITIAL_STATE)
    residual = float(np.max(np.abs(model.velocity_residual(y0))))
    if project:
        y0 = model.project_velocities(y0)
    y = integrate(model, y0, PUBLISHED_T, rtol=rtol).y[:, -1]
    reproduced = dict(zip(COMPONENTS, (float(v) for v in y)))
    rel = {k: abs(reproduced[k] - v) / abs(v) for k, v in PUBLISHED.items()}
    return Reproduction(published=dict(PUBLISHED), reproduced=reproduced, relative_error=rel,
                        max_relative_error=max(rel[k] for k in COMPONENTS[:7]), projected=project,
                        velocity_residual=residual)


@dataclass(frozen=True)
class SteadyState:
    """The damped periodic steady state of the reference model at one crank speed.

    crank_angle (n,) [rad] over one cycle from 0 (uniform, last sample not repeating the first);
    midspan (n,) [m]: the rod's lateral midspan deflection q1 (the elastic deflection normal to the rod's
    chord); cycles: crank cycles marched; change: max |q1(cycle) - q1(cycle - 1)| / peak at the end."""

    omega: float
    crank_angle: np.ndarray
    midspan: np.ndarray
    cycles: int
    change: float

    @property
    def peak(self) -> float:
        """max |q1| over the cycle [m]."""
        return float(np.max(np.abs(self.midspan)))


def steady_state(omega: float, *, samples: int = 72, tolerance: float = 1e-8, max_cycles: int = 40,
                 rtol: float = 1e-10, consistent_axial_mass: bool = False, stiffness: str = "linear") -> SteadyState:
    """March the damped model (published damping matrix) from the rigid start at crank speed ``omega``
    [rad/s] cycle by cycle until the midspan history repeats within ``tolerance`` of its peak
    (``consistent_axial_mass``, ``stiffness``: the variants of :class:`SimeonParameters`)."""
    model = SimeonModel(SimeonParameters(omega=omega, damped=True, consistent_axial_mass=consistent_axial_mass,
                                         stiffness=stiffness))
    period = 2.0 * math.pi / abs(omega)
    y, last, change = model.rigid_start(), None, math.inf
    for cycle in range(1, max_cycles + 1):
        sol = integrate(model, y, period, rtol=rtol, atol=1e-14, t_eval=np.linspace(0.0, period, samples + 1))
        hist, y = sol.y[3, :-1].copy(), sol.y[:, -1].copy()
        y[0] -= 2.0 * math.pi * math.copysign(1.0, omega)  # phi1 = Omega t restarts each cycle
        if last is not None:
            change = float(np.max(np.abs(hist - last)) / max(np.max(np.abs(hist)), 1e-300))
            if change < tolerance:
                return SteadyState(omega, np.arange(samples) * 2.0 * math.pi / samples, hist, cycle, change)
        last = hist
    raise RuntimeError(f"Simeon slider-crank at {omega:g} rad/s: no periodic steady state within {max_cycles} "
                       f"cycles (last change {change:.2g} of the peak)")


def simeon_scene(omega: float, step_deg: float = 5.0, lumps: int = 5):
    """The harness's scene of the benchmark (the ``--linkage simeon`` scene: distributed mass, the rod's own and the
    slider's; rigid crank) at crank speed ``omega`` [rad/s] (> 0, CCW) on a grid of ``step_deg`` [deg], the rod in
    ``lumps`` lumps (the linear tier takes :data:`ked_bench.tiers.LUMPS`)."""
    from ked_quasi.slidercrank import build_slider_scene, simeon_slider_crank
    from ked_quasi.units import rad_s_to_rpm

    if not (math.isfinite(omega) and omega > 0.0):
        raise ValueError(f"omega: must be a positive crank speed [rad/s]; got {omega!r}")
    return build_slider_scene(simeon_slider_crank(), "distributed", rad_s_to_rpm(omega), step_deg, lumps=lumps)
