"""Input settings of the Exudyn flexible-multibody model (frozen, validated on construction).

Units: SI (s, Hz, rad). All fields are plain values so settings can be hashed, printed and
stored next to results.
"""

from __future__ import annotations

from dataclasses import dataclass

ELEMENT_TYPES = ("ancf", "gebeam")
STARTS = ("ramp", "quasi_static")
PERIODIC_METHODS = ("off", "anderson")


@dataclass(frozen=True)
class DynamicSettings:
    """Discretization, damping and solver settings of one steady-state run.

    element: "ancf" (ObjectANCFCable2D, default) or "gebeam" (ObjectBeamGeometricallyExact2D; its
        linear interpolation needs ~4x more elements than the cubic ANCF for the same accuracy).
    elements_per_link: finite elements per link (crank, coupler, extender, follower each).
    steps_per_cycle: fixed implicit time steps per crank revolution.
    spectral_radius: generalized-alpha spectral radius at infinite frequency (numerical damping
        of the highest modes; 1 = none).
    damping_ratio: modal damping ratio zeta of the structure at damping_reference_hz. It is applied
        as stiffness-proportional (Rayleigh beta) damping of every beam, see exudyn_models.damping.
    damping_reference_hz: frequency [Hz] at which the modal damping ratio equals damping_ratio;
        None -> the first natural frequency of the frozen structure, averaged over the crank-angle
        grid (ked_quasi.solver.natural_frequencies, same mass model).
    ramp_cycles: duration of the smooth start-up ramp in crank revolutions at full speed; the crank
        speed rises from rest as Omega*(3 tau^2 - 2 tau^3), so the crank acceleration is zero at
        the start and at the end of the ramp.
    steady_tol: periodic steady state is reached when two successive cycles of the coupler-point
        deflection on the scene grid differ by less than steady_tol times the peak (dx, dy against
        the peak of |dx|, |dy|; rotation against its peak). The transient left is then of the order
        of steady_tol (the default 2e-3 keeps it well inside a 1 % error budget).
    min_cycles / max_cycles: cycles at constant speed simulated at least / at most.
    extrapolate: also accept the limit cycle extrapolated from the last 4 cycles once it has settled
        (exudyn_models.simulate.extrapolate_limit); False returns only simulated cycles.
    newton_abs_tol [N], newton_rel_tol: upper bounds of the Newton tolerances of Exudyn's residual
        (forces). A run tightens them to the scene's quasi-static deflection and loads, so that small
        deflections (low speed) are resolved as well as large ones; the absolute tolerance is kept at
        least 1e-13 * E*A (round-off, very stiff links). See exudyn_models.tolerance.
    newton_max_iterations: Newton iterations per step before the step counts as failed.
    sparse: use Exudyn's sparse (Eigen) linear solver instead of the dense one.
    start: how the constant-speed phase begins. "ramp": from rest through the smooth start-up ramp
        of ramp_cycles (the original behaviour); "quasi_static": at full speed from crank angle 0, every
        node on its rigid-kinematics position, velocity and acceleration plus the quasi-static deflected
        shape (Exudyn static solve of the frozen linkage under the d'Alembert loads -M a_rigid) and its
        rate; ramp_cycles is then unused. See exudyn_models.start.
    periodic: "off": march cycle after cycle (steady-state test and extrapolation as above);
        "anderson": solve the periodic orbit directly: the full Exudyn state at the start of a cycle is
        the unknown of the fixed point x = Phi(x) (Phi = one simulated crank cycle), accelerated by
        Anderson mixing; steady only when a plain continuation cycle passes the steady_tol test
        (exudyn_models.periodic).
    anderson_memory: previous cycles kept by the Anderson mixing (periodic = "anderson").
    refine: on a Newton failure, retry with the refinement ladder of exudyn_models.refine (more Newton
        iterations, then 2x/4x/8x the steps per cycle, then 2x the elements per link) until a run goes
        through or refine_budget_s is spent. False keeps the original behaviour (raise at once).
    refine_budget_s: wall-time budget [s] of all attempts of one run together (the first included);
        a rung whose estimated cost exceeds what is left is skipped and recorded as such.
    """

    element: str = "ancf"
    elements_per_link: int = 4
    steps_per_cycle: int = 720
    spectral_radius: float = 0.9
    damping_ratio: float = 0.02
    damping_reference_hz: float | None = None
    ramp_cycles: float = 0.5
    steady_tol: float = 2e-3
    min_cycles: int = 2
    max_cycles: int = 80
    extrapolate: bool = True
    newton_abs_tol: float = 1e-4
    newton_rel_tol: float = 1e-6
    newton_max_iterations: int = 12
    sparse: bool = True
    start: str = "ramp"
    periodic: str = "off"
    anderson_memory: int = 5
    refine: bool = True
    refine_budget_s: float = 120.0

    def __post_init__(self) -> None:
        if self.element not in ELEMENT_TYPES:
            raise ValueError(f"element must be one of {ELEMENT_TYPES}, got {self.element!r}")
        for name in ("elements_per_link", "steps_per_cycle", "min_cycles", "max_cycles",
                     "newton_max_iterations"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value <= 0:
                raise ValueError(f"{name} must be a positive integer, got {value!r}")
        if self.start not in STARTS:
            raise ValueError(f"start must be one of {STARTS}, got {self.start!r}")
        if self.periodic not in PERIODIC_METHODS:
            raise ValueError(f"periodic must be one of {PERIODIC_METHODS}, got {self.periodic!r}")
        if isinstance(self.anderson_memory, bool) or not isinstance(self.anderson_memory, int) \
                or not 1 <= self.anderson_memory <= 20:
            raise ValueError(f"anderson_memory must be an integer in 1..20, got {self.anderson_memory!r}")
        if not isinstance(self.refine, bool):
            raise ValueError(f"refine must be True or False, got {self.refine!r}")
        if isinstance(self.refine_budget_s, bool) or not self.refine_budget_s > 0.0:
            raise ValueError(f"refine_budget_s must be positive [s], got {self.refine_budget_s!r}")
        if self.min_cycles > self.max_cycles:
            raise ValueError(f"min_cycles ({self.min_cycles}) must not exceed max_cycles ({self.max_cycles})")
        if not 0.0 <= self.spectral_radius <= 1.0:
            raise ValueError(f"spectral_radius must be in [0, 1], got {self.spectral_radius!r}")
        if not 0.0 <= self.damping_ratio < 1.0:
            raise ValueError(f"damping_ratio must be in [0, 1), got {self.damping_ratio!r}")
        if self.damping_reference_hz is not None and not self.damping_reference_hz > 0.0:
            raise ValueError(f"damping_reference_hz must be positive or None, got {self.damping_reference_hz!r}")
        if not self.ramp_cycles > 0.0:
            raise ValueError(f"ramp_cycles must be positive, got {self.ramp_cycles!r}")
        for name in ("steady_tol", "newton_abs_tol", "newton_rel_tol"):
            if not getattr(self, name) > 0.0:
                raise ValueError(f"{name} must be positive, got {getattr(self, name)!r}")


LEGACY_DEFAULTS: dict[str, object] = {
    "start": "ramp",
    "periodic": "off",
    "anderson_memory": 5,
    "refine": False,
    "refine_budget_s": 120.0,
}
"""For every DynamicSettings field added after results were first stored: the value that reproduces the
older behaviour exactly (stored settings without the field count as this value when a campaign checks
whether it may resume). start="ramp", periodic="off" and refine=False give the original algorithm bit for
bit; anderson_memory and refine_budget_s are unused under those values, so their legacy value is their
default (a stored scene is not refused for a field that did not act)."""
