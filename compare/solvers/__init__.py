"""The solver registry: every model a campaign can run on a scene, behind one interface.

A solver is one module that builds a :class:`Solver` and registers it.  It takes a
``ked_quasi.Scene`` plus its settings and returns a :class:`Solution`: the coupler-point deflection
on the scene's crank-angle grid, its resolved settings, run statistics and a status.  Campaigns, the
HDF5 store, the metrics (every pair of solvers), ``ked inspect``, ``ked plot`` and the studies
iterate over the registered solvers; adding one is a module plus a :func:`register` call.

Solvers travel to worker processes by reference (module and name), so a solver must be defined at
module level of an importable module.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from ked_quasi.scene import Scene

COMPONENTS = ("dx", "dy", "rotation")
"""Deflection components of the coupler point P: dx, dy [m] (global frame), rotation [rad, CCW]."""
COMPONENT_UNITS = {"dx": "m", "dy": "m", "rotation": "rad"}
STRESS = "stress"
"""The opt-in output of link stresses: per link the largest and smallest extreme-fibre normal stress over its
length at every crank angle (:class:`ked_quasi.stress.StressHistory`, sigma = N/A +- M c/I) [Pa]."""
OUTPUTS = (*COMPONENTS, STRESS)
"""What a campaign can ask its solvers for (``[campaign] outputs``)."""
STRESS_PREFIX = "stress_"
"""History name of a link's stress in :attr:`Solution.histories` and the metric rows: ``stress_<link>``."""

STATUS_OK = "ok"
STATUS_FAILED = "failed"
FAILURE_CLASSES = ("", "numerical", "physical", "undecided", "input")
"""Why a solution failed: "numerical" (the method gave up: discretization, iteration), "physical"
(the modelled system has no periodic steady state), "undecided" (the evidence shows neither), "input"
(the scene is outside what the solver accepts), "" (not classified / not failed)."""


@dataclass(frozen=True, eq=False)
class Solution:
    """One solver's answer for one scene.

    ``deflection``: component -> (n,) history on the scene grid (only the requested components; empty
    if the solver failed before producing one); ``settings``: the resolved settings (JSON-able
    scalars); ``stats``: run statistics (JSON-able scalars, ``wall_s`` [s] always); ``flags``: names of
    validity checks the answer failed (it is outside the range where the model holds);
    ``warnings``: the solver's warnings, "; "-joined; ``fidelity``: the solver's (travels with the
    answer, so that a file read where the solver is not registered keeps its pairs).
    """

    solver: str
    status: str
    deflection: dict[str, np.ndarray] = field(default_factory=dict)
    settings: dict[str, Any] = field(default_factory=dict)
    stats: dict[str, Any] = field(default_factory=dict)
    message: str = ""
    error_type: str = ""
    failure_class: str = ""
    flags: tuple[str, ...] = ()
    warnings: str = ""
    fidelity: int = 0
    stress: dict[str, np.ndarray] = field(default_factory=dict)
    """Link -> (n, 2) [Pa]: the largest and the smallest extreme-fibre normal stress over the link at each crank
    angle (only with the output ``stress``; empty where the solver gave none)."""

    @property
    def ok(self) -> bool:
        return self.status == STATUS_OK

    @property
    def histories(self) -> dict[str, np.ndarray]:
        """Everything the metrics compare: the deflection components, then ``stress_<link>`` (n, 2) per link."""
        return {**self.deflection, **{STRESS_PREFIX + lk: v for lk, v in self.stress.items()}}

    def array(self, components: tuple[str, ...] = COMPONENTS) -> np.ndarray:
        """(n, len(components)) history; raises KeyError if a component is missing."""
        return np.column_stack([self.deflection[c] for c in components])


def deflection_of(d: np.ndarray, outputs: tuple[str, ...]) -> dict[str, np.ndarray]:
    """The requested deflection components of an (n, 3) history (dx, dy, rotation)."""
    return {c: np.asarray(d[:, COMPONENTS.index(c)], dtype=float).copy() for c in outputs if c in COMPONENTS}


def stress_of(history: Any) -> dict[str, np.ndarray]:
    """:attr:`Solution.stress` of a :class:`ked_quasi.stress.StressHistory`: link -> (n, 2) [Pa]."""
    return {lk: np.column_stack([ls.sigma_max, ls.sigma_min]) for lk, ls in history.links.items()}


@dataclass(frozen=True)
class Solver:
    """A registered model.

    ``name``: its HDF5 group and the campaign config's name for it (``[grid] solvers``, and the
    table of its settings overrides); ``label``: how tables and figures call it; ``fidelity``: the
    solver with the highest fidelity present in a scene is the reference every other one is measured
    against; ``settings_class()``: the frozen dataclass of its settings (a function, so that heavy
    packages load only when used), built from the scene's explicit overrides by
    ``make_settings(overrides, damping_ratio)``; ``run(scene, settings, outputs)``
    returns the :class:`Solution` (it may raise: the campaign stores the exception as a failure); ``outputs``
    holds deflection components and may hold :data:`STRESS` (:func:`deflection_of` picks the components; a
    solver without stresses leaves :attr:`Solution.stress` empty and the metrics compare what both have);
    ``legacy_defaults()``: for settings fields added after results were stored, the value that
    reproduces the older behaviour (stored settings without the field count as that value);
    ``setting_rules()``: field name -> the :class:`ked_quasi.rules.Rule` (or ``Choice``, ``Flag``) its
    settings class checks the field with: the campaign config checks the solver's table with the same
    rules (a function, like ``settings_class``); ``physics_rtol``: the relative tolerance (on the peak)
    to which the solver meets the shared physics checks at low speed (speed ratio about 0.05: mirror
    symmetry, rpm^2 and 1/E scaling; ``tests/test_physics_checks.py`` runs them on every registered
    solver): round-off for a quasi-static method, its discretization and dynamic content otherwise.
    """

    name: str
    label: str
    fidelity: int
    settings_class: Callable[[], type]
    make_settings: Callable[[dict[str, Any], float], Any]
    run: Callable[[Scene, Any, tuple[str, ...]], Solution]
    description: str = ""
    legacy_defaults: Callable[[], dict[str, Any]] = dict
    setting_rules: Callable[[], Mapping[str, Any]] = dict
    physics_rtol: float = 0.02

    def settings_dict(self, settings: Any) -> dict[str, Any]:
        """Resolved settings as a JSON-able dict."""
        return dataclasses.asdict(settings)

    def setting_fields(self) -> dict[str, Any]:
        """Setting name -> default value (None when it has no default)."""
        out: dict[str, Any] = {}
        for f in dataclasses.fields(self.settings_class()):
            if f.default is not dataclasses.MISSING:
                out[f.name] = f.default
            elif f.default_factory is not dataclasses.MISSING:  # type: ignore[misc]
                out[f.name] = f.default_factory()  # type: ignore[misc]
            else:
                out[f.name] = None
        return out


REGISTRY: dict[str, Solver] = {}


def register(solver: Solver) -> Solver:
    """Add (or replace) a solver under its name; returns it."""
    if not isinstance(solver, Solver):
        raise TypeError("register() takes a Solver")
    REGISTRY[solver.name] = solver
    return solver


def get(name: str) -> Solver:
    """The registered solver ``name``; ValueError listing the registered ones otherwise."""
    _builtins()
    if name not in REGISTRY:
        raise ValueError(f"unknown solver {name!r}; registered: {', '.join(REGISTRY)}")
    return REGISTRY[name]


def names() -> tuple[str, ...]:
    """Registered solver names, lowest fidelity first."""
    _builtins()
    return tuple(sorted(REGISTRY, key=lambda n: (REGISTRY[n].fidelity, n)))


def label(name: str) -> str:
    """Display label of a solver (its name if it is not registered)."""
    _builtins()
    return REGISTRY[name].label if name in REGISTRY else name


def fidelity(name: str) -> int:
    _builtins()
    return REGISTRY[name].fidelity if name in REGISTRY else 0


BUILTIN_MODULES = ("quasi_static", "linear", "dynamic")
"""Modules of the built-in solvers (``linear`` registers ``linear`` and ``linear_classic``)."""


def _builtins() -> None:
    """Register the built-in solvers (imports are light: each solver loads its package on first run)."""
    import importlib

    for module in BUILTIN_MODULES:
        importlib.import_module(f"compare.solvers.{module}")  # registers itself on first import
