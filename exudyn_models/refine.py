"""Automatic refinement after a Newton failure (Exudyn's implicit integrators have no step control).

The ladder (rungs tried in order after the requested settings failed; a rung equal to an earlier one
after the caps is left out):

    newton x4      same discretization, 4x newton_max_iterations (the default 12 iterations run out in
                   the large-rotation steps of Case I at 300 rpm; the solution of the same discrete
                   equations, so the requested discretization is kept when it works)
    then, with 4x the Newton iterations, for mass models dominated by large rotations of a lump on
    massless links ("tip", "extender"; work-precision study: the element count matters there):
        elements x2;  elements x2 + steps x2;  elements x2 + steps x4;  elements x2 + steps x8
    and for the others ("joints", "distributed": the step matters, a higher mode near a crank
    harmonic is shifted by the integrator's period error):
        steps x2;  steps x4;  steps x8;  elements x2 + steps x8

A run that goes through but does not settle, with cycle changes that decay, gets one more rung
"cycles +N": a rerun with max_cycles raised by the cycles the measured contraction predicts (see
exudyn_models.failure.cycles_to_grant), within the same budget.

Caps: MAX_STEPS_PER_CYCLE steps per cycle and MAX_ELEMENTS_PER_LINK elements (more elements than that
never help: Newton's tolerance becomes unreachable, see failure_hint). Budget: settings.refine_budget_s
for all attempts together; before a rung its cost is estimated from the last attempt's wall time scaled
by the step and element factors, and it is skipped (recorded) if that exceeds what is left.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, replace

from .settings import DynamicSettings

MAX_STEPS_PER_CYCLE = 23040
MAX_ELEMENTS_PER_LINK = 64
MIN_WORKING_STEPS_PER_CYCLE = 64
"""Below this many steps per cycle the stability study saw Newton fail even on easy scenes (extender at
300 rpm needed 64)."""
NEWTON_FACTOR = 4

ELEMENTS_FIRST = ("tip", "extender")


@dataclass(frozen=True)
class Rung:
    """One rung: name, and factors on newton_max_iterations, steps_per_cycle, elements_per_link."""

    name: str
    newton: int = NEWTON_FACTOR
    steps: int = 1
    elements: int = 1


def ladder(mass_model: str) -> tuple[Rung, ...]:
    """The rungs after the requested settings for a mass model (module doc)."""
    first = (Rung("newton x4"),)
    if mass_model in ELEMENTS_FIRST:
        return first + (Rung("elements x2", elements=2), Rung("elements x2, steps x2", steps=2, elements=2),
                        Rung("elements x2, steps x4", steps=4, elements=2),
                        Rung("elements x2, steps x8", steps=8, elements=2))
    return first + (Rung("steps x2", steps=2), Rung("steps x4", steps=4), Rung("steps x8", steps=8),
                    Rung("elements x2, steps x8", steps=8, elements=2))


def rung_settings(base: DynamicSettings, rung: Rung) -> DynamicSettings:
    """The settings of a rung (caps applied; elements are never raised above the cap nor lowered)."""
    elements = base.elements_per_link
    if elements <= MAX_ELEMENTS_PER_LINK:
        elements = min(elements * rung.elements, MAX_ELEMENTS_PER_LINK)
    steps = min(base.steps_per_cycle * rung.steps, max(MAX_STEPS_PER_CYCLE, base.steps_per_cycle))
    return replace(base, newton_max_iterations=base.newton_max_iterations * rung.newton,
                   steps_per_cycle=steps, elements_per_link=elements)


@dataclass(frozen=True)
class Attempt:
    """One run of simulate_steady_state at fixed settings.

    rung: "requested" or the ladder rung's name; settings: the DynamicSettings used; outcome: "steady",
    "not steady" (ran through, no steady state within max_cycles), "newton failure", or "skipped"
    (budget); wall_s [s]: its wall time (0 if skipped); cycles: constant-speed cycles completed;
    message: the run's message, the exception text or why it was skipped."""

    rung: str
    settings: DynamicSettings
    outcome: str
    wall_s: float
    cycles: int
    message: str

    def text(self) -> str:
        s = self.settings
        return (f"{self.rung} ({s.elements_per_link} el, {s.steps_per_cycle} steps, {s.newton_max_iterations} "
                f"Newton it.): {self.outcome}, {self.wall_s:.1f} s")


def estimated_cost(last: Attempt, settings: DynamicSettings) -> float:
    """Wall time [s] of a run at `settings` estimated from the last attempt (steps x elements x max_cycles
    scaling; max_cycles differs only on the rung that grants a decaying transient more cycles)."""
    s0 = last.settings
    return last.wall_s * (settings.steps_per_cycle / s0.steps_per_cycle) * \
        (settings.elements_per_link / s0.elements_per_link) * (settings.max_cycles / s0.max_cycles)


def over_budget(t_start: float, budget_s: float, attempts: Sequence[Attempt], settings: DynamicSettings) -> str:
    """Why the rung is skipped ("" if it fits the budget).  The cost is the largest estimate from the
    attempts that ran: one that failed early (a Newton failure in the first cycle) says little."""
    left = budget_s - (time.perf_counter() - t_start)
    need = max((estimated_cost(a, settings) for a in attempts if a.wall_s > 0), default=0.0)
    return f"skipped: estimated {need:.1f} s > {max(left, 0.0):.1f} s left of refine_budget_s" if need > left else ""


def failure_hint(settings: DynamicSettings, step_index: int, time_s: float) -> str:
    """Likely cause and way out of a Newton failure, from the settings and where it failed."""
    n = settings.steps_per_cycle  # (elements beyond the working range are refused by DynamicSettings)
    if n < MIN_WORKING_STEPS_PER_CYCLE:
        return (f"Likely cause: steps_per_cycle = {n} is outside the range where the solver works (at least "
                f"{MIN_WORKING_STEPS_PER_CYCLE}, default 720; one step spans {360.0 / n:.3g} deg of crank "
                "rotation). Way out: steps_per_cycle >= 720, or refine=True to search automatically")
    if step_index >= 0 and step_index <= 2:
        return ("Likely cause: the first steps fail, so the settings (Newton tolerances / iterations, step "
                f"{360.0 / n:.3g} deg) do not fit this scene. Way out: default Newton settings, more steps per cycle")
    return ("Likely cause: the step or the element count is too coarse for the large, fast rotations here "
            "(Newton runs out of iterations). Way out: more steps_per_cycle or elements_per_link, or "
            "refine=True (the refinement ladder)")
