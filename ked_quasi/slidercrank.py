"""The slider-crank linkage: its definition, closed-form kinematics, mass lumps and scene, SI units.

Frame and conventions:

* crank pivot M at the origin; the slider moves on the straight line y = ``offset``, parallel to x, on
  the +x side of the pivot (crank angle 0 puts the slider at its far dead centre when offset = 0);
* crank angle ``theta``: angle of the crank M->A measured counter-clockwise from +x;
* coupler (connecting rod) from the crank pin A to the slider pin B; the coupler point P lies on it at
  the fraction ``coupler_point`` of its length from A (0.5: midspan);
* ``direction`` "ccw"/"cw": sign of the constant crank speed.

Closed form: x_B = l1 cos(theta) + sqrt(l2^2 - (l1 sin(theta) - offset)^2), the rod angle phi from
l1 sin(theta) + l2 sin(phi) = offset.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from . import rules, units
from .linkage import DIRECTIONS, SECTION_RULES, Section, direction_sign
from .massmodel import MassModel, default_payload
from .rules import check_choice
from .scene import CrankGrid

KIND = "slider-crank"
"""The ``kind`` of a slider-crank in a linkage TOML table."""

SLIDER_LINKS = ("crank", "coupler")
"""The elastic links of a slider-crank, in the order of :attr:`SliderCrank.sections`."""

SLIDER_MASS_MODELS = ("tip", "joints", "distributed")
"""Mass models that apply to a slider-crank (it has no extender)."""


@dataclass(frozen=True)
class SliderCrank:
    """A planar slider-crank with a coupler point, elastic or rigid links and a lumped slider (SI units).

    crank, coupler: lengths [m]; offset: y of the slider line [m] (the line is parallel to x);
    coupler_point: fraction of the coupler from A to P, in (0, 1); sections: (crank, coupler) sections;
    rigid: (crank, coupler) flags, a rigid link does not deform (its section still gives its mass);
    slider_mass: lumped mass of the slider at B [kg]; direction: "ccw" or "cw".  Construction validates
    every value, that the crank turns fully (crank + |offset| < coupler) and that the transmission angle
    stays at least :data:`~ked_quasi.rules.MIN_TRANSMISSION_DEG` from a toggle.
    """

    crank: float
    coupler: float
    sections: tuple[Section, Section]
    offset: float = 0.0
    coupler_point: float = 0.5
    rigid: tuple[bool, bool] = (False, False)
    slider_mass: float = 0.0
    direction: str = "ccw"
    crank_pivot: tuple[float, float] = field(default=(0.0, 0.0), init=False)

    def __post_init__(self) -> None:
        for name in ("crank", "coupler"):
            object.__setattr__(self, name, rules.LENGTH.check(getattr(self, name), f"SliderCrank.{name}"))
        object.__setattr__(self, "offset", rules.OFFSET.check(self.offset, "SliderCrank.offset"))
        object.__setattr__(self, "coupler_point",
                           rules.COUPLER_POINT.check(self.coupler_point, "SliderCrank.coupler_point"))
        object.__setattr__(self, "slider_mass", rules.SLIDER_MASS_KG.check(self.slider_mass, "SliderCrank.slider_mass"))
        check_choice("SliderCrank.direction", self.direction, DIRECTIONS)
        if len(self.sections) != 2 or not all(isinstance(s, Section) for s in self.sections):
            raise ValueError("SliderCrank.sections must be two Section objects (crank, coupler)")
        object.__setattr__(self, "sections", tuple(self.sections))
        if len(self.rigid) != 2 or not all(isinstance(r, (bool, np.bool_)) for r in self.rigid):
            raise ValueError(f"SliderCrank.rigid must be two booleans (crank, coupler); got {self.rigid!r}")
        object.__setattr__(self, "rigid", tuple(bool(r) for r in self.rigid))
        rules.check_slider_crank_turns(self.crank, self.coupler, self.offset)
        mu, at = self.min_transmission_deg()
        rules.check_transmission(mu, "SliderCrank", at, f"crank={self.crank:g} m, coupler={self.coupler:g} m, "
                                 f"offset={self.offset:g} m")

    # -- serialization ----------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """Plain dict (TOML, JSON): kind, lengths and offset [m], coupler_point, slider_mass [kg], direction,
        sections (list in :data:`SLIDER_LINKS` order, each with its ``rigid`` flag); :meth:`from_dict`
        inverts it."""
        return {"kind": KIND, "crank": self.crank, "coupler": self.coupler, "offset": self.offset,
                "coupler_point": self.coupler_point, "slider_mass": self.slider_mass, "direction": self.direction,
                "sections": [{**s.to_dict(), "rigid": r} for s, r in zip(self.sections, self.rigid)]}

    @staticmethod
    def from_dict(d: dict[str, Any]) -> SliderCrank:
        if d.get("kind", KIND) != KIND:
            raise ValueError(f"SliderCrank.kind: must be {KIND!r}; got {d.get('kind')!r}")
        return SliderCrank(crank=d["crank"], coupler=d["coupler"], offset=d.get("offset", 0.0),
                           coupler_point=d.get("coupler_point", 0.5), slider_mass=d.get("slider_mass", 0.0),
                           direction=d.get("direction", "ccw"),
                           sections=tuple(Section.from_dict(s) for s in d["sections"]),
                           rigid=tuple(bool(s.get("rigid", False)) for s in d["sections"]))

    # -- properties -------------------------------------------------------------------------
    @property
    def sign(self) -> int:
        """+1 for a ccw crank, -1 for cw."""
        return direction_sign(self.direction)

    @property
    def shortest_link(self) -> float:
        """The shorter of crank and coupler [m] (the validity bound of :mod:`ked_quasi.limits`)."""
        return min(self.crank, self.coupler)

    def length(self, link: str) -> float:
        check_choice("link", link, SLIDER_LINKS)
        return float(getattr(self, link))

    def section(self, link: str) -> Section:
        check_choice("link", link, SLIDER_LINKS)
        return self.sections[SLIDER_LINKS.index(link)]

    def is_rigid(self, link: str) -> bool:
        check_choice("link", link, SLIDER_LINKS)
        return self.rigid[SLIDER_LINKS.index(link)]

    def link_mass(self, link: str) -> float:
        """Mass of a link from its section [kg]."""
        return self.section(link).mass_per_length * self.length(link)

    def min_transmission_deg(self) -> tuple[float, float]:
        """Smallest distance of the transmission angle from a toggle [deg] and the crank angle [deg] where it
        occurs.  The transmission angle is the angle at B between B->A and the normal of the slider line (the
        slider's counterpart of the follower): 90 deg minus the rod's inclination to the line; the largest
        inclination, asin((crank + |offset|) / coupler), is reached at crank angle 90 deg (offset <= 0) or
        270 deg (offset > 0)."""
        incl = math.degrees(math.asin((self.crank + abs(self.offset)) / self.coupler))
        return 90.0 - incl, (270.0 if self.offset > 0 else 90.0)

    def with_stiffness_scale(self, factor: float) -> SliderCrank:
        """Copy with every Young's modulus multiplied by ``factor`` (> 0)."""
        rules.STIFFNESS_SCALE.check(factor)
        return replace(self, sections=tuple(replace(s, youngs_modulus=s.youngs_modulus * factor)
                                            for s in self.sections))

    def with_direction(self, direction: str) -> SliderCrank:
        return replace(self, direction=direction)

    @property
    def kind(self) -> str:
        """The linkage kind, :data:`KIND` (every linkage type has one: :mod:`ked_quasi.kinds`)."""
        return KIND


MECHANISMS = ("source",)
"""A slider-crank's mechanisms: its source only (no Roberts cognate)."""


def slider_variant(source: SliderCrank, mechanism: str = "source", stiffness_scale: float = 1.0,
                   direction: str | None = None) -> SliderCrank:
    """The slider-crank a scene analyses (as :func:`ked_quasi.scene.variant` for a four-bar): the source (its only
    mechanism), every Young's modulus times ``stiffness_scale``, crank turning in ``direction`` (None: the
    source's).  ValueError for another mechanism."""
    if mechanism not in MECHANISMS:
        raise ValueError(f"mechanism: a slider-crank has no Roberts cognate (its only mechanism is \"source\"); "
                         f"got {mechanism!r}")
    sc = source.with_stiffness_scale(stiffness_scale) if stiffness_scale != 1.0 else source
    return sc.with_direction(direction) if direction is not None else sc


# -- the data sheet's mechanism (Simeon 1996) --------------------------------------------------
SIMEON_OMEGA = 150.0
"""Simeon's crank speed [rad/s]."""


def simeon_slider_crank() -> SliderCrank:
    """Simeon's flexible slider-crank (Test Set for IVP solvers, problem "crank"), coupler point at midspan.

    Crank: rigid, 0.15 m; its mass 0.36 kg is given by a nominal steel section (density 7870 kg/m^3, area
    0.36 / (0.15 x 7870) m^2); a rigid crank clamped at the pivot carries its own inertia to the ground,
    so its mass and inertia J1 produce no elastic deflection in the quasi-static frame.  Rod: 0.30 m,
    square 8 mm steel, E = 2e11 Pa, rho = 7870 kg/m^3 (0.151104 kg).  Slider 0.075552 kg on the line
    through the crank pivot (offset 0), crank CCW.
    """
    b = 0.008
    rod = Section(youngs_modulus=2.0e11, area=b * b, second_moment=b**4 / 12.0, density=7870.0)
    area = 0.36 / (0.15 * 7870.0)
    crank = Section(youngs_modulus=2.0e11, area=area, second_moment=area**2 / 12.0, density=7870.0)
    return SliderCrank(crank=0.15, coupler=0.30, offset=0.0, coupler_point=0.5, sections=(crank, rod),
                       rigid=(True, False), slider_mass=0.075552, direction="ccw")


# -- kinematics ---------------------------------------------------------------------------------
def _as_angles(crank_angle: np.ndarray | float) -> np.ndarray:
    theta = np.atleast_1d(np.asarray(crank_angle, dtype=float))
    if theta.ndim != 1 or not np.all(np.isfinite(theta)):
        raise ValueError("crank_angle must be a finite scalar or 1-D array of angles in rad")
    return theta


def _xy(z: np.ndarray) -> np.ndarray:
    return np.stack([z.real, z.imag], axis=-1)


@dataclass(frozen=True)
class SliderKinematics:
    """Rigid kinematics at constant crank speed ``omega`` [rad/s, signed: + for CCW], over n crank angles.

    Complex positions x + i y [m] of A, B, P (n,); their velocities [m/s] and accelerations [m/s^2];
    rod angle phi [rad] (from +x to A->B), its rate [rad/s] and angular acceleration [rad/s^2].  The
    ``*_xy`` properties give (n, 2) real arrays.
    """

    crank_angle: np.ndarray
    omega: float
    zA: np.ndarray
    zB: np.ndarray
    zP: np.ndarray
    vA: np.ndarray
    vB: np.ndarray
    vP: np.ndarray
    aA: np.ndarray
    aB: np.ndarray
    aP: np.ndarray
    rod_angle: np.ndarray
    rod_rate: np.ndarray
    rod_acceleration: np.ndarray

    A = property(lambda self: _xy(self.zA))
    B = property(lambda self: _xy(self.zB))
    P = property(lambda self: _xy(self.zP))

    def point(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Position and acceleration of rod points at fractions ``s`` from A, complex (n, len(s))."""
        s = np.atleast_1d(np.asarray(s, float))
        e = (self.zB - self.zA)[:, None]
        c = (1j * self.rod_acceleration - self.rod_rate**2)[:, None]
        return self.zA[:, None] + s * e, self.aA[:, None] + c * s * e


def slider_kinematics(sc: SliderCrank, crank_angle: np.ndarray | float, rpm: float) -> SliderKinematics:
    """Closed-form positions, velocities and accelerations at constant crank speed ``rpm`` [rev/min]."""
    theta = _as_angles(crank_angle)
    w = units.rpm_to_rad_s(float(rules.RPM.check(rpm))) * sc.sign
    l1, l2, e = sc.crank, sc.coupler, sc.offset
    sphi = (e - l1 * np.sin(theta)) / l2
    cphi = np.sqrt(1.0 - sphi**2)
    phi = np.arctan2(sphi, cphi)
    zA = l1 * np.exp(1j * theta)
    zB = zA + l2 * (cphi + 1j * sphi)
    w2 = -l1 * w * np.cos(theta) / (l2 * cphi)
    a2 = (l1 * w**2 * np.sin(theta) + l2 * sphi * w2**2) / (l2 * cphi)
    vA = 1j * w * zA
    aA = -(w**2) * zA
    rod = zB - zA
    vB = vA + 1j * w2 * rod
    aB = aA + (1j * a2 - w2**2) * rod
    k = sc.coupler_point
    return SliderKinematics(crank_angle=theta, omega=w, zA=zA, zB=zB, zP=zA + k * rod, vA=vA, vB=vB,
                            vP=vA + 1j * w2 * k * rod, aA=aA, aB=aB, aP=aA + (1j * a2 - w2**2) * k * rod,
                            rod_angle=phi, rod_rate=w2, rod_acceleration=a2)


# -- mass lumps ---------------------------------------------------------------------------------
@dataclass(frozen=True)
class SliderLumps:
    """Point masses: parallel arrays ``link`` (crank or coupler), ``s`` (fraction from the link's root: crank
    from M, coupler from A) and ``mass`` [kg].  The payload sits at the coupler point, the slider at coupler
    s = 1 (B); lumps at the pivot M are dropped (no inertia load)."""

    link: tuple[str, ...]
    s: np.ndarray
    mass: np.ndarray


def slider_lumps(sc: SliderCrank, mm: MassModel) -> SliderLumps:
    """The point masses of mass model ``mm`` (``tip``, ``joints`` or ``distributed``) on ``sc``, plus the
    slider mass at B."""
    check_choice("mass model of a slider-crank", mm.name, SLIDER_MASS_MODELS)
    out: list[tuple[str, float, float]] = []

    def add(link: str, s: float, m: float) -> None:
        if m > 0.0 and not (link == "crank" and s == 0.0):
            out.append((link, s, m))

    if mm.name == "joints":
        for lk in SLIDER_LINKS:
            add(lk, 0.0, mm.joint_split * sc.link_mass(lk))
            add(lk, 1.0, (1.0 - mm.joint_split) * sc.link_mass(lk))
    elif mm.name == "distributed":
        k = np.arange(1, mm.lumps + 1, dtype=float)
        frac = (k - 0.5) / mm.lumps if mm.placement == "midpoint" else k / mm.lumps
        for lk in SLIDER_LINKS:
            for f in frac:
                add(lk, float(f), sc.link_mass(lk) / mm.lumps)
    add("coupler", sc.coupler_point, float(mm.payload))
    add("coupler", 1.0, sc.slider_mass)
    return SliderLumps(tuple(o[0] for o in out), np.array([o[1] for o in out], float),
                       np.array([o[2] for o in out], float))


# -- scene --------------------------------------------------------------------------------------
@dataclass(frozen=True)
class SliderScene(CrankGrid):
    """One slider-crank, one mass model, one constant crank speed, one crank-angle grid.

    linkage: the :class:`SliderCrank`; mass_model: one of :data:`SLIDER_MASS_MODELS`; rpm: crank speed
    magnitude [rev/min]; step_deg: grid step [deg], dividing 360.
    """

    linkage: SliderCrank
    mass_model: MassModel
    rpm: float
    step_deg: float = 10.0

    def __post_init__(self) -> None:
        if not isinstance(self.linkage, SliderCrank):
            raise ValueError("SliderScene.linkage must be a SliderCrank")
        if not isinstance(self.mass_model, MassModel):
            raise ValueError("SliderScene.mass_model must be a MassModel")
        check_choice("mass model of a slider-crank", self.mass_model.name, SLIDER_MASS_MODELS)
        object.__setattr__(self, "rpm", rules.RPM.check(self.rpm, "SliderScene.rpm"))
        object.__setattr__(self, "step_deg", rules.check_step_deg(self.step_deg, "SliderScene.step_deg"))
        n_nodes = len(slider_lumps(self.linkage, self.mass_model).link) + 4  # lumps + A, B, P, midspan
        rules.check_work(self.n_angles, 2 * n_nodes + 1, "SliderScene.step_deg and MassModel.lumps")

    @property
    def kind(self) -> str:
        """The linkage kind, :data:`KIND` (every scene type has one)."""
        return KIND

    def to_dict(self) -> dict[str, Any]:
        """Plain dict (JSON); :meth:`from_dict` inverts it."""
        return {"slider_crank": self.linkage.to_dict(), "mass_model": self.mass_model.to_dict(), "rpm": self.rpm,
                "step_deg": self.step_deg}

    @staticmethod
    def from_dict(d: dict[str, Any]) -> SliderScene:
        return SliderScene(SliderCrank.from_dict(d["slider_crank"]), MassModel.from_dict(d["mass_model"]), d["rpm"],
                           d["step_deg"])


def build_slider_scene(sc: SliderCrank, mass_model: str = "distributed", rpm: float = 300.0, step_deg: float = 10.0,
                       lumps: int = 5, payload: float | None = None, stiffness_scale: float = 1.0,
                       direction: str | None = None) -> SliderScene:
    """A slider-crank scene from plain parameters (the command line's construction)."""
    if stiffness_scale != 1.0:
        sc = sc.with_stiffness_scale(stiffness_scale)
    if direction is not None:
        sc = sc.with_direction(direction)
    mm = MassModel(mass_model, lumps=lumps, payload=default_payload(mass_model) if payload is None else payload)
    return SliderScene(sc, mm, rpm, step_deg)


# -- linkage TOML table ------------------------------------------------------------------------
TABLE_KEYS = ("kind", "crank", "coupler", "offset", "coupler_point", "slider_mass", "direction", "section",
              "sections")
SECTION_KEYS = (*SECTION_RULES, "rigid")


PRESET_KINDS = {"thesis": "four-bar", "simeon": KIND}
"""The kind of each linkage preset a ``[linkage]`` table may name (``preset = ...``)."""


def kind_conflict(tab: Any) -> str:
    """The problem of a ``[linkage]`` table whose ``preset`` and ``kind`` name different kinds of linkage
    (empty when they agree or either is absent)."""
    if not isinstance(tab, dict):
        return ""
    preset, kind = tab.get("preset"), tab.get("kind")
    own = PRESET_KINDS.get(preset) if isinstance(preset, str) else None
    if own is None or kind is None or kind == own:
        return ""
    return (f"linkage.preset = {preset!r} is a {own} but linkage.kind = {kind!r}: the keys preset and kind "
            f"conflict; drop kind (or write kind = {own!r})")


def is_slider_table(tab: Any) -> bool:
    """Whether a ``[linkage]`` table declares a slider-crank: ``kind = "slider-crank"`` or the preset
    ``"simeon"`` (without a conflicting kind, :func:`kind_conflict`)."""
    if not isinstance(tab, dict):
        return False
    return tab.get("kind") == KIND or (tab.get("preset") == "simeon" and not kind_conflict(tab))


def slider_from_table(tab: dict[str, Any]) -> SliderCrank:
    """A ``[linkage]`` table with ``kind = "slider-crank"`` -> :class:`SliderCrank`; ValueError naming the
    TOML path otherwise.  Keys: crank, coupler [m], offset [m] (default 0), coupler_point (default 0.5),
    slider_mass [kg] (default 0), direction (default ccw), ``[linkage.section]`` (all links) and
    ``[linkage.sections.crank|coupler]`` (overrides, each may set ``rigid = true``)."""
    unknown = sorted(set(tab) - set(TABLE_KEYS))
    if unknown:
        raise ValueError(f"linkage: unknown key(s) {', '.join(unknown)} for kind = \"{KIND}\"; allowed: "
                         f"{', '.join(TABLE_KEYS)}")
    for key in ("crank", "coupler"):
        if key not in tab:
            raise ValueError(f"linkage.{key}: missing (the {key} length in m)")
    common = tab.get("section", {})
    per = tab.get("sections", {})
    if not isinstance(common, dict) or not isinstance(per, dict):
        raise ValueError("linkage.section and linkage.sections must be tables")
    bad = sorted(set(per) - set(SLIDER_LINKS))
    if bad:
        raise ValueError(f"linkage.sections: unknown link(s) {', '.join(bad)}; a slider-crank has "
                         f"{', '.join(SLIDER_LINKS)}")
    sections, rigid = [], []
    for link in SLIDER_LINKS:
        own = per.get(link, {})
        if not isinstance(own, dict):
            raise ValueError(f"linkage.sections.{link} must be a table")
        for path, t in ((f"linkage.sections.{link}", own), ("linkage.section", common)):
            extra = sorted(set(t) - set(SECTION_KEYS))
            if extra:
                raise ValueError(f"{path}: unknown key(s) {', '.join(extra)}; allowed: {', '.join(SECTION_KEYS)}")
        props = {}
        for key, rule in rules.USER_SECTION_RULES.items():  # the plausibility bounds of a user's material
            src, path = (own, f"linkage.sections.{link}") if key in own else (common, "linkage.section")
            if key not in src:
                raise ValueError(f"linkage.section.{key}: missing for the {link} (in [linkage.section] or "
                                 f"[linkage.sections.{link}])")
            props[key] = rule.check(src[key], f"{path}.{key}")
        flag = own.get("rigid", common.get("rigid", False))
        if not isinstance(flag, bool):
            raise ValueError(f"linkage.sections.{link}.rigid: must be true or false; got {flag!r}")
        sections.append(Section(**props))
        rigid.append(flag)
    direction = tab.get("direction", "ccw")
    check_choice("linkage.direction", direction, DIRECTIONS)
    return SliderCrank(crank=rules.LENGTH.check(tab["crank"], "linkage.crank"),
                       coupler=rules.LENGTH.check(tab["coupler"], "linkage.coupler"),
                       offset=rules.OFFSET.check(tab.get("offset", 0.0), "linkage.offset"),
                       coupler_point=rules.COUPLER_POINT.check(tab.get("coupler_point", 0.5), "linkage.coupler_point"),
                       slider_mass=rules.SLIDER_MASS_KG.check(tab.get("slider_mass", 0.0), "linkage.slider_mass"),
                       direction=direction, sections=tuple(sections), rigid=tuple(rigid))
