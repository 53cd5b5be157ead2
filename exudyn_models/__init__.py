"""Exudyn flexible-multibody models of the four-bar (issue 4).

Every link is an elastic beam (ANCF cable by default), the crank is driven at constant speed after a
smooth start-up ramp, and the coupler-point deflection is returned over one periodic steady cycle,
on the same scene definition and kinematics as ked_quasi.
"""

from .builder import BuiltModel, build_model
from .damping import rayleigh_beta, reference_frequency
from .modal import frozen_natural_frequencies
from .settings import ELEMENT_TYPES, DynamicSettings
from .simulate import DynamicResult, SimulationError, simulate_steady_state

__all__ = [
    "ELEMENT_TYPES",
    "BuiltModel",
    "DynamicResult",
    "DynamicSettings",
    "SimulationError",
    "build_model",
    "frozen_natural_frequencies",
    "rayleigh_beta",
    "reference_frequency",
    "simulate_steady_state",
]
