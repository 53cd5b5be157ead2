"""The quasi-static (instantaneous-structure) solver: ``ked_quasi.solve_quasi_static``."""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass
from typing import Any

from compare.solvers import COMPONENTS, STATUS_OK, Solution, Solver, register


@dataclass(frozen=True)
class QuasiStaticSettings:
    """The quasi-static solver has no settings (the scene defines it completely)."""


def settings_class() -> type:
    return QuasiStaticSettings


def make_settings(overrides: dict[str, Any], damping_ratio: float) -> QuasiStaticSettings:
    return QuasiStaticSettings(**overrides)


def run(scene: Any, settings: QuasiStaticSettings, outputs: tuple[str, ...] = COMPONENTS) -> Solution:
    """Quasi-static deflection of P on the scene grid (near-toggle warnings kept)."""
    from ked_quasi import limits
    from ked_quasi.solver import solve_quasi_static

    t0 = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        res = solve_quasi_static(scene)
    wall = time.perf_counter() - t0
    d = res.deflection
    flags = limits.flags(d, scene.fourbar)
    notes = sorted({str(w.message) for w in caught}) + ([limits.describe(flags, d, scene.fourbar)] if flags else [])
    return Solution(
        solver=SOLVER.name, status=STATUS_OK,
        deflection={c: d[:, COMPONENTS.index(c)].copy() for c in outputs},
        stats={"wall_s": wall}, flags=flags, warnings="; ".join(notes),
    )


SOLVER = register(Solver(
    name="quasi_static", label="quasi-static", fidelity=0, settings_class=settings_class,
    make_settings=make_settings, run=run, physics_rtol=1e-10,
    description="instantaneous-structure flexibility method (ked_quasi): inertia loads on the frozen linkage",
))
