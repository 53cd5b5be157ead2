"""Link stress histories of the frozen structure: axial force, bending moment and extreme-fibre stress.

Each link of the frozen structure is a chain of straight elements between its nodes (joints and lumps,
:mod:`ked_quasi.structure`, :mod:`ked_quasi.slider_static`).  Under nodal loads the axial force N is
constant along an element and the bending moment M linear, so the extreme-fibre normal stresses

    sigma = N / A +- M c / I            (tension > 0; c: :attr:`ked_quasi.linkage.Section.extreme_fibre`)

take their extremes along a link at element ends.  Per link and crank angle the signed largest and smallest
fibre stress are kept (the mean and alternating stress of fatigue need both signs).  The moment at an
element's inner end i follows from the outer end j's forces (N, V, M about j, in the element frame e = i->j):
M_i = M_j + L V (the free side's resultant moved from j to i, L the element length).  SI units.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .linkage import LINKS, Section


@dataclass(frozen=True)
class LinkStress:
    """Section forces and fibre stresses of one link at n crank angles, per element (E of them).

    link: its name; s0, s1 (E,): the element ends as fractions of the link from its root; axial (n, E) [N]
    (tension > 0); moment (n, E, 2) [N m] at the inner and outer end (the sign of :mod:`ked_quasi.structure`);
    area [m^2], second_moment [m^4], fibre [m]: the section's A, I and extreme-fibre distance c.
    """

    link: str
    s0: np.ndarray
    s1: np.ndarray
    axial: np.ndarray
    moment: np.ndarray
    area: float
    second_moment: float
    fibre: float

    @property
    def fibre_max(self) -> np.ndarray:
        """(n, E, 2) [Pa]: N/A + |M| c / I at each element end (the more tensile fibre)."""
        return self.axial[..., None] / self.area + np.abs(self.moment) * (self.fibre / self.second_moment)

    @property
    def fibre_min(self) -> np.ndarray:
        """(n, E, 2) [Pa]: N/A - |M| c / I at each element end (the more compressive fibre)."""
        return self.axial[..., None] / self.area - np.abs(self.moment) * (self.fibre / self.second_moment)

    @property
    def sigma_max(self) -> np.ndarray:
        """(n,) [Pa]: the largest (signed) normal stress over the link at each crank angle."""
        return self.fibre_max.reshape(self.axial.shape[0], -1).max(axis=1)

    @property
    def sigma_min(self) -> np.ndarray:
        """(n,) [Pa]: the smallest (signed) normal stress over the link at each crank angle."""
        return self.fibre_min.reshape(self.axial.shape[0], -1).min(axis=1)

    @property
    def peak(self) -> float:
        """max over the cycle of max(|sigma_max|, |sigma_min|) [Pa]."""
        return float(np.nanmax(np.maximum(np.abs(self.sigma_max), np.abs(self.sigma_min))))

    def moment_at(self, s: float) -> np.ndarray:
        """(n,) [N m]: the bending moment at fraction ``s`` of the link (linear within its element)."""
        e = int(np.clip(np.searchsorted(self.s1, s), 0, self.s1.size - 1))
        t = (s - self.s0[e]) / (self.s1[e] - self.s0[e])
        return (1.0 - t) * self.moment[:, e, 0] + t * self.moment[:, e, 1]

    def on_breaks(self, breaks: np.ndarray) -> LinkStress:
        """The same link on the elements between ``breaks`` (sorted fractions from 0 to 1 that include this
        link's element ends): exact, since N is constant and M linear within each of this link's elements."""
        b = np.asarray(breaks, dtype=float)
        mid = 0.5 * (b[:-1] + b[1:])
        parent = np.clip(np.searchsorted(self.s1, mid), 0, self.s1.size - 1)
        span = self.s1[parent] - self.s0[parent]
        t0, t1 = (b[:-1] - self.s0[parent]) / span, (b[1:] - self.s0[parent]) / span
        m0, m1 = self.moment[:, parent, 0], self.moment[:, parent, 1]
        moment = np.stack([(1 - t0) * m0 + t0 * m1, (1 - t1) * m0 + t1 * m1], axis=-1)
        return LinkStress(link=self.link, s0=b[:-1], s1=b[1:], axial=self.axial[:, parent], moment=moment,
                          area=self.area, second_moment=self.second_moment, fibre=self.fibre)


@dataclass(frozen=True)
class StressHistory:
    """Stress histories of every link: crank_angle (n,) [rad]; links: name -> :class:`LinkStress`;
    tier: the model that gave them ("quasi-static", "linear", "exudyn")."""

    crank_angle: np.ndarray
    links: dict[str, LinkStress]
    tier: str

    def peaks(self) -> dict[str, float]:
        """Link -> peak |sigma| over the cycle [Pa]."""
        return {k: v.peak for k, v in self.links.items()}


def link_stress(link: str, section: Section, length: float, s0: np.ndarray, s1: np.ndarray,
                forces: np.ndarray) -> LinkStress:
    """:class:`LinkStress` of one link from its elements' outer-end forces ``forces`` (n, E, 3) = (N, V, M)
    [N, N, N m] (the :func:`ked_quasi.structure.element_forces` convention); ``length`` [m]."""
    L = (np.asarray(s1) - np.asarray(s0)) * length
    outer = forces[..., 2]
    inner = outer + L * forces[..., 1]
    return LinkStress(link=link, s0=np.asarray(s0, float), s1=np.asarray(s1, float), axial=forces[..., 0].copy(),
                      moment=np.stack([inner, outer], axis=-1), area=section.area,
                      second_moment=section.second_moment, fibre=section.extreme_fibre)


def split_links(linkage: object, elem_link: tuple[str, ...], s0: np.ndarray, s1: np.ndarray, forces: np.ndarray,
                names: tuple[str, ...]) -> dict[str, LinkStress]:
    """Per link of ``names``: its elements of the chain (``elem_link``, ``s0``, ``s1``) and their forces."""
    out = {}
    for lk in names:
        idx = np.array([i for i, e in enumerate(elem_link) if e == lk], dtype=int)
        out[lk] = link_stress(lk, linkage.section(lk), linkage.length(lk), s0[idx], s1[idx], forces[:, idx])
    return out


def four_bar_stress_from_loads(scene: object, crank_angle: np.ndarray, loads: np.ndarray,
                               tier: str = "quasi-static") -> StressHistory:
    """Stress histories of a four-bar ``scene`` under nodal loads ``loads`` (n, N, 2) [N] on its frozen
    structure (nodes of :func:`ked_quasi.structure.topology` of the scene's lumps) at ``crank_angle`` [rad]."""
    from .massmodel import lumps
    from .structure import element_forces, geometry, topology

    theta = np.atleast_1d(np.asarray(crank_angle, dtype=float))
    topo = topology(lumps(scene.fourbar, scene.mass_model))
    geo = geometry(scene.fourbar, topo, theta)
    with np.errstate(divide="ignore", invalid="ignore"):
        f = element_forces(topo, geo, loads)
    f[geo.sin_transmission == 0.0] = np.nan
    links = split_links(scene.fourbar, topo.elem_link, topo.elem_s0, topo.elem_s1, f, LINKS)
    return StressHistory(crank_angle=theta, links=links, tier=tier)


def four_bar_stress(scene: object, crank_angle: np.ndarray | None = None) -> StressHistory:
    """Quasi-static stress histories of a four-bar ``scene`` (default grid: its ``crank_angles``): the frozen
    structure's member forces under the d'Alembert loads -m a_rigid; links crank, coupler, extender, follower.
    Any linkage kind: :func:`ked_quasi.kinds.quasi_static_stress`."""
    from .massmodel import lumps
    from .solver import inertia_loads
    from .structure import topology

    theta = scene.crank_angles if crank_angle is None else np.atleast_1d(np.asarray(crank_angle, float))
    lm = lumps(scene.fourbar, scene.mass_model)
    loads = inertia_loads(scene, topology(lm), lm, theta)
    return four_bar_stress_from_loads(scene, theta, loads)


def slider_stress(scene: object, crank_angle: np.ndarray | None = None, loads: np.ndarray | None = None,
                  tier: str = "quasi-static") -> StressHistory:
    """Stress histories of a slider-crank ``scene`` at ``crank_angle`` [rad] (default: its grid) under nodal
    loads ``loads`` (n, N, 2) [N] (default: the quasi-static d'Alembert loads); links crank and coupler (the
    rod)."""
    from .slider_static import _chunk, _frozen, _sub, force_transformation, inertia_loads
    from .slidercrank import SLIDER_LINKS

    theta = scene.crank_angles if crank_angle is None else np.atleast_1d(np.asarray(crank_angle, dtype=float))
    lm, topo, kin, X = _frozen(scene, theta)
    loads = inertia_loads(scene, topo, lm, kin) if loads is None else loads
    P = np.concatenate([loads.reshape(theta.size, -1), np.zeros((theta.size, 1))], axis=1)
    f = np.empty((theta.size, len(topo.elem_link), 3))
    chunk = _chunk(topo)
    for lo in range(0, theta.size, chunk):
        sl = slice(lo, lo + chunk)
        beta = force_transformation(topo, X[sl], _sub(kin, sl))
        f[sl] = np.einsum("nmd,nd->nm", beta, P[sl]).reshape(-1, len(topo.elem_link), 3)
    links = split_links(scene.linkage, topo.elem_link, topo.elem_s0, topo.elem_s1, f, SLIDER_LINKS)
    return StressHistory(crank_angle=theta, links=links, tier=tier)


def combine(base: StressHistory, plus: StressHistory, minus: StressHistory, tier: str) -> StressHistory:
    """base + plus - minus, link by link, on the union of their element ends (each exact: N piecewise
    constant, M piecewise linear): the static correction of a model solved on fewer lumps."""
    links = {}
    for lk, b in base.links.items():
        parts = (b, plus.links[lk], minus.links[lk])
        breaks = np.unique(np.concatenate([np.r_[p.s0, p.s1[-1:]] for p in parts]))
        rb, rp, rm = (p.on_breaks(breaks) for p in parts)
        links[lk] = LinkStress(link=lk, s0=rb.s0, s1=rb.s1, axial=rb.axial + rp.axial - rm.axial,
                               moment=rb.moment + rp.moment - rm.moment, area=b.area,
                               second_moment=b.second_moment, fibre=b.fibre)
    return StressHistory(crank_angle=base.crank_angle, links=links, tier=tier)


def history_error(test: StressHistory, reference: StressHistory) -> dict[str, float]:
    """Link -> max over the cycle of |sigma_test - sigma_ref| for both the max and min fibre stress, divided
    by the reference's peak |sigma| (the peak-normalised history error of the deflection verdict)."""
    out = {}
    for lk, ref in reference.links.items():
        t = test.links[lk]
        diff = max(np.nanmax(np.abs(t.sigma_max - ref.sigma_max)), np.nanmax(np.abs(t.sigma_min - ref.sigma_min)))
        out[lk] = float(diff / ref.peak) if ref.peak > 0 else float("nan")
    return out


__all__ = ["LinkStress", "StressHistory", "combine", "four_bar_stress", "four_bar_stress_from_loads", "history_error",
           "link_stress", "slider_stress"]
