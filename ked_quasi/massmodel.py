"""Mass models: where the moving mass of a four-bar sits, as point masses on its links.

Every model is a set of lumps, each on one link at a fraction ``s`` of its length measured from the
link's root (crank from M, coupler and extender from A, follower from Q), plus an optional payload
at the coupler point P.

* ``tip`` (thesis Case I): payload at P only, massless links (payload must be > 0).
* ``joints`` (Case II): each link's mass lumped at its two ends; ``joint_split`` is the fraction at the
  root end: 0.5 (default) puts half at each end; 0.0 is the thesis's own placement (its Case II force
  transformation puts each link's whole mass at its far joint: crank at A, coupler and follower at B,
  extender at P).
* ``extender`` (Case III): the extender's mass in ``lumps`` equal lumps along AP, other links massless.
* ``distributed``: every link's mass in ``lumps`` equal lumps: the quasi-static counterpart of a
  flexible-body model with real distributed link mass.

Lumps sit at the midpoints of ``lumps`` equal sub-elements (``placement="midpoint"``, converges as
the midpoint rule) or at their outer ends (``placement="end"``, the thesis's Case III nodes).
Lumps at a ground pivot (crank s=0, follower s=0) carry no inertia load and are dropped.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from . import rules
from .linkage import LINKS, THESIS_TIP_MASS_KG, FourBar
from .rules import check_choice

MASS_MODELS = ("tip", "joints", "extender", "distributed")
PLACEMENTS = ("midpoint", "end")


def default_payload(name: str) -> float:
    """Payload at P [kg] when none is given: the thesis's 2 lb for ``tip`` (massless links need one),
    none otherwise.  The same default for every linkage, in campaigns and on the command line."""
    return THESIS_TIP_MASS_KG if name == "tip" else 0.0


@dataclass(frozen=True)
class MassModel:
    """Which mass model, and its parameters.

    name: one of :data:`MASS_MODELS`; lumps: lumps per distributed link (>= 1); payload: point mass at
    P [kg] (>= 0; > 0 for ``tip``); joint_split: fraction of each link's mass at its root end in the
    ``joints`` model (0..1, 0.5 = half at each end); placement: ``midpoint`` or ``end``.
    """

    name: str
    lumps: int = rules.DEFAULT_LUMPS
    payload: float = 0.0
    joint_split: float = 0.5
    placement: str = "midpoint"

    def __post_init__(self) -> None:
        check_choice("mass model", self.name, MASS_MODELS)
        object.__setattr__(self, "lumps", rules.LUMPS.check(self.lumps, "MassModel.lumps"))
        object.__setattr__(self, "payload", rules.PAYLOAD_KG.check(self.payload, "MassModel.payload"))
        if self.name == "tip" and self.payload <= 0:
            raise ValueError("MassModel.payload must be > 0 kg for the 'tip' mass model (massless links)")
        object.__setattr__(self, "joint_split", rules.JOINT_SPLIT.check(self.joint_split, "MassModel.joint_split"))
        check_choice("MassModel.placement", self.placement, PLACEMENTS)

    def to_dict(self) -> dict[str, Any]:
        """Plain dict (TOML, JSON, HDF5 attributes); :meth:`from_dict` inverts it."""
        return {"name": self.name, "lumps": self.lumps, "payload": self.payload,
                "joint_split": self.joint_split, "placement": self.placement}

    @staticmethod
    def from_dict(d: dict[str, Any]) -> MassModel:
        return MassModel(name=d["name"], lumps=int(d["lumps"]), payload=d["payload"],
                         joint_split=d["joint_split"], placement=d["placement"])


@dataclass(frozen=True)
class Lumps:
    """Point masses on the links: parallel arrays ``link`` (names), ``s`` (fraction from root),
    ``mass`` [kg].  The payload at P appears as an extender lump at s = 1."""

    link: tuple[str, ...]
    s: np.ndarray
    mass: np.ndarray

    def on(self, link: str) -> tuple[np.ndarray, np.ndarray]:
        """(s, mass) of the lumps on one link."""
        sel = np.array([lk == link for lk in self.link], dtype=bool)
        return self.s[sel], self.mass[sel]

    @property
    def total_mass(self) -> float:
        return float(self.mass.sum())


def _fractions(n: int, placement: str) -> np.ndarray:
    k = np.arange(1, n + 1, dtype=float)
    return (k - 0.5) / n if placement == "midpoint" else k / n


def lumps(fourbar: FourBar, mass_model: MassModel) -> Lumps:
    """The point masses of ``mass_model`` on ``fourbar`` (ground-pivot lumps dropped)."""
    link: list[str] = []
    s: list[float] = []
    m: list[float] = []

    def add(lk: str, frac: float, mass: float) -> None:
        if lk in ("crank", "follower") and frac == 0.0:
            return  # sits on a ground pivot: no inertia load on the structure
        if mass > 0.0:
            link.append(lk)
            s.append(frac)
            m.append(mass)

    mm = mass_model
    if mm.name == "joints":
        for lk in LINKS:
            add(lk, 0.0, mm.joint_split * fourbar.link_mass(lk))
            add(lk, 1.0, (1.0 - mm.joint_split) * fourbar.link_mass(lk))
    elif mm.name in ("extender", "distributed"):
        for lk in ("extender",) if mm.name == "extender" else LINKS:
            for frac in _fractions(mm.lumps, mm.placement):
                add(lk, float(frac), fourbar.link_mass(lk) / mm.lumps)
    add("extender", 1.0, float(mm.payload))
    return Lumps(tuple(link), np.array(s, dtype=float), np.array(m, dtype=float))
