"""The quasi-static (instantaneous-structure) solver: ``ked_quasi.solve_quasi_static``."""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass
from typing import Any

from compare.solvers import COMPONENTS, STATUS_OK, STRESS, Solution, Solver, deflection_of, register, stress_of


@dataclass(frozen=True)
class QuasiStaticSettings:
    """The quasi-static solver has no settings (the scene defines it completely)."""


def settings_class() -> type:
    return QuasiStaticSettings


def make_settings(overrides: dict[str, Any], damping_ratio: float) -> QuasiStaticSettings:
    return QuasiStaticSettings(**overrides)


def run(scene: Any, settings: QuasiStaticSettings, outputs: tuple[str, ...] = COMPONENTS) -> Solution:
    """Quasi-static deflection of P on the scene grid (near-toggle warnings kept); a slider-crank scene is
    solved by its own frozen structure (ked_quasi.slider_static).  With the output ``stress``, the frozen
    structure's link stresses (ked_quasi.stress)."""
    from ked_quasi import limits
    from ked_quasi.kinds import model, quasi_static_stress

    linkage = scene.linkage
    t0 = time.perf_counter()
    stats: dict[str, Any] = {}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = model(scene).quasi_static(scene)
        wall = time.perf_counter() - t0
        stress = {}
        if STRESS in outputs:  # the frozen structure's member forces: timed apart, as the other solvers' stresses
            stress = stress_of(quasi_static_stress(scene))
            stats["stress_wall_s"] = time.perf_counter() - t0 - wall
    d = res.deflection
    flags = limits.flags(d, linkage)
    notes = sorted({str(w.message) for w in caught}) + ([limits.describe(flags, d, linkage)] if flags else [])
    return Solution(
        solver=SOLVER.name, status=STATUS_OK,
        deflection=deflection_of(d, outputs), stress=stress,
        stats={"wall_s": wall, **stats}, flags=flags, warnings="; ".join(notes),
    )


SOLVER = register(Solver(
    name="quasi_static", label="quasi-static", fidelity=0, settings_class=settings_class,
    make_settings=make_settings, run=run, physics_rtol=1e-10,
    description="instantaneous-structure flexibility method (ked_quasi): inertia loads on the frozen linkage",
))
