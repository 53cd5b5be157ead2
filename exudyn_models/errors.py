"""The exception of a failed time integration, with where it failed and why (class and evidence)."""

from __future__ import annotations

import math

FAILURE_CLASSES = ("numerical", "physical", "undecided")
"""numerical: the method gave up (Newton failures on every rung of the refinement ladder within the
budget, cycle changes stalled at the noise floor, or a decay confirmed by the cycles the ladder granted
that needs still more); physical: the evidence says the linkage has no (attracting) periodic orbit: the
response grows without bound, does not repeat from cycle to cycle (quasi-periodic / subharmonic), or did
not settle within the cycles its measured contraction predicted; undecided: neither is shown (the
numbers are in the evidence). See exudyn_models.failure."""


def crank_angle_deg_text(crank_angle: float) -> str:
    """Crank angle [rad] as degrees in [0, 360) with 3 decimals (never "360.000")."""
    deg = round(math.degrees(crank_angle) % 360.0, 3)
    return f"{0.0 if deg >= 360.0 else deg:.3f}"


class SimulationError(RuntimeError):
    """The time integration failed. `.time` [s] and `.crank_angle` [rad, in [0, 2 pi)] say where;
    `.failure_class` ("numerical" or "physical"), `.evidence` (text) and `.attempts` (the refinement
    ladder's Attempt records, if it ran) say why and what was tried; `.cycles` constant-speed cycles
    were completed and `.peaks` [m] are their peak |d| (growth evidence)."""

    def __init__(self, message: str, time: float, crank_angle: float, *, failure_class: str = "numerical",
                 evidence: str = "", attempts: tuple = (), cycles: int = 0, peaks: tuple[float, ...] = (),
                 step_index: int = -1, detail: str = ""):
        where = f"{message} at t = {time:.6g} s, crank angle = {crank_angle_deg_text(crank_angle)} deg"
        super().__init__(where + (f". {detail}" if detail else ""))
        self.reason = message
        self.detail = detail
        self.time = time
        self.crank_angle = crank_angle
        self.failure_class = failure_class
        self.evidence = evidence
        self.attempts = tuple(attempts)
        self.cycles = cycles
        self.peaks = tuple(peaks)
        self.step_index = step_index

    def with_context(self, *, detail: str | None = None, failure_class: str | None = None,
                     evidence: str | None = None, attempts: tuple | None = None) -> SimulationError:
        """A copy with a detail text (cause, way out, what was tried) and/or classification."""
        out = SimulationError(self.reason, self.time, self.crank_angle,
                              failure_class=self.failure_class if failure_class is None else failure_class,
                              evidence=self.evidence if evidence is None else evidence,
                              attempts=self.attempts if attempts is None else attempts, cycles=self.cycles,
                              peaks=self.peaks, step_index=self.step_index,
                              detail=self.detail if detail is None else detail)
        return out
