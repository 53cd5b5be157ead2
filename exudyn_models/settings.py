"""Input settings of the Exudyn flexible-multibody model (frozen, validated on construction).

Units: SI (s, Hz, rad). All fields are plain values so settings can be hashed, printed and
stored next to results.
"""

from __future__ import annotations

from dataclasses import dataclass

ELEMENT_TYPES = ("ancf", "gebeam")


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
    newton_abs_tol [N], newton_rel_tol: Newton tolerances of Exudyn's residual (forces). Exudyn's
        1e-10 default fails on round-off; the absolute tolerance is raised to 1e-13 * E*A for
        very stiff links (exudyn_models.simulate.newton_abs_tolerance).
    newton_max_iterations: Newton iterations per step before the step counts as failed.
    sparse: use Exudyn's sparse (Eigen) linear solver instead of the dense one.
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

    def __post_init__(self) -> None:
        if self.element not in ELEMENT_TYPES:
            raise ValueError(f"element must be one of {ELEMENT_TYPES}, got {self.element!r}")
        for name in ("elements_per_link", "steps_per_cycle", "min_cycles", "max_cycles",
                     "newton_max_iterations"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value <= 0:
                raise ValueError(f"{name} must be a positive integer, got {value!r}")
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
