"""A small real solver for the registry tests: the quasi-static solution of the linkage made stiffer by a
factor (every Young's modulus times ``factor``).  Defined at module level of an importable module, as
the registry requires (solvers travel to workers by reference); registered only by the tests that use it.

Expected values: the flexibility method is linear in the compliance, so its deflection is exactly the
quasi-static one divided by ``factor`` (to round-off), and it meets the shared physics checks as the
quasi-static solver does.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

from compare.solvers import COMPONENTS, Solution, Solver
from compare.solvers import quasi_static as qs_solver
from ked_quasi import rules

FACTOR = rules.Rule("factor", "", 0.0, 1e3, "a factor on every Young's modulus", lo_open=True)
RULES = {"factor": FACTOR}


@dataclass(frozen=True)
class StiffSettings:
    """Settings of the test solver: ``factor`` [1] on every Young's modulus."""

    factor: float = 4.0

    def __post_init__(self) -> None:
        rules.check_fields(self, RULES)


def settings_class() -> type:
    return StiffSettings


def setting_rules() -> dict[str, Any]:
    return RULES


def make_settings(overrides: dict[str, Any], damping_ratio: float) -> StiffSettings:
    return StiffSettings(**overrides)


def run(scene: Any, settings: StiffSettings, outputs: tuple[str, ...] = COMPONENTS) -> Solution:
    stiff = replace(scene, fourbar=scene.fourbar.with_stiffness_scale(settings.factor))
    return replace(qs_solver.run(stiff, qs_solver.QuasiStaticSettings(), outputs), solver=STIFF.name)


STIFF = Solver(name="stiff_quasi_static", label="quasi-static, stiffer", fidelity=1, settings_class=settings_class,
               make_settings=make_settings, run=run, setting_rules=setting_rules, physics_rtol=1e-10,
               description="the quasi-static solution of the linkage with every Young's modulus times a factor")
