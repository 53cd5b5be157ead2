"""Input settings of the Exudyn flexible-multibody model (frozen, validated on construction).

Units: SI (s, Hz, rad). All fields are plain values so settings can be hashed, printed and
stored next to results.
"""

from __future__ import annotations

from dataclasses import dataclass

from ked_quasi import rules

ELEMENT_TYPES = ("ancf", "gebeam")
STARTS = ("ramp", "quasi_static", "linear")
PERIODIC_METHODS = ("off", "anderson")

RULES: dict[str, rules.Rule | rules.Choice | rules.Flag] = {
    "element": rules.Choice("element", ELEMENT_TYPES),
    "elements_per_link": rules.Rule("elements_per_link", "per link", 1, 64, "beyond 64 very short, stiff elements "
                                    "make Newton's tolerance unreachable (the refinement ladder's cap); 4 (default) "
                                    "to 16 work well",
                                    integer=True),
    "steps_per_cycle": rules.Rule("steps_per_cycle", "per cycle", 8, 1_000_000, "at least 8 steps per crank "
                                  "revolution, at most a million", integer=True),
    "spectral_radius": rules.Rule("spectral_radius", "", 0.0, 1.0, "the generalized-alpha spectral radius"),
    "damping_ratio": rules.DAMPING_RATIO,
    "damping_reference_hz": rules.DAMPING_REFERENCE_HZ,
    "ramp_cycles": rules.Rule("ramp_cycles", "cycles", 0.0, 1000.0, "a start-up ramp of crank revolutions",
                              lo_open=True),
    "steady_tol": rules.Rule("steady_tol", "", 0.0, 1.0, "a fraction of the peak", lo_open=True),
    "min_cycles": rules.Rule("min_cycles", "cycles", 1, 10_000, "crank revolutions at constant speed",
                             integer=True),
    "max_cycles": rules.Rule("max_cycles", "cycles", 1, 10_000, "crank revolutions at constant speed",
                             integer=True),
    "extrapolate": rules.Flag("extrapolate"),
    "newton_abs_tol": rules.Rule("newton_abs_tol", "N", 0.0, 1e6, "a residual force", lo_open=True),
    "newton_rel_tol": rules.Rule("newton_rel_tol", "", 0.0, 1.0, "a relative residual", lo_open=True),
    "newton_max_iterations": rules.Rule("newton_max_iterations", "", 1, 10_000, "Newton iterations per step (the "
                                        "refinement ladder quadruples them)", integer=True),
    "sparse": rules.Flag("sparse"),
    "start": rules.Choice("start", STARTS),
    "periodic": rules.Choice("periodic", PERIODIC_METHODS),
    "anderson_memory": rules.Rule("anderson_memory", "cycles", 1, 20, "previous cycles of the Anderson mixing",
                                  integer=True),
    "refine": rules.Flag("refine"),
    "refine_budget_s": rules.Rule("refine_budget_s", "s", 0.0, 1e6, "a wall-time budget", lo_open=True),
}
"""The allowed values of every :class:`DynamicSettings` field: the class and the campaign config's
``[dynamic]`` table check each value with the same rule."""


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
        rate; ramp_cycles is then unused; "linear": as "quasi_static", with the static solves under the loads of
        the whole motion of the linear model's periodic steady state (its elastic accelerations too), so the
        start lies on that orbit; where the linear answer is unavailable, not stable or outside its range (its
        flags) the run starts from the ramp and its start note says why, as does the slider-crank model, which
        has no linear start. See exudyn_models.start.
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
    damping_ratio: float = rules.DEFAULT_DAMPING_RATIO
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
        rules.check_fields(self, RULES)
        if self.min_cycles > self.max_cycles:
            raise ValueError(f"DynamicSettings.min_cycles ({self.min_cycles}) must not exceed max_cycles "
                             f"({self.max_cycles})")


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
