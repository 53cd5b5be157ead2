"""Settings of the linear time-periodic KED model (frozen, validated, plain values: hashable and JSON-able)."""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

from ked_quasi import rules

HARMONICS = rules.Rule("harmonics", "", 1, 64, "crank harmonics with dynamic response; the dense solve grows "
                       "as (harmonics x coordinates)^3", integer=True)
TOLERANCE = rules.Rule("tolerance", "", 1e-12, 0.1, "relative error of the history (a fraction of its peak)")
FLOQUET_STEPS = rules.Rule("floquet_steps", "per cycle", 8, 65536, "time steps of the monodromy propagator",
                           integer=True)
DYNAMIC_LUMPS = rules.Rule("dynamic_lumps", "per link", 1, 256, "lumps per distributed link carrying the inertia "
                           "of the elastic motion (at most the scene's own)", integer=True)
FLOQUET_TOLERANCE = rules.Rule("floquet_tolerance", "", 1e-12, 0.5, "absolute error of the largest |multiplier|")

RULES: dict[str, rules.Rule | rules.Choice | rules.Flag] = {
    "damping_ratio": rules.DAMPING_RATIO, "damping_reference_hz": rules.DAMPING_REFERENCE_HZ,
    "prestress": rules.Flag("prestress"), "harmonics": HARMONICS, "max_harmonics": HARMONICS,
    "tolerance": TOLERANCE, "dynamic_lumps": DYNAMIC_LUMPS, "floquet_steps": FLOQUET_STEPS,
    "floquet_tolerance": FLOQUET_TOLERANCE,
}
"""The allowed values of every :class:`LinearSettings` field: the class and the campaign config's
``[linear]`` table check each value with the same rule."""


@dataclass(frozen=True)
class LinearSettings:
    """Damping, prestress and resolution of one linear KED solve.

    damping_ratio: modal damping ratio zeta at ``damping_reference_hz`` (0 <= zeta <= 0.99), applied as
        stiffness-proportional damping C = beta K_E, beta = 2 zeta / (2 pi f_ref) [s]
        (:mod:`ked_quasi.damping`, the Exudyn model's definition).
    damping_reference_hz: f_ref [Hz]; None -> the first natural frequency of the frozen structure
        averaged over the scene's grid (:func:`ked_quasi.damping.damping_reference_hz`).
    prestress: add the geometric stiffness of the links' axial forces under the quasi-static inertia
        loads at the scene's speed (False: the classical linear KED model).
    harmonics: crank harmonics H given a dynamic response in the periodic solve; None -> automatic
        (4, 8, 16, ... up to ``max_harmonics`` until the estimated error is below ``tolerance``).
    max_harmonics: largest H tried by the automatic choice.
    tolerance: target relative error of the coupler-point history (fraction of its peak).
    floquet_steps: time steps per crank cycle of the monodromy propagator of the full model; None ->
        automatic (64, 128, ... until the change of max |multiplier| is below ``floquet_tolerance``; damped
        extender and distributed models then try the reduced system first, ``ked_linear.reduction``).
    floquet_tolerance: target absolute error of max |multiplier|.
    dynamic_lumps: lumps per distributed link of the model that carries the inertia of the elastic motion
        (dynamic response, Floquet multipliers, frozen frequencies) when the scene has more; the answer is
        that model's plus the static correction, the quasi-static answer on the scene's own lumps minus that on
        ``dynamic_lumps`` (mode-acceleration style: the dynamic part converges in the lumps much faster than
        the quasi-static part, docs/linear_model.md).  None: the scene's own lumps throughout.
    """

    damping_ratio: float = rules.DEFAULT_DAMPING_RATIO
    damping_reference_hz: float | None = None
    prestress: bool = True
    harmonics: int | None = None
    max_harmonics: int = 32
    tolerance: float = 1e-3
    floquet_steps: int | None = None
    floquet_tolerance: float = 1e-3
    dynamic_lumps: int | None = 10

    def __post_init__(self) -> None:
        rules.check_fields(self, RULES)

    def to_dict(self) -> dict[str, Any]:
        """Plain dict (JSON, HDF5 attributes); ``LinearSettings(**d)`` inverts it."""
        return asdict(self)

