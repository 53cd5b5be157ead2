"""ked_linear: the linear time-periodic kineto-elastodynamic (KED) model of a planar four-bar.

The third solver of the harness, between the quasi-static ``ked_quasi`` and the nonlinear Exudyn model:
the lumped masses move on the frozen (instantaneous) structure of each crank angle,

    M u'' + C(theta) u' + K(theta) u = -M a_rigid(theta),   theta = theta0 + s Omega t,

u the absolute elastic displacements of the masses, K the frozen structure condensed on them (plus
the geometric stiffness of the quasi-static axial forces), C = beta K_E.  Its periodic steady state is
solved directly (Fourier collocation), its stability from the Floquet multipliers.  Pure numerics on
a ``ked_quasi.Scene``; derivation in docs/linear_model.md.  SI units.
"""

from .floquet import FloquetResult, floquet, monodromy, multipliers
from .kinds import linkage_system
from .linkage import LinkageSystem, frozen_frequencies
from .periodic import Coefficients, PeriodicSolution, PeriodicSystem, SteadyState, solve_periodic, steady_state
from .settings import LinearSettings
from .solver import UNRESOLVED_ESTIMATE, LinearResult, describe_flags, forget_recalled, result_flags, solve_linear

__all__ = [
    "UNRESOLVED_ESTIMATE", "Coefficients", "FloquetResult",
    "LinearResult", "LinearSettings", "LinkageSystem", "PeriodicSolution",
    "PeriodicSystem", "SteadyState", "floquet", "frozen_frequencies", "linkage_system", "monodromy",
    "multipliers", "describe_flags", "forget_recalled", "result_flags", "solve_linear", "solve_periodic",
    "steady_state",
]
