"""Tolerances of a regression comparison (``ked diff``, the pytest plugin): data, per tier, solver and quantity.

Two tiers.  ``same``: the scene was computed with the same settings and the same versions of the harness and of
Exudyn; the answers must agree to round-off (the solvers are deterministic: a rerun reproduces every stored
number, so a drift beyond round-off is a change of the code or of the machine's arithmetic).  ``physics``: the
settings or a version differ; the answers must agree within the reference's own stated uncertainty.

Quantities, per solver:

- ``history`` [1]: max_k |new_k - base_k| / max_k |base_k| of each stored history (dx, dy, rotation);
- ``history_abs`` [m or rad, the component's unit]: the absolute floor of that drift: a history passes when
  max |new - base| <= max(history * baseline peak, history_abs) (a near-zero history is judged by the floor);
- ``verdict_error`` [1]: |new - base| of the solver's verdict error (history error of the deflection vector
  against the scene's reference solver), in points of the error (0.01 = one percentage point).

Where each default comes from (:data:`DEFAULTS`):

- ``same``, every solver: 1e-9 relative and 1e-15 m|rad: round-off of double precision (1e-16) grown by the
  solvers' condition numbers (the quasi-static frame is checked against an independent stiffness model to 1e-9,
  ``ked_quasi.stiffness``); ``dynamic`` 1e-6: Exudyn's Newton iterations stop at a relative residual of
  ``newton_rel_tol`` (1e-6 or tighter, docs/exudyn_models.md), so two machines may stop an iteration apart.
  A rerun on one machine reproduces every stored number bit for bit; a change of the code that moves Exudyn's
  iterations moves the answer within the model's own tolerances (measured: 0.031 % of the peak for one of the 12
  scenes of ``results/reference``, whose config therefore allows its ``steady_tol``, 0.2 %).
- ``physics``, ``dynamic``: 0.0112 = 2 x 0.56 %: every scene of the default campaign is within 0.56 % of a fine
  run (8 elements, 5760 steps; docs/exudyn_models.md), so two admissible settings differ by at most twice that;
  the verdict error against it moves by the same amount (0.0112 points).
- ``physics``, ``linear``: 0.02: the linear model calls an answer unresolved when its error estimate is above
  2 % of the peak (docs/linear_model.md, "Resolution and error estimate"); its verdict error moves by that plus
  the reference's 0.0112 (0.0312).
- ``physics``, ``quasi_static``: 1e-6: closed-form statics, exact to its frame check (1e-9): no Exudyn or
  linear-model setting moves it; its verdict error moves with the reference's (0.0112).  Histories on different
  crank-angle grids (another ``step_deg``) are not compared point by point: only their verdict errors are.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

TIERS = ("same", "physics")
QUANTITIES = ("history", "history_abs", "verdict_error")
ANY_SOLVER = "default"
"""The solver entry used for a solver without its own (a solver registered by a user)."""


@dataclass(frozen=True)
class Bounds:
    """The bounds of one solver in one tier: ``history`` [1], ``history_abs`` [m|rad], ``verdict_error`` [1]."""

    history: float
    history_abs: float
    verdict_error: float

    def __post_init__(self) -> None:
        for name in QUANTITIES:
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0:
                raise ValueError(f"{name}: must be a finite number >= 0, got {v!r}")

    def to_dict(self) -> dict[str, float]:
        return {q: float(getattr(self, q)) for q in QUANTITIES}


_ROUND_OFF = Bounds(history=1e-9, history_abs=1e-15, verdict_error=1e-9)
DEFAULTS: dict[str, dict[str, Bounds]] = {
    "same": {"quasi_static": _ROUND_OFF, "linear": _ROUND_OFF, "linear_classic": _ROUND_OFF,
             "dynamic": Bounds(history=1e-6, history_abs=1e-12, verdict_error=1e-6),
             ANY_SOLVER: Bounds(history=1e-6, history_abs=1e-12, verdict_error=1e-6)},
    "physics": {"quasi_static": Bounds(history=1e-6, history_abs=1e-12, verdict_error=0.0112),
                "linear": Bounds(history=0.02, history_abs=1e-9, verdict_error=0.0312),
                "linear_classic": Bounds(history=0.02, history_abs=1e-9, verdict_error=0.0312),
                "dynamic": Bounds(history=0.0112, history_abs=1e-9, verdict_error=0.0112),
                ANY_SOLVER: Bounds(history=0.0112, history_abs=1e-9, verdict_error=0.0112)},
}


@dataclass(frozen=True)
class Tolerances:
    """tier -> solver -> :class:`Bounds` (a solver missing from a tier takes that tier's ``default`` entry)."""

    tiers: Mapping[str, Mapping[str, Bounds]] = field(default_factory=lambda: DEFAULTS)

    def bounds(self, tier: str, solver: str) -> Bounds:
        t = self.tiers[tier]
        return t.get(solver) or t[ANY_SOLVER]

    def to_dict(self) -> dict[str, Any]:
        return {tier: {s: b.to_dict() for s, b in solvers.items()} for tier, solvers in self.tiers.items()}


def parse_tolerances(table: Any, path: str = "tolerances") -> tuple[Tolerances, list[str]]:
    """A ``[tolerances]`` TOML table -> (:class:`Tolerances`, problems).  Layout::

        [tolerances.physics.dynamic]
        history = 0.02          # given keys override the default of that tier and solver
        verdict_error = 0.02

    Every problem is returned as ``"toml.path: message"`` (none: the tolerances are valid)."""
    problems: list[str] = []
    if not isinstance(table, dict):
        return Tolerances(), [f"{path}: must be a table ([tolerances.<tier>.<solver>]), got {type(table).__name__}"]
    tiers = {t: dict(DEFAULTS[t]) for t in TIERS}
    for tier, solvers in table.items():
        tp = f"{path}.{tier}"
        if tier not in TIERS:
            problems.append(f"{tp}: unknown tier (allowed: {', '.join(TIERS)})")
            continue
        if not isinstance(solvers, dict):
            problems.append(f"{tp}: must be a table of solvers ([{tp}.<solver>])")
            continue
        for solver, values in solvers.items():
            sp = f"{tp}.{solver}"
            if not isinstance(values, dict):
                problems.append(f"{sp}: must be a table with keys {', '.join(QUANTITIES)}")
                continue
            unknown = [k for k in values if k not in QUANTITIES]
            problems += [f"{sp}.{k}: unknown key (allowed: {', '.join(QUANTITIES)})" for k in unknown]
            base = tiers[tier].get(solver) or tiers[tier][ANY_SOLVER]
            merged = {**base.to_dict(), **{k: v for k, v in values.items() if k in QUANTITIES}}
            bad = [k for k in QUANTITIES if isinstance(merged[k], bool) or not isinstance(merged[k], (int, float))
                   or not math.isfinite(merged[k]) or merged[k] < 0]
            problems += [f"{sp}.{k}: must be a finite number >= 0, got {merged[k]!r}" for k in bad]
            if not bad:
                tiers[tier][solver] = Bounds(**{k: float(v) for k, v in merged.items()})
    return Tolerances(tiers), problems
