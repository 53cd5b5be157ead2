"""The linkage model shared by every solver: link sections and the four-bar, SI units.

Frame and conventions (used everywhere in the harness):

* global planar frame x, y; crank pivot M, follower pivot Q (ground is rigid);
* crank angle ``theta``: angle of the crank M->A measured counter-clockwise from the ground
  line M->Q; the same definition for every four-bar, source or cognate;
* coupler point P = A + extender * (unit vector of A->B rotated CCW by ``coupler_angle``);
* ``branch`` "open": B lies to the left of the line A->Q (cross(Q-A, B-A) > 0), "crossed": to the
  right; a four-bar keeps its branch over a full turn unless it passes a toggle;
* ``direction`` "ccw"/"cw": sign of the constant crank speed (theta increases / decreases in time).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from . import rules, units
from .rules import check_choice

LINKS = ("crank", "coupler", "extender", "follower")
LENGTHS = ("crank", "coupler", "follower", "extender")
BRANCHES = ("open", "crossed")
DIRECTIONS = ("ccw", "cw")


SECTION_RULES = {"youngs_modulus": rules.YOUNGS_MODULUS, "area": rules.AREA,
                 "second_moment": rules.SECOND_MOMENT, "density": rules.DENSITY}
"""Field of :class:`Section` -> its rule (also the order of the serialized fields)."""


@dataclass(frozen=True)
class Section:
    """Uniform cross-section and material of one link.

    youngs_modulus [Pa], area [m^2], second_moment (about the axis normal to the plane) [m^4],
    density [kg/m^3]; fibre_distance [m]: the distance c of the extreme fibres from the neutral axis (for the
    bending stress M c / I); None (default) takes the solid circle of the section's A and I, r = 2 sqrt(I/A)
    (:attr:`extreme_fibre`).  A given c must be at least the radius of gyration sqrt(I/A) (no section has all
    its area closer to the axis than that).
    """

    youngs_modulus: float
    area: float
    second_moment: float
    density: float
    fibre_distance: float | None = None

    def __post_init__(self) -> None:
        for name, rule in SECTION_RULES.items():
            object.__setattr__(self, name, rule.check(getattr(self, name), f"Section.{name}"))
        if self.fibre_distance is not None:
            c = rules.FIBRE_DISTANCE.check(self.fibre_distance, "Section.fibre_distance")
            gyration = math.sqrt(self.second_moment / self.area)
            if c < gyration * (1.0 - 1e-12):
                raise ValueError(
                    f"Section.fibre_distance: {c:g} m is less than the radius of gyration sqrt(I/A) = {gyration:g} m "
                    "of this section (I <= A c^2 for any section); allowed: a distance in m from the neutral axis "
                    "to the extreme fibre, at least sqrt(second_moment / area)")
            object.__setattr__(self, "fibre_distance", c)

    def to_dict(self) -> dict[str, float]:
        """Plain dict (TOML, JSON, HDF5 attributes); :meth:`from_dict` inverts it (``fibre_distance`` only
        when given)."""
        d = {name: getattr(self, name) for name in SECTION_RULES}
        if self.fibre_distance is not None:
            d["fibre_distance"] = self.fibre_distance
        return d

    @staticmethod
    def from_dict(d: dict[str, Any]) -> Section:
        return Section(**{name: d[name] for name in SECTION_RULES}, fibre_distance=d.get("fibre_distance"))

    @property
    def extreme_fibre(self) -> float:
        """c [m]: ``fibre_distance``, or the solid circle's radius r = 2 sqrt(I/A) (I = pi r^4/4, A = pi r^2)."""
        if self.fibre_distance is not None:
            return self.fibre_distance
        return 2.0 * math.sqrt(self.second_moment / self.area)

    @property
    def section_modulus(self) -> float:
        """I / c [m^3]."""
        return self.second_moment / self.extreme_fibre

    @property
    def mass_per_length(self) -> float:
        """kg/m."""
        return self.density * self.area

    @property
    def axial_stiffness(self) -> float:
        """EA [N]."""
        return self.youngs_modulus * self.area

    @property
    def bending_stiffness(self) -> float:
        """EI [N m^2]."""
        return self.youngs_modulus * self.second_moment


KIND = "four-bar"
"""The linkage kind of a :class:`FourBar` and its scenes (the slider-crank's: :data:`ked_quasi.slidercrank.KIND`)."""


@dataclass(frozen=True)
class FourBar:
    """A planar four-bar with a coupler point, its assembly branch and elastic links (SI units).

    Lengths in m, ``coupler_angle`` in rad (CCW from A->B to A->P), pivots in m in the global
    frame, ``sections`` in the order of :data:`LINKS`.  Construction validates every value and,
    unless ``full_turn`` is False (a rocker-driven linkage such as a double-rocker cognate, which no
    crank-driven solver accepts), that the linkage assembles at every crank angle of a full turn and
    stays at least :data:`~ked_quasi.rules.MIN_TRANSMISSION_DEG` from a toggle (change-point and
    near-change-point linkages are refused).  ``check_toggle=False`` skips the toggle check only to study
    the solvers at a toggle (no loader sets it; it is not serialized).
    """

    crank: float
    coupler: float
    follower: float
    extender: float
    coupler_angle: float
    sections: tuple[Section, Section, Section, Section]
    crank_pivot: tuple[float, float] = (0.0, 0.0)
    follower_pivot: tuple[float, float] = (1.0, 0.0)
    branch: str = "open"
    direction: str = "ccw"
    full_turn: bool = True
    check_toggle: bool = field(default=True, compare=False, repr=False)
    _ground: float = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        for name in LENGTHS:
            object.__setattr__(self, name, rules.LENGTH.check(getattr(self, name), f"FourBar.{name}"))
        angle = rules.COUPLER_ANGLE.check(self.coupler_angle, "FourBar.coupler_angle")
        object.__setattr__(self, "coupler_angle", angle)
        for name in ("crank_pivot", "follower_pivot"):
            p = getattr(self, name)
            if not isinstance(p, (tuple, list, np.ndarray)) or len(p) != 2:
                raise ValueError(f"FourBar.{name} must be an (x, y) pair in m, got {p!r}")
            xy = tuple(float(rules.COORDINATE.check(c, f"FourBar.{name}[{i}]")) for i, c in enumerate(p))
            object.__setattr__(self, name, xy)
        check_choice("FourBar.branch", self.branch, BRANCHES)
        check_choice("FourBar.direction", self.direction, DIRECTIONS)
        if len(self.sections) != 4 or not all(isinstance(s, Section) for s in self.sections):
            raise ValueError("FourBar.sections must be four Section objects (crank, coupler, extender, follower)")
        object.__setattr__(self, "sections", tuple(self.sections))
        ground = math.dist(self.crank_pivot, self.follower_pivot)
        if not ground > 0.0:
            raise ValueError("FourBar.follower_pivot must differ from crank_pivot (ground length must be > 0)")
        rules.LENGTH.check(ground, "FourBar.ground (|follower_pivot - crank_pivot|)")
        object.__setattr__(self, "_ground", ground)
        failing = self.failing_angles()
        if failing.size and self.full_turn:
            deg = np.degrees(failing)
            raise ValueError(
                "FourBar cannot assemble over a full crank turn "
                f"(Grashof class: {self.grashof_class}; crank={self.crank:g} m, coupler={self.coupler:g} m, "
                f"follower={self.follower:g} m, ground={self.ground:g} m): no position of B for crank angles "
                f"{deg.min():.1f}..{deg.max():.1f} deg ({failing.size} of 3600 checked). "
                "The crank can turn fully only if coupler+follower >= ground+crank and "
                "|coupler-follower| <= |ground-crank|."
            )
        if self.full_turn and self.check_toggle:
            mu, at = self.min_transmission_deg()
            rules.check_transmission(mu, "FourBar", at, f"crank={self.crank:g} m, coupler={self.coupler:g} m, "
                                     f"follower={self.follower:g} m, ground={self.ground:g} m")

    # -- serialization ----------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """Plain dict (TOML, JSON, HDF5 attributes): lengths [m], coupler_angle [rad], pivots [m],
        branch, direction, sections (list in :data:`LINKS` order); :meth:`from_dict` inverts it."""
        return {
            **{name: getattr(self, name) for name in (*LENGTHS, "coupler_angle")},
            "crank_pivot": list(self.crank_pivot), "follower_pivot": list(self.follower_pivot),
            "branch": self.branch, "direction": self.direction,
            "sections": [s.to_dict() for s in self.sections],
        }

    @staticmethod
    def from_dict(d: dict[str, Any], full_turn: bool = True) -> FourBar:
        """Inverse of :meth:`to_dict` (``direction`` defaults to ccw when absent); ``full_turn=False``
        reads a linkage that cannot be crank-driven (e.g. a stored failed scene) without refusing it."""
        return FourBar(
            **{name: d[name] for name in (*LENGTHS, "coupler_angle")},
            crank_pivot=tuple(d["crank_pivot"]), follower_pivot=tuple(d["follower_pivot"]),
            branch=d["branch"], direction=d.get("direction", "ccw"),
            sections=tuple(Section.from_dict(s) for s in d["sections"]), full_turn=full_turn,
        )

    # -- geometry ---------------------------------------------------------------------------
    @property
    def sign(self) -> int:
        """+1 for a ccw crank, -1 for cw: the sign of the crank speed."""
        return direction_sign(self.direction)

    @property
    def ground(self) -> float:
        """Ground length |MQ| [m]."""
        return self._ground

    @property
    def ground_angle(self) -> float:
        """Angle of M->Q from the global x axis [rad]."""
        return math.atan2(self.follower_pivot[1] - self.crank_pivot[1],
                          self.follower_pivot[0] - self.crank_pivot[0])

    def length(self, link: str) -> float:
        """Length of a link [m]; ``link`` in :data:`LINKS`."""
        check_choice("link", link, LINKS)
        return float(getattr(self, link))

    def section(self, link: str) -> Section:
        check_choice("link", link, LINKS)
        return self.sections[LINKS.index(link)]

    def link_mass(self, link: str) -> float:
        """Mass of a link from its section [kg]."""
        return self.section(link).mass_per_length * self.length(link)

    @property
    def grashof_class(self) -> str:
        """Grashof classification of the four lengths (crank, coupler, follower, ground)."""
        return grashof_class(self.crank, self.coupler, self.follower, self.ground)

    def failing_angles(self, n: int = 3600) -> np.ndarray:
        """Crank angles [rad] of an n-point full-turn grid at which B cannot be placed."""
        theta = np.arange(n) * (2.0 * np.pi / n)
        d = np.sqrt(self.crank**2 + self.ground**2 - 2.0 * self.crank * self.ground * np.cos(theta))
        tol = 1e-12 * (self.coupler + self.follower)
        bad = (d > self.coupler + self.follower + tol) | (d < abs(self.coupler - self.follower) - tol)
        return theta[bad]

    def min_transmission_deg(self, n: int = 3600) -> tuple[float, float]:
        """Smallest distance of the transmission angle mu from a toggle, min(mu, 180 - mu) [deg], over an
        n-point full-turn grid, and the crank angle [deg] where it occurs.  mu is the angle at B between
        B->A and B->Q (law of cosines in triangle A-B-Q; the same on both branches)."""
        theta = np.arange(n) * (2.0 * np.pi / n)
        d2 = self.crank**2 + self.ground**2 - 2.0 * self.crank * self.ground * np.cos(theta)
        cos_mu = np.clip((self.coupler**2 + self.follower**2 - d2) / (2.0 * self.coupler * self.follower), -1.0, 1.0)
        dist = 90.0 - np.degrees(np.arcsin(np.abs(cos_mu)))  # min(mu, 180 - mu)
        i = int(np.argmin(dist))
        return float(dist[i]), float(np.degrees(theta[i]))

    # -- variants ---------------------------------------------------------------------------
    def with_stiffness_scale(self, factor: float) -> FourBar:
        """Copy with every Young's modulus multiplied by ``factor`` (> 0)."""
        rules.STIFFNESS_SCALE.check(factor)
        secs = tuple(replace(s, youngs_modulus=s.youngs_modulus * factor) for s in self.sections)
        return replace(self, sections=secs)

    def with_direction(self, direction: str) -> FourBar:
        return replace(self, direction=direction)

    @property
    def kind(self) -> str:
        """The linkage kind, :data:`KIND` (every linkage type has one: :mod:`ked_quasi.kinds`)."""
        return KIND



def direction_sign(direction: str) -> int:
    """+1 for "ccw", -1 for "cw": the sign of the crank speed (theta grows / falls with time)."""
    return 1 if check_choice("direction", direction, DIRECTIONS) == "ccw" else -1


def grashof_class(crank: float, coupler: float, follower: float, ground: float) -> str:
    """Grashof class of a four-bar from its link lengths (any consistent unit)."""
    lengths = {"crank": crank, "coupler": coupler, "follower": follower, "ground": ground}
    s_name = min(lengths, key=lengths.get)
    vals = sorted(lengths.values())
    s, p, q, l_ = vals
    lhs, rhs = s + l_, p + q
    if math.isclose(lhs, rhs, rel_tol=1e-12):
        return "change-point (s+l = p+q)"
    if lhs > rhs:
        return "non-Grashof triple-rocker (s+l > p+q)"
    kind = {"crank": "crank-rocker", "ground": "double-crank (drag-link)",
            "coupler": "Grashof double-rocker", "follower": "rocker-crank"}[s_name]
    return f"{kind} (Grashof, s+l < p+q)"


# -- the thesis's numerical example -------------------------------------------------------------
THESIS_RPM = 300.0
THESIS_TIP_MASS_KG = 2.0 * units.POUND_MASS  # "Mass at coupler point for Case I: 2 lb"

THESIS_SECTION = Section(
    youngs_modulus=10e6 * units.PSI,  # aluminium, 1e7 psi
    area=0.19634 * units.INCH**2,  # 0.5 in diameter round bar
    second_moment=0.0030679615 * units.INCH**4,
    density=0.098 * units.POUND_MASS / units.INCH**3,  # 0.098 lb/in^3
)


def thesis_fourbar() -> FourBar:
    """The thesis's numerical example (Ali 1977, Fig. 13a), converted to SI.

    L1 = 10 in crank, L3 = 30 in coupler, L2 = 10 in extender, L4 = 25 in follower, L5 = 30 in ground,
    alpha = 60 deg, all links 0.5 in round aluminium bar.  Frame: M at the origin, Q on +x, open branch,
    crank CCW (this frame reproduces the published rigid X, Y columns of Table I).
    """
    i = units.INCH
    return FourBar(
        crank=10 * i, coupler=30 * i, follower=25 * i, extender=10 * i,
        coupler_angle=math.radians(60.0),
        sections=(THESIS_SECTION,) * 4,
        crank_pivot=(0.0, 0.0), follower_pivot=(30 * i, 0.0),
        branch="open", direction="ccw",
    )
