"""The harness's tiers against Simeon's reference model: the rod's midspan deflection per crank speed.

For each crank speed Omega the reference (:func:`ked_bench.simeon.steady_state`: the published model with
its damping matrix, marched from a rigid start to its periodic steady state) gives q1(theta), the rod's
lateral midspan deflection relative to its chord over one crank cycle.  The harness's tiers give the same
quantity on the same crank angles for the preset ``--linkage simeon`` (``ked_quasi.simeon_slider_crank``,
the rod's mass in midpoint lumps, :data:`QS_LUMPS` and :data:`LUMPS`, the slider mass at B):

* quasi-static: ``ked_quasi.slider_static.solve_slider_quasi_static(...).midspan``;
* linear KED: ``ked_linear.solve_linear(...).midspan`` with the reference's damping, the first-mode ratio
  of the published damping matrix, DQ11 / (2 sqrt(KQ11 MQ11)) = 2.59 %, set at the rod's first bending
  frequency (stiffness-proportional damping: higher modes get proportionally more), and without prestress:
  the reference model (linear stiffness) has no geometric stiffness, so this is the like-for-like
  comparison; the harness's default linear tier (prestress on) is compared too, and the difference is the
  geometric stiffening of the rod by its axial inertia load, a model difference of size ~ r^2;
* dynamic (Exudyn): :func:`exudyn_midspan` (``ked_bench.exudyn_tier.slider_midspan_history``).

The reference's default (linear stiffness) lacks the rod's geometric stiffening by its axial force, which
the harness's Exudyn beams (geometrically nonlinear) and prestressed linear tier contain; optionally the
tiers are also compared with the reference with geometric stiffness (``steady_state(omega,
stiffness="geometric")``): the like-for-like comparison for those two.

Each error is the history error of ``compare.metrics`` (max |a - ref| / max |ref| over the cycle).  SI units.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .simeon import SimeonParameters, SteadyState, rod_matrices, simeon_scene, steady_state

SPEEDS = tuple(float(w) for w in range(25, 325, 25))
"""The crank speeds of the benchmark sweep [rad/s]: 25, 50, ..., 300."""

LUMPS = 16
"""Midpoint lumps of the rod's mass in the linear tier of the benchmark (its cost grows as the cube of the
coordinates; the lumping error at 16 lumps is ~0.15 % of the peak, docs/linear_model.md)."""

QS_LUMPS = 128
"""Midpoint lumps of the rod's mass in the quasi-static tier of the benchmark (cheap: converged, so that its
error is the dynamic part it misses plus the reference's two-mode difference)."""


def reference_damping_ratio() -> float:
    """The first bending mode's damping ratio of the published damping matrix, DQ11 / (2 sqrt(KQ11 MQ11))."""
    rod = rod_matrices(SimeonParameters(damped=True))
    return float(rod.dq[0, 0] / (2.0 * math.sqrt(rod.kq[0, 0] * rod.mq[0, 0])))


def reference_first_bending_hz() -> float:
    """The reference rod's first bending frequency [Hz], sqrt(KQ11 / MQ11) / (2 pi)."""
    rod = rod_matrices(SimeonParameters())
    return math.sqrt(rod.kq[0, 0] / rod.mq[0, 0]) / (2.0 * math.pi)


def linear_settings(prestress: bool = False):
    """The linear tier's settings of the benchmark: the reference's first-mode damping ratio at its first
    bending frequency; ``prestress`` off like the reference (no geometric stiffness), or on (the harness's
    default)."""
    from ked_linear import LinearSettings

    return LinearSettings(damping_ratio=reference_damping_ratio(), damping_reference_hz=reference_first_bending_hz(),
                          prestress=prestress)


def quasi_static_midspan(omega: float, samples: int = 72, lumps: int = QS_LUMPS) -> np.ndarray:
    """The quasi-static tier's midspan deflection [m] at ``samples`` crank angles from 0."""
    from ked_quasi.slider_static import solve_slider_quasi_static

    return solve_slider_quasi_static(simeon_scene(omega, 360.0 / samples, lumps)).midspan


def linear_midspan(omega: float, samples: int = 72, lumps: int = LUMPS, prestress: bool = False):
    """The linear tier's result (``ked_linear.slider.SliderLinearResult``: ``midspan`` [m], stability)."""
    from ked_linear import solve_linear

    return solve_linear(simeon_scene(omega, 360.0 / samples, lumps), linear_settings(prestress))


def exudyn_midspan(omega: float, samples: int = 72) -> np.ndarray:
    """The Exudyn tier's steady-state midspan deflection [m] of the benchmark's slider-crank at crank speed
    ``omega`` [rad/s] on ``samples`` crank angles from 0 (``ked_bench.exudyn_tier.slider_midspan_history``: 6 ANCF
    elements on the rod, 1080 steps per cycle, damping as :func:`linear_settings`; the sign of the
    reference's q1, the CCW normal of the rod's chord).

    Raises ``exudyn_models.SimulationError`` when no run goes through, RuntimeError when the run did not
    settle to a periodic steady state (no answer: the benchmark reports ``dynamic_error`` null)."""
    from ked_bench.exudyn_tier import slider_midspan_history

    _, midspan, res = slider_midspan_history(omega, step_deg=360.0 / samples)
    if not res.converged:
        raise RuntimeError(f"the Exudyn model did not settle to a periodic steady state at {omega:g} rad/s")
    if midspan.shape != (samples,):
        raise RuntimeError(f"the Exudyn model gave {midspan.size} crank angles, expected {samples}")
    return midspan


@dataclass(frozen=True)
class SpeedComparison:
    """One crank speed of the benchmark.  omega_rad_s; speed_ratio: Omega over the reference rod's first
    bending frequency; reference_peak_m: max |q1| of the reference [m]; quasi_static_error, linear_error,
    dynamic_error: history errors of the tiers' midspan deflection against the reference (None: no
    answer; the reason in ``notes``), the linear tier without prestress like the reference;
    linear_prestressed_error: the linear tier with the harness's default prestress (geometric stiffness of
    the axial inertia loads, which the reference model lacks); linear_status: the linear tier's Floquet
    verdict (without prestress); reference_geometric_peak_m, dynamic_error_geometric,
    linear_prestressed_error_geometric: the same against the reference with geometric stiffness
    (``stiffness="geometric"`` of ``ked_bench.simeon``, the like-for-like model of the harness's
    geometrically nonlinear beams and prestressed linear tier; None: not marched)."""

    omega_rad_s: float
    speed_ratio: float
    reference_peak_m: float
    quasi_static_error: float
    linear_error: float | None
    linear_prestressed_error: float | None
    dynamic_error: float | None
    linear_status: str
    notes: tuple[str, ...]
    reference_geometric_peak_m: float | None = None
    dynamic_error_geometric: float | None = None
    linear_prestressed_error_geometric: float | None = None

    def to_dict(self) -> dict[str, object]:
        return {"omega_rad_s": self.omega_rad_s, "speed_ratio": self.speed_ratio,
                "quasi_static_error": self.quasi_static_error, "linear_error": self.linear_error,
                "dynamic_error": self.dynamic_error, "linear_prestressed_error": self.linear_prestressed_error,
                "reference_peak_m": self.reference_peak_m, "linear_status": self.linear_status,
                "dynamic_error_geometric": self.dynamic_error_geometric,
                "linear_prestressed_error_geometric": self.linear_prestressed_error_geometric,
                "reference_geometric_peak_m": self.reference_geometric_peak_m, "notes": list(self.notes)}


def compare_speed(omega: float, reference: SteadyState | None = None, lumps: int = LUMPS,
                  dynamic: bool = True, geometric: SteadyState | None = None) -> SpeedComparison:
    """The tiers against the reference at crank speed ``omega`` [rad/s] (``reference``: its steady state if
    already marched; ``dynamic``: also run the Exudyn tier, else ``dynamic_error`` is None; ``geometric``:
    the reference's steady state with geometric stiffness, to compare the prestressed linear and the Exudyn
    tiers with it too)."""
    from compare.metrics import history_error

    ref = steady_state(omega) if reference is None else reference
    n = ref.crank_angle.size
    if geometric is not None and geometric.crank_angle.size != n:
        raise ValueError(f"geometric: the reference with geometric stiffness has {geometric.crank_angle.size} "
                         f"crank angles, the reference {n}; march both on the same grid")
    notes: list[str] = []
    qs = history_error(quasi_static_midspan(omega, n), ref.midspan)
    lin_errors, status, lin_geo = [], "ok", None
    for prestress in (False, True):
        res = linear_midspan(omega, n, lumps, prestress)
        if not prestress:
            status = res.status
        lin_errors.append(history_error(res.midspan, ref.midspan) if res.stable else None)
        if prestress and res.stable and geometric is not None:
            lin_geo = history_error(res.midspan, geometric.midspan)
        if not res.stable:
            notes.append(f"linear{' (prestressed)' if prestress else ''}: {res.message}")
    dyn: float | None = None
    dyn_geo: float | None = None
    if dynamic:
        try:
            exu = exudyn_midspan(omega, n)
            dyn = history_error(exu, ref.midspan)
            dyn_geo = None if geometric is None else history_error(exu, geometric.midspan)
        except RuntimeError as exc:  # SimulationError is one: no answer, the reason in the notes
            notes.append(f"dynamic: {exc}")
    else:
        notes.append("dynamic: not run")
    return SpeedComparison(omega_rad_s=float(omega), speed_ratio=abs(omega) / (2.0 * math.pi *
                                                                             reference_first_bending_hz()),
                           reference_peak_m=ref.peak, quasi_static_error=qs, linear_error=lin_errors[0],
                           linear_prestressed_error=lin_errors[1], dynamic_error=dyn, linear_status=status,
                           notes=tuple(notes),
                           reference_geometric_peak_m=None if geometric is None else geometric.peak,
                           dynamic_error_geometric=dyn_geo, linear_prestressed_error_geometric=lin_geo)


__all__ = ["LUMPS", "QS_LUMPS", "SPEEDS", "SpeedComparison", "compare_speed", "exudyn_midspan", "linear_midspan",
           "linear_settings", "quasi_static_midspan", "reference_damping_ratio", "reference_first_bending_hz"]
