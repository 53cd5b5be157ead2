"""ked_quasi: quasi-static kineto-elastodynamic (KED) analysis of planar four-bars.

The thesis's instantaneous-structure flexibility method (Ali 1977), corrected and general: any
four-bar and its Roberts cognates, any set of lumped masses, vectorized over crank angles.  SI units.
"""

from .cognates import Cognate, mechanism, roberts_cognates
from .kinematics import Kinematics, coupler_point, joint_positions, kinematics
from .linkage import LINKS, THESIS_RPM, THESIS_TIP_MASS_KG, FourBar, Section, thesis_fourbar
from .massmodel import MASS_MODELS, MassModel, lumps
from .scene import Scene
from .slider_static import SliderQuasiStaticResult, slider_natural_frequencies, solve_slider_quasi_static
from .slidercrank import SliderCrank, SliderScene, simeon_slider_crank, slider_kinematics
from .solver import QuasiStaticResult, ToggleWarning, natural_frequencies, solve_quasi_static

__version__ = "0.1.0"

__all__ = [
    "Cognate", "FourBar", "Kinematics", "LINKS", "MASS_MODELS", "MassModel", "QuasiStaticResult",
    "Scene", "Section", "THESIS_RPM", "THESIS_TIP_MASS_KG", "ToggleWarning", "coupler_point",
    "joint_positions", "kinematics", "lumps", "mechanism", "natural_frequencies", "roberts_cognates",
    "solve_quasi_static", "thesis_fourbar",
    "SliderCrank", "SliderQuasiStaticResult", "SliderScene", "simeon_slider_crank", "slider_kinematics",
    "slider_natural_frequencies", "solve_slider_quasi_static",
]
