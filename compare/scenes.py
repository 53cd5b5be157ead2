"""Campaign scenes: one grid point as a frozen recipe of a ``ked_quasi.Scene``, and its content key.

A :class:`SceneSpec` holds the source four-bar and mass model as the ``ked_quasi`` dataclasses
themselves (:class:`~ked_quasi.FourBar`, :class:`~ked_quasi.MassModel`), plus what a campaign varies
on top of them: the mechanism (source or cognate), the crank speed (absolute or as a ratio of the
lowest first natural frequency), a stiffness scale, a damping ratio, a direction, the grid, the
solvers and the solvers' explicit settings.  :attr:`SceneSpec.key` is the first 16 hex digits of the
SHA-256 of :meth:`SceneSpec.key_dict` in canonical JSON: the same parameters always give the same
key (what makes campaigns resumable).  The solver list is not part of the key: a stored scene gains
a solver by resuming with it.

Units: SI (m, kg, Pa, m^2, m^4, kg/m^3, rad) unless a name says otherwise (``step_deg`` in degrees,
``rpm`` in revolutions per minute).
"""

from __future__ import annotations

import functools
import hashlib
import itertools
import json
from dataclasses import dataclass
from typing import Any

from ked_quasi import kinds
from ked_quasi.cognates import MECHANISMS  # noqa: F401  (re-exported where it was defined)
from ked_quasi.linkage import FourBar
from ked_quasi.massmodel import MassModel
from ked_quasi.scene import KIND as FOUR_BAR
from ked_quasi.scene import Scene
from ked_quasi.slidercrank import KIND as SLIDER_KIND  # noqa: F401  (the kinds' names, imported from here)
from ked_quasi.slidercrank import SliderCrank, SliderScene

DEFAULT_SOLVERS = ("quasi_static", "dynamic")
"""The solvers of a campaign that does not name its own."""

Items = tuple[tuple[str, Any], ...]


@dataclass(frozen=True)
class SpeedSpec:
    """Crank speed, either absolute (``kind="rpm"``, value in rev/min) or as a ratio of the lowest
    first natural frequency over the cycle (``kind="ratio"``: Omega = value * omega1_min)."""

    kind: str
    value: float

    def to_dict(self) -> dict[str, Any]:
        return {"kind": self.kind, "value": self.value}

    def label(self) -> str:
        return f"{self.value:g}rpm" if self.kind == "rpm" else f"{self.value:g}w1"


@dataclass(frozen=True)
class SceneSpec:
    """One immutable scene of a campaign (see module docstring for units).

    ``linkage``: the source four-bar or slider-crank (its own ``direction`` is ignored: ``direction`` is the
    axis; :attr:`kind` says which);
    ``dynamic``: the explicit Exudyn settings overrides as sorted ``(name, value)`` pairs (damping
    ratio included); ``extra_settings``: other solvers' explicit overrides, ``(solver, pairs)``;
    ``solvers``: the solvers to run (not hashed).  Defaults are resolved by each solver and stored in
    the results file, but do not enter the key.
    """

    linkage: FourBar | SliderCrank
    mechanism: str
    mass_model: MassModel
    speed: SpeedSpec
    stiffness_scale: float
    damping_ratio: float
    direction: str
    step_deg: float
    n_modes: int
    outputs: tuple[str, ...]
    tolerance: float
    dynamic: Items = ()
    extra_settings: tuple[tuple[str, Items], ...] = ()
    solvers: tuple[str, ...] = DEFAULT_SOLVERS

    # -- the scene itself -------------------------------------------------------------------
    @property
    def kind(self) -> str:
        """The linkage kind ("four-bar", "slider-crank": the linkage's own, :mod:`ked_quasi.kinds`)."""
        return self.linkage.kind

    def fourbar(self) -> FourBar | SliderCrank:
        """The analysed linkage (mechanism, stiffness scale and direction applied; a slider-crank has only its
        source mechanism)."""
        return kinds.model(self).variant(self.linkage, self.mechanism, self.stiffness_scale, self.direction)

    def scene(self, rpm: float) -> Scene | SliderScene:
        """The ``ked_quasi.Scene`` (a ``SliderScene`` for a slider-crank) at a resolved crank speed [rev/min]."""
        return kinds.model(self).scene_type(self.fourbar(), self.mass_model, rpm=rpm, step_deg=self.step_deg)

    def settings_for(self, solver: str) -> dict[str, Any]:
        """Explicit settings overrides of one solver (``dynamic``: the Exudyn model's)."""
        if solver == "dynamic":
            return dict(self.dynamic)
        return dict(dict(self.extra_settings).get(solver, ()))

    def shared_settings(self) -> dict[str, Any]:
        """Physical settings every dynamic model of the scene shares: the damping reference frequency
        when the campaign pins it (in ``[dynamic]``), so that all models are damped alike."""
        ref = dict(self.dynamic).get("damping_reference_hz")
        return {} if ref is None else {"damping_reference_hz": ref}

    # -- serialization ----------------------------------------------------------------------
    def key_dict(self) -> dict[str, Any]:
        """JSON-serialisable dictionary of everything that defines the scene's results (hashed into
        :attr:`key`).  Solvers' settings other than Exudyn's appear only when given."""
        d = {
            "linkage": _linkage_dict(self.linkage),
            "mechanism": self.mechanism,
            "mass_model": _mass_model_dict(self.mass_model),
            "speed": self.speed.to_dict(),
            "stiffness_scale": self.stiffness_scale,
            "damping_ratio": self.damping_ratio,
            "direction": self.direction,
            "step_deg": self.step_deg,
            "n_modes": self.n_modes,
            "outputs": list(self.outputs),
            "tolerance": self.tolerance,
            "dynamic": dict(self.dynamic),
        }
        d.update({name: dict(items) for name, items in self.extra_settings if items})
        return d

    def to_dict(self) -> dict[str, Any]:
        """:meth:`key_dict` plus the solver list (what the results file stores)."""
        return {**self.key_dict(), "solvers": list(self.solvers)}

    @staticmethod
    def from_dict(d: dict[str, Any]) -> SceneSpec:
        known = {"linkage", "mechanism", "mass_model", "speed", "stiffness_scale", "damping_ratio", "direction",
                 "step_deg", "n_modes", "outputs", "tolerance", "dynamic", "solvers"}
        # a four-bar's stored linkage has no kind (the keys of the campaigns stored before the slider-crank)
        linkage = kinds.named(d["linkage"].get("kind", FOUR_BAR)).read_linkage(d["linkage"])
        return SceneSpec(
            linkage=linkage,
            mechanism=str(d["mechanism"]),
            mass_model=MassModel.from_dict(d["mass_model"]),
            speed=SpeedSpec(kind=str(d["speed"]["kind"]), value=float(d["speed"]["value"])),
            stiffness_scale=float(d["stiffness_scale"]),
            damping_ratio=float(d["damping_ratio"]),
            direction=str(d["direction"]),
            step_deg=float(d["step_deg"]),
            n_modes=int(d["n_modes"]),
            outputs=tuple(d["outputs"]),
            tolerance=float(d["tolerance"]),
            dynamic=tuple(sorted(d["dynamic"].items())),
            extra_settings=tuple(sorted((k, tuple(sorted(v.items()))) for k, v in d.items() if k not in known)),
            solvers=tuple(d.get("solvers", DEFAULT_SOLVERS)),
        )

    def canonical_json(self) -> str:
        """Canonical JSON of :meth:`key_dict`: sorted keys, no whitespace, shortest round-trip floats."""
        return canonical_json(self.key_dict())

    @functools.cached_property
    def key(self) -> str:
        """Stable content key: 16 hex digits of SHA-256 of :meth:`canonical_json`."""
        return hashlib.sha256(self.canonical_json().encode("utf-8")).hexdigest()[:16]

    @property
    def label(self) -> str:
        """Short human-readable label, e.g. ``source/tip/300rpm/k1/z0.02/ccw``; a slider-crank's first segment is
        ``slider-crank`` (its only mechanism is its source), so the two kinds of a mixed grid never share one."""
        return (
            f"{self._first_segment()}/{self.mass_model.name}/{self.speed.label()}"
            f"/k{self.stiffness_scale:g}/z{self.damping_ratio:g}/{self.direction}"
        )


    def _first_segment(self) -> str:
        """The mechanism; the kind's name for a kind with one mechanism only (a slider-crank's source)."""
        return self.kind if len(kinds.model(self).mechanisms) == 1 else self.mechanism


@functools.lru_cache(maxsize=64)
def _linkage_dict(fourbar: FourBar | SliderCrank) -> dict[str, Any]:
    """The source linkage as hashed into keys (its direction is a grid axis of its own); cached: a
    grid shares one linkage (callers must not modify the result).  A four-bar's dict has no ``kind`` (its
    keys are those of the campaigns stored before the slider-crank); a slider-crank's has
    ``kind = "slider-crank"``, so the two kinds never share a key."""
    d = fourbar.to_dict()
    del d["direction"]
    return d


@functools.lru_cache(maxsize=256)
def _mass_model_dict(mass_model: MassModel) -> dict[str, Any]:
    return mass_model.to_dict()


def canonical_json(obj: Any) -> str:
    """Deterministic JSON text of ``obj`` (sorted keys, compact separators, NaN forbidden)."""
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), allow_nan=False)


@dataclass(frozen=True)
class Grid:
    """The axes of a campaign grid and the settings every scene shares (see :class:`SceneSpec`).

    ``linkages``: the source linkages, one or more, of either kind (a campaign's ``[linkage]`` table, or each
    table of its ``[[linkage]]`` array); every other axis applies to each of them."""

    linkages: tuple[FourBar | SliderCrank, ...]
    mechanisms: tuple[str, ...]
    mass_models: tuple[MassModel, ...]
    speeds: tuple[SpeedSpec, ...]
    stiffness_scales: tuple[float, ...]
    damping_ratios: tuple[float, ...]
    directions: tuple[str, ...]
    step_deg: float
    n_modes: int
    outputs: tuple[str, ...]
    tolerance: float
    dynamic: Items
    dynamic_variants: tuple[Items, ...] = ((),)
    extra_settings: tuple[tuple[str, Items], ...] = ()
    solvers: tuple[str, ...] = DEFAULT_SOLVERS

    @property
    def linkage(self) -> FourBar | SliderCrank:
        """The first source linkage (the only one of a campaign with a single ``[linkage]`` table)."""
        return self.linkages[0]

    def size(self) -> int:
        """Number of grid points (before removing duplicate keys)."""
        n = 1
        for axis in (self.linkages, self.mechanisms, self.mass_models, self.speeds, self.stiffness_scales,
                     self.damping_ratios, self.directions, self.dynamic_variants):
            n *= len(axis)
        return n

    def expand(self) -> tuple[SceneSpec, ...]:
        """Cartesian product of the axes, in a fixed order, without duplicate keys.

        Order: linkage, mechanism, mass model, speed, stiffness scale, damping ratio, direction, dynamic variant
        (last varies fastest).  Each dynamic variant's overrides are merged on top of ``dynamic``.
        """
        scenes: list[SceneSpec] = []
        seen: set[str] = set()
        for linkage, mech, mm, speed, k, zeta, direction, var in itertools.product(
            self.linkages, self.mechanisms, self.mass_models, self.speeds, self.stiffness_scales, self.damping_ratios,
            self.directions, self.dynamic_variants,
        ):
            dyn = tuple(sorted(dict(self.dynamic, **dict(var), damping_ratio=zeta).items()))
            spec = SceneSpec(linkage=linkage, mechanism=mech, mass_model=mm, speed=speed, stiffness_scale=k,
                             damping_ratio=zeta, direction=direction, step_deg=self.step_deg, n_modes=self.n_modes,
                             outputs=self.outputs, tolerance=self.tolerance, dynamic=dyn,
                             extra_settings=self.extra_settings, solvers=self.solvers)
            if spec.key not in seen:
                seen.add(spec.key)
                scenes.append(spec)
        return tuple(scenes)
