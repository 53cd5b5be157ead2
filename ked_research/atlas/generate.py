"""The atlas's linkages: a documented, seeded sample of crank-driven four-bars (pure).

Candidate ``i`` of seed ``s`` is drawn from its own generator ``numpy.random.default_rng([s, i])``, so a
candidate never depends on the others and ``generate(n, s)`` is a prefix of ``generate(m, s)`` for
m > n (an atlas grows without changing the linkages it already has).  Every draw (:data:`RANGES`):

* ground |MQ| [m]: log-uniform; M = (0, 0), Q = (ground, 0); crank turning ccw;
* crank/ground, coupler/ground, follower/ground: uniform; only Grashof crank-rockers are kept (crank the
  shortest link, s + l < p + q, margin :attr:`Ranges.grashof_margin`);
* coupler point: extender/coupler uniform, coupler angle uniform over a full turn; branch open or crossed;
* section (one for all links, as a Roberts cognate needs): steel (E 210 GPa, 7850 kg/m^3) or aluminium
  (70 GPa, 2700 kg/m^3); round rod or rectangular bar (in-plane depth h, width b = aspect * h);
  size from the ground slenderness ground / radius of gyration, log-uniform;
* payload at P: tip model payload/link mass log-uniform; the other models carry the same payload with
  probability 1/2 (else none).

A candidate that does not assemble over a full turn, is not a crank-rocker, is near toggle (minimum
transmission angle below :attr:`Ranges.min_transmission_deg`), or breaks a rule of ``ked_quasi.rules``
is a :class:`Reject` with its reason.  An accepted linkage's crossed Roberts cognate is analysed too
when it is crank-drivable and not near toggle; otherwise the reason is kept.  SI units.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from ked_quasi.kinematics import kinematics
from ked_quasi.linkage import FourBar, Section
from ked_quasi.massmodel import MASS_MODELS, MassModel
from ked_quasi.scene import variant

MATERIALS = {"steel": (210e9, 7850.0), "aluminium": (70e9, 2700.0)}
"""Material -> (Young's modulus [Pa], density [kg/m^3])."""
SHAPES = ("rod", "bar")


@dataclass(frozen=True)
class Ranges:
    """The sampled ranges (lo, hi) and the acceptance bounds."""

    ground_m: tuple[float, float] = (0.1, 1.0)
    crank_ratio: tuple[float, float] = (0.10, 0.45)
    coupler_ratio: tuple[float, float] = (0.5, 2.0)
    follower_ratio: tuple[float, float] = (0.4, 1.8)
    extender_ratio: tuple[float, float] = (0.2, 1.5)
    coupler_angle_deg: tuple[float, float] = (-180.0, 180.0)
    slenderness: tuple[float, float] = (40.0, 600.0)
    bar_aspect: tuple[float, float] = (0.5, 4.0)
    payload_ratio: tuple[float, float] = (0.1, 3.0)
    grashof_margin: float = 0.02
    min_transmission_deg: float = 20.0


RANGES = Ranges()


@dataclass(frozen=True)
class Design:
    """The drawn parameters of one candidate (lengths as ratios of the ground, see :class:`Ranges`)."""

    index: int
    ground_m: float
    crank_ratio: float
    coupler_ratio: float
    follower_ratio: float
    extender_ratio: float
    coupler_angle_deg: float
    branch: str
    material: str
    shape: str
    slenderness: float
    bar_aspect: float
    payload_ratio: float
    payload_all: bool


@dataclass(frozen=True)
class Linkage:
    """An accepted candidate: its source four-bar, the mechanisms to analyse, its mass models and
    features.  ``min_transmission_deg``: smallest transmission angle over the cycle (distance from a
    toggle, 0..90 deg) of the source; ``cognate_reason``: why the cognate is left out ("" if it is in)."""

    design: Design
    fourbar: FourBar
    mechanisms: tuple[str, ...]
    mass_models: tuple[MassModel, ...]
    min_transmission_deg: float
    cognate_min_transmission_deg: float
    cognate_reason: str

    @property
    def index(self) -> int:
        return self.design.index

    @property
    def source(self) -> FourBar:
        """The analysed source linkage."""
        return self.fourbar


@dataclass(frozen=True)
class Reject:
    """A candidate left out, and why."""

    design: Any  # the Design of its linkage kind's generator
    reason: str

    @property
    def index(self) -> int:
        return self.design.index


@dataclass(frozen=True)
class Sample:
    """``generate``'s answer: accepted linkages and rejects, both by candidate index."""

    seed: int
    linkages: tuple[Any, ...]  # Linkage of its kind's generator
    rejects: tuple[Reject, ...]


def log_uniform(rng: np.random.Generator, lo_hi: tuple[float, float]) -> float:
    """A draw log-uniform on ``lo_hi``."""
    return float(math.exp(rng.uniform(math.log(lo_hi[0]), math.log(lo_hi[1]))))


def draw(seed: int, index: int, ranges: Ranges = RANGES) -> Design:
    """The parameters of candidate ``index`` (its own generator, see the module docstring)."""
    rng = np.random.default_rng([seed, index])
    u = rng.uniform
    return Design(
        index=index, ground_m=log_uniform(rng, ranges.ground_m), crank_ratio=float(u(*ranges.crank_ratio)),
        coupler_ratio=float(u(*ranges.coupler_ratio)), follower_ratio=float(u(*ranges.follower_ratio)),
        extender_ratio=float(u(*ranges.extender_ratio)), coupler_angle_deg=float(u(*ranges.coupler_angle_deg)),
        branch=str(rng.choice(["open", "crossed"])), material=str(rng.choice(list(MATERIALS))),
        shape=str(rng.choice(SHAPES)), slenderness=log_uniform(rng, ranges.slenderness),
        bar_aspect=float(u(*ranges.bar_aspect)), payload_ratio=log_uniform(rng, ranges.payload_ratio),
        payload_all=bool(rng.uniform() < 0.5),
    )


def section(d: Design) -> Section:
    """The common section: radius of gyration ground / slenderness; rod d = 4 r_g, bar h = sqrt(12) r_g."""
    return round_or_bar(d.material, d.shape, d.ground_m / d.slenderness, d.bar_aspect)


def round_or_bar(material: str, shape: str, rg: float, bar_aspect: float) -> Section:
    """A section of ``material`` with radius of gyration ``rg`` [m]: a round rod (d = 4 rg) or a bar
    (in-plane depth h = sqrt(12) rg, width ``bar_aspect`` x h)."""
    E, rho = MATERIALS[material]
    if shape == "rod":
        dia = 4.0 * rg
        return Section(E, math.pi * dia**2 / 4.0, math.pi * dia**4 / 64.0, rho)
    h = math.sqrt(12.0) * rg
    b = bar_aspect * h
    return Section(E, b * h, b * h**3 / 12.0, rho)


def fourbar(d: Design) -> FourBar:
    """The source four-bar of a design (ValueError if it breaks a rule or cannot assemble)."""
    g = d.ground_m
    return FourBar(crank=d.crank_ratio * g, coupler=d.coupler_ratio * g, follower=d.follower_ratio * g,
                   extender=d.extender_ratio * d.coupler_ratio * g, coupler_angle=math.radians(d.coupler_angle_deg),
                   sections=(section(d),) * 4, crank_pivot=(0.0, 0.0), follower_pivot=(g, 0.0), branch=d.branch,
                   check_toggle=False)  # the sampler applies its own, stricter toggle bound (candidate)


def crank_rocker_problem(d: Design, margin: float) -> str:
    """Why the lengths are not a Grashof crank-rocker with ``margin`` (fractions of the ground), or ""."""
    c, a, b = d.crank_ratio, d.coupler_ratio, d.follower_ratio
    if c >= min(a, b, 1.0):
        return "not a crank-rocker: the crank is not the shortest link"
    if c + max(a, b, 1.0) > sum(sorted((a, b, 1.0))[:2]) - margin:
        return f"not a Grashof crank-rocker with margin {margin:g} (s + l >= p + q - margin)"
    return ""


def min_transmission_deg(fb: FourBar, n: int = 360) -> float:
    """Smallest distance of the transmission angle from a toggle (0 or 180 deg) over a turn [deg]."""
    mu = kinematics(fb, np.arange(n) * (2.0 * np.pi / n), 1.0).transmission_angle
    return float(np.degrees(np.min(np.minimum(mu, np.pi - mu))))


def mass_models(d: Design, fb: FourBar) -> tuple[MassModel, ...]:
    """The four mass models; the payload at P is ``payload_ratio`` x the link mass (always for tip)."""
    link_mass = sum(fb.link_mass(lk) for lk in ("crank", "coupler", "extender", "follower"))
    payload = d.payload_ratio * link_mass
    return tuple(MassModel(name, payload=payload if name == "tip" or d.payload_all else 0.0) for name in MASS_MODELS)


def _cognate(fb: FourBar, bound: float) -> tuple[float, str]:
    try:
        cog = variant(fb, "cognate")
    except ValueError as exc:
        return math.nan, str(exc)
    mu = min_transmission_deg(cog)
    return mu, "" if mu >= bound else f"cognate near toggle: min transmission angle {mu:.1f} deg < {bound:g} deg"


def candidate(seed: int, index: int, ranges: Ranges = RANGES) -> Linkage | Reject:
    """Draw candidate ``index`` and accept or reject it (see the module docstring)."""
    d = draw(seed, index, ranges)
    problem = crank_rocker_problem(d, ranges.grashof_margin)
    if problem:
        return Reject(d, problem)
    try:
        fb = fourbar(d)
        mms = mass_models(d, fb)
    except ValueError as exc:
        return Reject(d, str(exc))
    mu = min_transmission_deg(fb)
    if mu < ranges.min_transmission_deg:
        return Reject(d, f"near toggle: min transmission angle {mu:.1f} deg < {ranges.min_transmission_deg:g} deg")
    mu_c, why = _cognate(fb, ranges.min_transmission_deg)
    mechs = ("source",) if why else ("source", "cognate")
    return Linkage(d, fb, mechs, mms, mu, mu_c, why)


def generate(n: int, seed: int = 0, ranges: Ranges = RANGES, max_candidates: int | None = None) -> Sample:
    """The first ``n`` accepted linkages of ``seed`` and every reject drawn on the way."""
    return accept_first(lambda i: candidate(seed, i, ranges), n, seed, max_candidates)


def accept_first(draw_one: Callable[[int], Any], n: int, seed: int, max_candidates: int | None = None) -> Sample:
    """The first ``n`` accepted candidates ``draw_one(0), draw_one(1), ...`` (a linkage or a :class:`Reject`)
    and every reject drawn on the way (any linkage kind's generator)."""
    if n < 0:
        raise ValueError(f"n must be >= 0; got {n}")
    cap = 50 * n + 100 if max_candidates is None else max_candidates
    ok: list[Any] = []
    bad: list[Reject] = []
    index = 0
    while len(ok) < n:
        if index >= cap:
            raise ValueError(f"only {len(ok)} of {n} linkages accepted in {cap} candidates")
        c = draw_one(index)
        (bad if isinstance(c, Reject) else ok).append(c)
        index += 1
    return Sample(seed, tuple(ok), tuple(bad))


def ranges_dict(ranges: Ranges = RANGES) -> dict:
    """The ranges as a JSON-able dict (stored with the atlas)."""
    return {**asdict(ranges), "materials": {k: list(v) for k, v in MATERIALS.items()}, "shapes": list(SHAPES)}
