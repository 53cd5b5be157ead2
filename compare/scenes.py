"""Immutable scene specifications, grid expansion and stable content keys.

A *scene* is one point of a campaign grid: one linkage, one mechanism (source or cognate), one mass
model, one crank speed, one stiffness scale, one damping ratio, one direction, plus the numerical
settings of both solvers.  A :class:`SceneSpec` is a frozen, JSON-serialisable description of it; its
:attr:`SceneSpec.key` is the first 16 hex digits of the SHA-256 of its canonical JSON, so the same
parameters always give the same key (this is what makes campaigns resumable).

Everything here is pure: building the solver objects (``ked_quasi`` scenes, Exudyn settings) happens in
:mod:`compare.runner`.  Units are SI (m, kg, Pa, m^2, m^4, kg/m^3, rad) unless a name says otherwise
(``step_deg`` in degrees, ``rpm`` in revolutions per minute).
"""

from __future__ import annotations

import hashlib
import itertools
import json
from dataclasses import dataclass, field
from typing import Any

LINKS = ("crank", "coupler", "extender", "follower")
COMPONENTS = ("dx", "dy", "rotation")
COMPONENT_UNITS = {"dx": "m", "dy": "m", "rotation": "rad"}
MECHANISMS = ("source", "cognate")
MASS_MODEL_NAMES = ("tip", "joints", "extender", "distributed")
DIRECTIONS = ("ccw", "cw")
BRANCHES = ("open", "crossed")


@dataclass(frozen=True)
class SectionSpec:
    """Cross-section and material of one link.

    youngs_modulus [Pa], area [m^2], second_moment [m^4], density [kg/m^3].
    """

    youngs_modulus: float
    area: float
    second_moment: float
    density: float

    def to_dict(self) -> dict[str, float]:
        return {
            "youngs_modulus": self.youngs_modulus,
            "area": self.area,
            "second_moment": self.second_moment,
            "density": self.density,
        }


@dataclass(frozen=True)
class LinkageSpec:
    """Dimensions of the source four-bar.

    Lengths [m], ``coupler_angle`` [rad] (CCW from AB to AP), pivots [m] (M = crank pivot,
    Q = follower pivot), ``branch`` "open"|"crossed", ``sections`` in :data:`LINKS` order.
    """

    crank: float
    coupler: float
    follower: float
    extender: float
    coupler_angle: float
    crank_pivot: tuple[float, float]
    follower_pivot: tuple[float, float]
    branch: str
    sections: tuple[SectionSpec, SectionSpec, SectionSpec, SectionSpec]

    def to_dict(self) -> dict[str, Any]:
        return {
            "crank": self.crank,
            "coupler": self.coupler,
            "follower": self.follower,
            "extender": self.extender,
            "coupler_angle": self.coupler_angle,
            "crank_pivot": list(self.crank_pivot),
            "follower_pivot": list(self.follower_pivot),
            "branch": self.branch,
            "sections": [s.to_dict() for s in self.sections],
        }

    @staticmethod
    def from_dict(d: dict[str, Any]) -> LinkageSpec:
        return LinkageSpec(
            crank=float(d["crank"]),
            coupler=float(d["coupler"]),
            follower=float(d["follower"]),
            extender=float(d["extender"]),
            coupler_angle=float(d["coupler_angle"]),
            crank_pivot=(float(d["crank_pivot"][0]), float(d["crank_pivot"][1])),
            follower_pivot=(float(d["follower_pivot"][0]), float(d["follower_pivot"][1])),
            branch=str(d["branch"]),
            sections=tuple(SectionSpec(**{k: float(v) for k, v in s.items()}) for s in d["sections"]),
        )


@dataclass(frozen=True)
class MassModelSpec:
    """Mass model of a scene: ``name`` in :data:`MASS_MODEL_NAMES`, ``lumps`` per link,
    ``payload`` [kg] at the coupler point P, ``joint_split`` fraction [1] of each link's mass at its
    root end in the ``joints`` model, ``placement`` "midpoint"|"end" (see
    ``ked_quasi.massmodel.MassModel``)."""

    name: str
    lumps: int = 5
    payload: float = 0.0
    joint_split: float = 0.5
    placement: str = "midpoint"

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "lumps": self.lumps,
            "payload": self.payload,
            "joint_split": self.joint_split,
            "placement": self.placement,
        }


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

    ``dynamic`` holds the explicit ``exudyn_models.DynamicSettings`` overrides as sorted
    ``(name, value)`` pairs (damping ratio included); defaults are resolved by the runner and stored
    in the results file, but do not enter the key.
    """

    linkage: LinkageSpec
    mechanism: str
    mass_model: MassModelSpec
    speed: SpeedSpec
    stiffness_scale: float
    damping_ratio: float
    direction: str
    step_deg: float
    n_modes: int
    outputs: tuple[str, ...]
    tolerance: float
    dynamic: tuple[tuple[str, Any], ...] = field(default=())

    def to_dict(self) -> dict[str, Any]:
        """JSON-serialisable dictionary (the canonical form hashed into :attr:`key`)."""
        return {
            "linkage": self.linkage.to_dict(),
            "mechanism": self.mechanism,
            "mass_model": self.mass_model.to_dict(),
            "speed": self.speed.to_dict(),
            "stiffness_scale": self.stiffness_scale,
            "damping_ratio": self.damping_ratio,
            "direction": self.direction,
            "step_deg": self.step_deg,
            "n_modes": self.n_modes,
            "outputs": list(self.outputs),
            "tolerance": self.tolerance,
            "dynamic": {k: v for k, v in self.dynamic},
        }

    @staticmethod
    def from_dict(d: dict[str, Any]) -> SceneSpec:
        mm = d["mass_model"]
        return SceneSpec(
            linkage=LinkageSpec.from_dict(d["linkage"]),
            mechanism=str(d["mechanism"]),
            mass_model=MassModelSpec(
                name=str(mm["name"]),
                lumps=int(mm["lumps"]),
                payload=float(mm["payload"]),
                joint_split=float(mm["joint_split"]),
                placement=str(mm["placement"]),
            ),
            speed=SpeedSpec(kind=str(d["speed"]["kind"]), value=float(d["speed"]["value"])),
            stiffness_scale=float(d["stiffness_scale"]),
            damping_ratio=float(d["damping_ratio"]),
            direction=str(d["direction"]),
            step_deg=float(d["step_deg"]),
            n_modes=int(d["n_modes"]),
            outputs=tuple(d["outputs"]),
            tolerance=float(d["tolerance"]),
            dynamic=tuple(sorted(d["dynamic"].items())),
        )

    def canonical_json(self) -> str:
        """Canonical JSON: sorted keys, no whitespace, floats in shortest round-trip form."""
        return canonical_json(self.to_dict())

    @property
    def key(self) -> str:
        """Stable content key: 16 hex digits of SHA-256 of :meth:`canonical_json`."""
        return hashlib.sha256(self.canonical_json().encode("utf-8")).hexdigest()[:16]

    @property
    def label(self) -> str:
        """Short human-readable label, e.g. ``source/tip/300rpm/k1/z0.02/ccw``."""
        return (
            f"{self.mechanism}/{self.mass_model.name}/{self.speed.label()}"
            f"/k{self.stiffness_scale:g}/z{self.damping_ratio:g}/{self.direction}"
        )


def canonical_json(obj: Any) -> str:
    """Deterministic JSON text of ``obj`` (sorted keys, compact separators, NaN forbidden)."""
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), allow_nan=False)


def expand_grid(
    *,
    linkage: LinkageSpec,
    mechanisms: tuple[str, ...],
    mass_models: tuple[MassModelSpec, ...],
    speeds: tuple[SpeedSpec, ...],
    stiffness_scales: tuple[float, ...],
    damping_ratios: tuple[float, ...],
    directions: tuple[str, ...],
    step_deg: float,
    n_modes: int,
    outputs: tuple[str, ...],
    tolerance: float,
    dynamic: tuple[tuple[str, Any], ...],
    dynamic_variants: tuple[tuple[tuple[str, Any], ...], ...] = ((),),
) -> tuple[SceneSpec, ...]:
    """Cartesian product of the grid axes, in a fixed order, without duplicate keys.

    Order: mechanism, mass model, speed, stiffness scale, damping ratio, direction, dynamic variant
    (last varies fastest).  Each dynamic variant's overrides are merged on top of ``dynamic``.
    """
    scenes: list[SceneSpec] = []
    seen: set[str] = set()
    for mech, mm, speed, k, zeta, direction, variant in itertools.product(
        mechanisms, mass_models, speeds, stiffness_scales, damping_ratios, directions, dynamic_variants
    ):
        dyn = tuple(sorted(dict(dynamic, **dict(variant), damping_ratio=zeta).items()))
        spec = SceneSpec(
            linkage=linkage,
            mechanism=mech,
            mass_model=mm,
            speed=speed,
            stiffness_scale=k,
            damping_ratio=zeta,
            direction=direction,
            step_deg=step_deg,
            n_modes=n_modes,
            outputs=outputs,
            tolerance=tolerance,
            dynamic=dyn,
        )
        if spec.key not in seen:
            seen.add(spec.key)
            scenes.append(spec)
    return tuple(scenes)
