"""Exudyn flexible-multibody models of the four-bar and the slider-crank.

Every link is an elastic beam (ANCF cable by default), the crank is driven at constant speed (from the
quasi-static state, or after a smooth start-up ramp), and the coupler-point deflection is returned over
one periodic steady cycle (solved directly or marched to), on the same scene definition and kinematics
as ked_quasi. Newton failures are retried along a refinement ladder; failures are classified. A
slider-crank scene (ked_quasi.slidercrank.SliderScene) runs its own model (slider_builder, slider_simulate)
through the same machinery (Simeon's benchmark mechanism in the Exudyn tier: ked_bench.exudyn_tier).
"""

from .builder import BuiltModel, build_model
from .damping import rayleigh_beta, reference_frequency
from .errors import FAILURE_CLASSES, SimulationError
from .modal import frozen_natural_frequencies
from .refine import Attempt
from .settings import ELEMENT_TYPES, LEGACY_DEFAULTS, PERIODIC_METHODS, STARTS, DynamicSettings
from .simulate import DynamicResult, simulate_steady_state

__all__ = [
    "ELEMENT_TYPES",
    "FAILURE_CLASSES",
    "LEGACY_DEFAULTS",
    "PERIODIC_METHODS",
    "STARTS",
    "Attempt",
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
