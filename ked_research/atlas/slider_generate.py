"""The slider atlas's linkages: a documented, seeded sample of crank-driven slider-cranks (pure).

Candidate ``i`` of seed ``s`` is drawn from its own generator ``numpy.random.default_rng([s, i])``, so
``generate(n, s)`` is a prefix of ``generate(m, s)`` for m > n, as in :mod:`ked_research.atlas.generate`.
Every draw (:data:`RANGES`):

* crank [m]: log-uniform; crank/rod ratio lambda: log-uniform (the rod = crank / lambda);
* slider-line offset: uniform fraction of the rod (0: an in-line slider-crank);
* coupler point P: uniform fraction of the rod from the crank pin (the model keeps P on the rod);
* section (one for crank and rod): steel (E 210 GPa, 7850 kg/m^3) or aluminium (70 GPa, 2700 kg/m^3);
  round rod or rectangular bar (in-plane depth h, width b = aspect * h); size from the rod's slenderness
  rod / radius of gyration, log-uniform; the crank is rigid with probability 1/2 (as in Simeon's
  benchmark: its mass, not its flexibility, is modelled);
* payload at P: tip model payload/link mass log-uniform; the other models carry the same payload with
  probability 1/2 (else none); slider mass / rod mass log-uniform.

A candidate the model refuses (``ked_quasi.slidercrank.SliderCrank``'s rules: the crank must turn fully,
the transmission angle stay away from a toggle) or whose minimum transmission angle is below
:attr:`Ranges.min_transmission_deg` is a :class:`~ked_research.atlas.generate.Reject` with its reason.  A
slider-crank has one mechanism ("source": it has no Roberts cognate) and the mass models
:data:`~ked_quasi.slidercrank.SLIDER_MASS_MODELS`.  SI units.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from ked_quasi.massmodel import MassModel
from ked_quasi.slidercrank import SLIDER_MASS_MODELS, SliderCrank
from ked_research.atlas.generate import MATERIALS, SHAPES, Reject, Sample, log_uniform, round_or_bar

MECHANISMS = ("source",)
"""A slider-crank's mechanisms (it has no Roberts cognate)."""


@dataclass(frozen=True)
class Ranges:
    """The sampled ranges (lo, hi) and the acceptance bound."""

    crank_m: tuple[float, float] = (0.05, 0.5)
    crank_rod_ratio: tuple[float, float] = (0.15, 0.45)
    offset_ratio: tuple[float, float] = (0.0, 0.1)
    coupler_point: tuple[float, float] = (0.2, 0.8)
    slenderness: tuple[float, float] = (40.0, 600.0)
    bar_aspect: tuple[float, float] = (0.5, 4.0)
    payload_ratio: tuple[float, float] = (0.1, 3.0)
    slider_ratio: tuple[float, float] = (0.1, 3.0)
    rigid_crank_probability: float = 0.5
    min_transmission_deg: float = 20.0


RANGES = Ranges()


@dataclass(frozen=True)
class Design:
    """The drawn parameters of one candidate (rod and offset as ratios, see :class:`Ranges`)."""

    index: int
    crank_m: float
    crank_rod_ratio: float
    offset_ratio: float
    coupler_point: float
    material: str
    shape: str
    slenderness: float
    bar_aspect: float
    payload_ratio: float
    payload_all: bool
    slider_ratio: float
    rigid_crank: bool


@dataclass(frozen=True)
class Linkage:
    """An accepted slider-crank: its design, the model, its mechanisms and mass models, and its minimum
    transmission angle (distance from a toggle, 0..90 deg)."""

    design: Design
    slider: SliderCrank
    mechanisms: tuple[str, ...]
    mass_models: tuple[MassModel, ...]
    min_transmission_deg: float

    @property
    def index(self) -> int:
        return self.design.index

    @property
    def source(self) -> SliderCrank:
        """The analysed source linkage."""
        return self.slider


def draw(seed: int, index: int, ranges: Ranges = RANGES) -> Design:
    """The parameters of candidate ``index`` (its own generator, see the module docstring)."""
    rng = np.random.default_rng([seed, index])
    u = rng.uniform
    return Design(
        index=index, crank_m=log_uniform(rng, ranges.crank_m), crank_rod_ratio=log_uniform(rng, ranges.crank_rod_ratio),
        offset_ratio=float(u(*ranges.offset_ratio)), coupler_point=float(u(*ranges.coupler_point)),
        material=str(rng.choice(list(MATERIALS))), shape=str(rng.choice(SHAPES)),
        slenderness=log_uniform(rng, ranges.slenderness), bar_aspect=float(u(*ranges.bar_aspect)),
        payload_ratio=log_uniform(rng, ranges.payload_ratio), payload_all=bool(u() < 0.5),
        slider_ratio=log_uniform(rng, ranges.slider_ratio), rigid_crank=bool(u() < ranges.rigid_crank_probability),
    )


def slider_crank(d: Design) -> SliderCrank:
    """The slider-crank of a design (ValueError naming the parameter if the model refuses it)."""
    rod = d.crank_m / d.crank_rod_ratio
    sec = round_or_bar(d.material, d.shape, rod / d.slenderness, d.bar_aspect)
    rod_mass = sec.density * sec.area * rod
    return SliderCrank(crank=d.crank_m, coupler=rod, offset=d.offset_ratio * rod, coupler_point=d.coupler_point,
                       sections=(sec, sec), rigid=(d.rigid_crank, False), slider_mass=d.slider_ratio * rod_mass)


def mass_models(d: Design, sc: SliderCrank) -> tuple[MassModel, ...]:
    """The slider mass models; the payload at P is ``payload_ratio`` x the link mass (always for tip)."""
    payload = d.payload_ratio * sum(sc.link_mass(lk) for lk in ("crank", "coupler"))
    return tuple(MassModel(name, payload=payload if name == "tip" or d.payload_all else 0.0)
                 for name in SLIDER_MASS_MODELS)


def candidate(seed: int, index: int, ranges: Ranges = RANGES) -> Linkage | Reject:
    """Draw candidate ``index`` and accept or reject it (see the module docstring)."""
    d = draw(seed, index, ranges)
    try:
        sc = slider_crank(d)
        mms = mass_models(d, sc)
    except ValueError as exc:
        return Reject(d, str(exc))
    mu, _ = sc.min_transmission_deg()
    if mu < ranges.min_transmission_deg:
        return Reject(d, f"near toggle: min transmission angle {mu:.1f} deg < {ranges.min_transmission_deg:g} deg")
    return Linkage(d, sc, MECHANISMS, mms, float(mu))


def generate(n: int, seed: int = 0, ranges: Ranges = RANGES, max_candidates: int | None = None) -> Sample:
    """The first ``n`` accepted slider-cranks of ``seed`` and every reject drawn on the way."""
    from ked_research.atlas.generate import accept_first

    return accept_first(lambda i: candidate(seed, i, ranges), n, seed, max_candidates)


def ranges_dict(ranges: Ranges = RANGES) -> dict:
    """The ranges as a JSON-able dict (stored with the slider atlas)."""
    return {"kind": "slider-crank", **asdict(ranges), "materials": {k: list(v) for k, v in MATERIALS.items()},
            "shapes": list(SHAPES)}
