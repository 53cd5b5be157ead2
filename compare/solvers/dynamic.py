"""The nonlinear dynamic reference: Exudyn flexible multibody model to periodic steady state."""

from __future__ import annotations

from typing import Any

import numpy as np

from compare.solvers import (
    COMPONENTS,
    STATUS_FAILED,
    STATUS_OK,
    STRESS,
    Solution,
    Solver,
    deflection_of,
    register,
    stress_of,
)


def settings_class() -> type:
    from exudyn_models.settings import DynamicSettings

    return DynamicSettings


def setting_rules() -> dict[str, Any]:
    from exudyn_models.settings import RULES

    return RULES


def make_settings(overrides: dict[str, Any], damping_ratio: float) -> Any:
    """``DynamicSettings`` from the explicit overrides (the scene's damping ratio included in them)."""
    return settings_class()(**overrides)


def legacy_defaults() -> dict[str, Any]:
    """Settings added after results were first stored, as the values that reproduce the older runs.

    ``refine`` and ``refine_budget_s`` only act after a Newton failure or a run without a steady state
    (the ladder never changes a run that settles at the requested settings), so a stored solution counts
    as computed with today's values of them: resuming keeps it; ``ked run --retry-failed`` recomputes the
    failed ones."""
    from exudyn_models.settings import LEGACY_DEFAULTS, DynamicSettings

    now = DynamicSettings()
    return {**LEGACY_DEFAULTS, "refine": now.refine, "refine_budget_s": now.refine_budget_s}


def attempts_text(attempts: tuple[Any, ...]) -> str:
    """The refinement ladder's attempts, one ``; ``-joined line (stored with the solution)."""
    return "; ".join(a.text() for a in attempts)[:2000]


def _stats(res: Any) -> dict[str, Any]:
    solved = res.solved_settings or res.settings
    return {"wall_s": float(res.wall_s - res.stress_wall_s), "steps": int(res.steps),
            "newton_iterations": int(res.newton_iterations),
            "cycles": int(res.cycles), "converged": bool(res.converged), "dynamic_message": str(res.message)[:2000],
            "damping_reference_hz": float(res.damping_reference_hz), "start": str(res.start),
            "attempts": attempts_text(res.attempts), "n_attempts": len(res.attempts),
            "solved_elements_per_link": int(solved.elements_per_link),
            "solved_steps_per_cycle": int(solved.steps_per_cycle),
            "solved_newton_max_iterations": int(solved.newton_max_iterations),
            "evidence": str(res.evidence)[:2000],
            **({"stress_wall_s": float(res.stress_wall_s)} if res.stress is not None else {})}


def run(scene: Any, settings: Any, outputs: tuple[str, ...] = COMPONENTS) -> Solution:
    """Exudyn steady state of the scene (with the validity flags of ``ked_quasi.limits`` where its
    history leaves the small-deflection range); a run without a periodic steady state is a failed solution
    that keeps its last cycle, classified (numerical / physical / undecided) with its evidence.  The stats say
    which settings produced the history (``solved_*``) and every attempt of the refinement ladder.  With the
    output ``stress``, the beam elements' section forces over one more steady cycle (exudyn_models.stress_cycle)."""
    from exudyn_models.simulate import simulate_steady_state

    res = simulate_steady_state(scene, settings, stress=STRESS in outputs)
    if not np.allclose(np.asarray(res.crank_angle, dtype=float), scene.crank_angles, rtol=0.0, atol=1e-9):
        raise ValueError("dynamic result is not on the scene's crank-angle grid")
    stats = _stats(res)
    d = np.asarray(res.deflection, dtype=float)
    deflection = deflection_of(d, outputs)
    stress = stress_of(res.stress) if res.stress is not None else {}
    if res.converged:  # an answer beyond the small-deflection range carries its flags (not a valid reference)
        return Solution(SOLVER.name, STATUS_OK, deflection, stats=stats, flags=tuple(res.flags),
                        warnings=res.validity, stress=stress)
    evidence = f" ({res.evidence})" if res.evidence else ""
    return Solution(SOLVER.name, STATUS_FAILED, deflection, stats=stats, error_type="NoSteadyState",
                    failure_class=res.failure_class or "numerical",
                    message=f"no periodic steady state: {res.message}{evidence}"[:2000])


SOLVER = register(Solver(
    name="dynamic", label="dynamic (Exudyn)", fidelity=10, settings_class=settings_class,
    make_settings=make_settings, run=run, legacy_defaults=legacy_defaults, setting_rules=setting_rules,
    description="Exudyn flexible multibody model (ANCF or geometrically exact beams), periodic steady state",
))


def settings_for(spec: Any) -> Any:
    """The ``DynamicSettings`` a campaign scene (``compare.scenes.SceneSpec``) runs with."""
    return make_settings(spec.settings_for(SOLVER.name), spec.damping_ratio)
