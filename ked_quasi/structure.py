"""The frozen four-bar as an instantaneous structure: nodes, elements and the force transformation.

At each crank angle the linkage is frozen: the crank is a cantilever clamped at M and pinned at A,
coupler and extender form one rigid-jointed body, pinned to the crank at A and to the follower at B;
the follower is pinned at Q; the ground is rigid.  Each link is a chain of straight Euler-Bernoulli
elements (axial + bending) between nodes: the joints and the load (mass) nodes on it.

The structure is statically determinate.  Its only redundancy-free coupling is the pin force R_B
that the follower exerts on the coupler body, fixed by two moment conditions (no moment through the
pins A and Q); every element's end forces then follow from the loads on its free side.  Element
forces per element (axial N, transverse V, moment M at its outer end j, in the element frame e = i->j,
n = z x e) make the force transformation ``beta``: f = beta P, and with the cantilever element
flexibility F the system flexibility is beta^T F beta (the thesis's eq. (6), general in geometry and
load nodes).

System coordinates: x, y of every node (global frame) and the rotation of P.  Units SI.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass

import numpy as np

from .kinematics import Loop, loop
from .linkage import LINKS, FourBar
from .massmodel import Lumps


def _canonical(link: str, s: float) -> tuple[str, float]:
    """Map a point on a link to its structural node (joints belong to the coupler body)."""
    if link == "crank" and s == 1.0:
        return ("coupler", 0.0)  # A
    if link == "follower" and s == 1.0:
        return ("coupler", 1.0)  # B
    if link == "extender" and s == 0.0:
        return ("coupler", 0.0)  # A
    return (link, float(s))


@dataclass(frozen=True)
class Topology:
    """Nodes, elements and the free-side incidence of the frozen structure (angle independent).

    Nodes: A, B, P, then interior load nodes; ``node_link``/``node_s`` place each node on a link.
    Elements: per link, consecutive nodes from its root; ``elem_*`` describe them.
    """

    node_label: tuple[str, ...]
    node_link: tuple[str, ...]
    node_s: np.ndarray
    elem_link: tuple[str, ...]
    elem_s0: np.ndarray
    elem_s1: np.ndarray
    free: np.ndarray  # (n_elem, n_node) node loads act on the element's free side
    via_A: np.ndarray  # (n_elem, n_node) ... but are transmitted through pin A (crank elements)
    r_b_sign: np.ndarray  # (n_elem,) sign with which R_B acts on the free side
    r_b_at_A: np.ndarray  # (n_elem,) R_B transmitted through pin A (crank elements)
    body: np.ndarray  # (n_node,) node on the coupler body
    on_follower: np.ndarray  # (n_node,) node inside the follower
    chain: dict  # link -> node indices of its interior nodes, in order from the root

    @property
    def n_nodes(self) -> int:
        return len(self.node_label)

    @property
    def n_dofs(self) -> int:
        """x, y of each node plus the rotation of P."""
        return 2 * self.n_nodes + 1

    @property
    def p_index(self) -> int:
        return self.node_label.index("P")

    def node_of(self, link: str, s: float) -> int:
        key = _canonical(link, s)
        for i, (lk, ss) in enumerate(zip(self.node_link, self.node_s)):
            if lk == key[0] and abs(ss - key[1]) < 1e-12:
                return i
        raise KeyError(f"no node at {link} s={s}")


_TOPOLOGIES: dict[tuple, Topology] = {}
_TOPOLOGIES_LOCK = threading.Lock()
TOPOLOGIES_KEPT = 64
"""Topologies remembered (by the lumps' links and positions: nothing else enters), the oldest forgotten first."""


def topology(lumps: Lumps) -> Topology:
    """Build the structure's topology with a node at every lump (remembered per lump layout: a solve asks
    for it several times, ~40 us each; the remembered arrays are read-only)."""
    key = (tuple(lumps.link), np.asarray(lumps.s, dtype=float).tobytes())
    with _TOPOLOGIES_LOCK:
        topo = _TOPOLOGIES.get(key)
    if topo is None:
        topo = _topology(lumps)
        for value in vars(topo).values():
            if isinstance(value, np.ndarray):
                value.flags.writeable = False
        for chain in topo.chain.values():
            chain.flags.writeable = False
        with _TOPOLOGIES_LOCK:
            if len(_TOPOLOGIES) >= TOPOLOGIES_KEPT:
                _TOPOLOGIES.pop(next(iter(_TOPOLOGIES)))
            topo = _TOPOLOGIES.setdefault(key, topo)
    return topo


def _topology(lumps: Lumps) -> Topology:
    labels = ["A", "B", "P"]
    links = ["coupler", "coupler", "extender"]
    ss = [0.0, 1.0, 1.0]
    for lk, s in zip(lumps.link, lumps.s):
        c = _canonical(lk, float(s))
        if c in set(zip(links, ss)) or (lk in ("crank", "follower") and s == 0.0):
            continue
        links.append(c[0])
        ss.append(c[1])
        labels.append(f"{c[0]}@{c[1]:.6g}")
    node_s = np.array(ss)
    body = np.array([lk in ("coupler", "extender") for lk in links])
    on_follower = np.array([lk == "follower" for lk in links])

    elem_link, e0, e1 = [], [], []
    for lk in LINKS:
        inner = sorted(s for l2, s in zip(links, ss) if l2 == lk and 0.0 < s < 1.0)
        pts = [0.0, *inner, 1.0]
        for a, b in zip(pts[:-1], pts[1:]):
            elem_link.append(lk)
            e0.append(a)
            e1.append(b)
    n_e, n_n = len(elem_link), len(links)
    free = np.zeros((n_e, n_n), dtype=bool)
    via_A = np.zeros((n_e, n_n), dtype=bool)
    r_b_sign = np.zeros(n_e)
    r_b_at_A = np.zeros(n_e, dtype=bool)
    for e, (lk, sj) in enumerate(zip(elem_link, e1)):
        beyond = np.array([l2 == lk and s >= sj - 1e-12 for l2, s in zip(links, ss)])
        if lk == "extender":
            free[e] = beyond
        elif lk == "coupler":
            free[e] = beyond  # interior coupler nodes beyond the cut and B (coupler s=1)
            r_b_sign[e] = 1.0
        elif lk == "follower":
            free[e] = beyond & on_follower
            r_b_sign[e] = -1.0
        else:  # crank: its own nodes beyond the cut, and the whole body through the pin at A
            free[e] = beyond | body
            via_A[e] = body
            r_b_sign[e] = 1.0
            r_b_at_A[e] = True
    return Topology(
        node_label=tuple(labels), node_link=tuple(links), node_s=node_s,
        elem_link=tuple(elem_link), elem_s0=np.array(e0), elem_s1=np.array(e1),
        free=free, via_A=via_A, r_b_sign=r_b_sign, r_b_at_A=r_b_at_A, body=body, on_follower=on_follower,
        chain={lk: np.array(sorted((i for i, l2 in enumerate(links) if l2 == lk and 0.0 < ss[i] < 1.0),
                                   key=lambda i: ss[i]), dtype=int) for lk in LINKS},
    )


def _xy(z: np.ndarray) -> np.ndarray:
    return np.stack([z.real, z.imag], axis=-1)


@dataclass(frozen=True)
class Geometry:
    """Positions at n crank angles as complex numbers x + i y [m]: nodes (n, N), joints A, B, Q (n,),
    element outer ends (n, E) and unit axes i -> j (n, E); ``sin_transmission`` (n,) is the signed sine
    of the angle at B between B->A and B->Q.  The (..., 2) properties give the same as real arrays."""

    z_nodes: np.ndarray
    zA: np.ndarray
    zB: np.ndarray
    zQ: np.ndarray
    z_end: np.ndarray
    z_axis: np.ndarray
    sin_transmission: np.ndarray

    nodes = property(lambda self: _xy(self.z_nodes))
    A = property(lambda self: _xy(self.zA))
    B = property(lambda self: _xy(self.zB))
    Q = property(lambda self: _xy(self.zQ))
    elem_end = property(lambda self: _xy(self.z_end))
    elem_axis = property(lambda self: _xy(self.z_axis))


def geometry(fourbar: FourBar, topo: Topology, crank_angle: np.ndarray, lp: Loop | None = None) -> Geometry:
    """Frozen geometry at the crank angles [rad] (``lp``: the assembled loop, if already at hand)."""
    lp = loop(fourbar, crank_angle) if lp is None else lp
    A = lp.M + lp.z1
    root = np.stack([lp.M + 0 * A, A, A, lp.Q + 0 * A], axis=1)  # LINKS order
    vec = np.stack([lp.z1, lp.z3, lp.k * lp.z3, lp.z4], axis=1)
    n_idx = [LINKS.index(lk) for lk in topo.node_link]
    e_idx = [LINKS.index(lk) for lk in topo.elem_link]
    nodes = root[:, n_idx] + vec[:, n_idx] * topo.node_s
    ends = root[:, e_idx] + vec[:, e_idx] * topo.elem_s1
    unit = vec / np.abs(vec)
    u, w = -lp.z3, -lp.z4  # B->A, B->Q
    sin_mu = (np.conj(u) * w).imag / (np.abs(u) * np.abs(w))
    return Geometry(z_nodes=nodes, zA=A, zB=A + lp.z3, zQ=lp.Q + 0 * A, z_end=ends, z_axis=unit[:, e_idx],
                    sin_transmission=sin_mu)


def force_transformation(topo: Topology, geo: Geometry) -> np.ndarray:
    """beta: (n_angles, 3 * n_elements, n_dofs), element forces (N, V, M per element) per unit system load.

    System dofs: (x, y) of node k at 2k, 2k+1; rotation (moment) of P last.
    """
    n = geo.nodes.shape[0]
    N, E, D = topo.n_nodes, len(topo.elem_link), topo.n_dofs
    X = geo.nodes  # (n, N, 2)
    # pin force R_B (follower -> coupler body) per unit load: two moment conditions
    armA = X - geo.A[:, None, :]
    armQ = X - geo.Q[:, None, :]
    TA = np.zeros((n, D))
    TQ = np.zeros((n, D))
    body, fol = topo.body.astype(float), topo.on_follower.astype(float)
    TA[:, 0:2 * N:2] = -armA[..., 1] * body
    TA[:, 1:2 * N:2] = armA[..., 0] * body
    TA[:, -1] = 1.0  # a moment at P acts on the body
    TQ[:, 0:2 * N:2] = -armQ[..., 1] * fol
    TQ[:, 1:2 * N:2] = armQ[..., 0] * fol
    Rx, Ry = np.einsum("aij,ajd->aid", _pin_force_map(geo), np.stack([TA, TQ], axis=1)).transpose(1, 0, 2)

    # resultant force (Fx, Fy) and moment about each element's outer end, per unit load
    Fx = np.zeros((n, E, D))
    Fy = np.zeros((n, E, D))
    Mz = np.zeros((n, E, D))
    free = topo.free.astype(float)
    direct = (topo.free & ~topo.via_A).astype(float)
    # application point: own position, or A for body loads reaching the crank through the pin
    app = np.where(topo.via_A[None, :, :, None], geo.A[:, None, None, :], X[:, None, :, :])
    arm = app - geo.elem_end[:, :, None, :]  # (n, E, N, 2)
    Fx[:, :, 0:2 * N:2] = free
    Fy[:, :, 1:2 * N:2] = free
    Mz[:, :, 0:2 * N:2] = -arm[..., 1] * free
    Mz[:, :, 1:2 * N:2] = arm[..., 0] * free
    Mz[:, :, -1] = direct[:, topo.p_index]
    sgn = topo.r_b_sign[None, :, None]
    Rpt = np.where(topo.r_b_at_A[None, :, None], geo.A[:, None, :], geo.B[:, None, :])
    Rarm = Rpt - geo.elem_end  # (n, E, 2)
    Fx += sgn * Rx[:, None, :]
    Fy += sgn * Ry[:, None, :]
    Mz += sgn * (Rarm[..., 0:1] * Ry[:, None, :] - Rarm[..., 1:2] * Rx[:, None, :])

    e = geo.elem_axis[..., None]  # (n, E, 2, 1)
    Nn = Fx * e[:, :, 0] + Fy * e[:, :, 1]
    Vn = -Fx * e[:, :, 1] + Fy * e[:, :, 0]
    beta = np.stack([Nn, Vn, Mz], axis=2)  # (n, E, 3, D)
    return beta.reshape(n, 3 * E, D)


def element_flexibility(fourbar: FourBar, topo: Topology) -> np.ndarray:
    """Cantilever flexibility of every element, (n_elements, 3, 3), for (N, V, M) at its outer end.

    [[L/EA, 0, 0], [0, L^3/3EI, L^2/2EI], [0, L^2/2EI, L/EI]]; L = element length [m].
    """
    out = np.zeros((len(topo.elem_link), 3, 3))
    for i, (lk, s0, s1) in enumerate(zip(topo.elem_link, topo.elem_s0, topo.elem_s1)):
        sec = fourbar.section(lk)
        L = (s1 - s0) * fourbar.length(lk)
        EA, EI = sec.axial_stiffness, sec.bending_stiffness
        out[i] = [[L / EA, 0, 0], [0, L**3 / (3 * EI), L**2 / (2 * EI)], [0, L**2 / (2 * EI), L / EI]]
    return out


def element_deformations(F: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Element deformations d = F f for element forces f (n, E, 3), using the cantilever flexibility's
    structure (axial decoupled from bending, as built by :func:`element_flexibility`)."""
    d = np.empty_like(f)
    d[..., 0] = F[:, 0, 0] * f[..., 0]
    d[..., 1] = F[:, 1, 1] * f[..., 1] + F[:, 1, 2] * f[..., 2]
    d[..., 2] = F[:, 2, 1] * f[..., 1] + F[:, 2, 2] * f[..., 2]
    return d


def system_flexibility(F: np.ndarray, beta: np.ndarray) -> np.ndarray:
    """beta^T F beta: (n_angles, k, k) for beta shaped (n_angles, 3 * n_elements, k)."""
    n, m, k = beta.shape
    bb = beta.reshape(n, m // 3, 3, k)
    Fb = np.einsum("eij,nejk->neik", F, bb).reshape(n, m, k)
    return np.einsum("nmi,nmj->nij", beta, Fb)


def _cx(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Planar cross product a x b of complex-encoded vectors."""
    return (np.conj(a) * b).imag


def _pin_force_map(geo: Geometry) -> np.ndarray:
    """C (n, 2, 2): (R_x, R_y) = C @ (T_A, T_Q), the follower's pin force on the coupler body from the
    moments about A of the body's loads (T_A) and about Q of the follower's loads (T_Q)."""
    u = geo.zB - geo.zA
    w = geo.zB - geo.zQ
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / _cx(u, w)
    return inv[:, None, None] * np.stack([np.stack([-w.real, -u.real], -1), np.stack([-w.imag, -u.imag], -1)], 1)


def _suffix(a: np.ndarray) -> np.ndarray:
    return np.cumsum(a[:, ::-1], axis=1)[:, ::-1]


def _chain_ends(topo: Topology, geo: Geometry):
    """Per link: element slice, node indices, the end point where the chain's end load acts."""
    out = {}
    start = 0
    for lk in LINKS:
        idx = topo.chain[lk]
        sl = slice(start, start + idx.size + 1)
        start = sl.stop
        end_pt = {"crank": geo.zA, "coupler": geo.zB, "extender": None, "follower": geo.zB}[lk]
        out[lk] = (sl, idx, end_pt)
    return out


def element_forces(topo: Topology, geo: Geometry, loads: np.ndarray, moment_p: np.ndarray | None = None) -> np.ndarray:
    """f = beta P without forming beta: element forces (n, E, 3) = (N, V, M) for nodal loads (n, N, 2) [N]
    and an optional moment at P (n,) [N m].  Same statics as :func:`force_transformation`, with the
    free-side sums of each link done as suffix sums along its chain (O(n N))."""
    n = loads.shape[0]
    mp = np.zeros(n) if moment_p is None else moment_p
    L = loads[..., 0] + 1j * loads[..., 1]
    X = geo.z_nodes
    p, b = topo.p_index, topo.node_label.index("B")
    TA = _cx(X - geo.zA[:, None], L) @ topo.body.astype(float) + mp
    TQ = _cx(X - geo.zQ[:, None], L) @ topo.on_follower.astype(float)
    Rxy = np.einsum("aij,aj->ai", _pin_force_map(geo), np.stack([TA, TQ], -1))
    R = Rxy[:, 0] + 1j * Rxy[:, 1]
    end_load = {"crank": L @ topo.body.astype(float) + R, "coupler": L[:, b] + R, "extender": L[:, p],
                "follower": -R}
    end_moment = {"extender": mp}
    f = np.empty((n, len(topo.elem_link), 3))
    for lk, (sl, idx, end_pt) in _chain_ends(topo, geo).items():
        pt = np.concatenate([X[:, idx], (X[:, p] if end_pt is None else end_pt)[:, None]], axis=1)
        F = np.concatenate([L[:, idx], end_load[lk][:, None]], axis=1)
        Mo = _cx(pt, F)
        if lk in end_moment:
            Mo[:, -1] += end_moment[lk]
        Fs = _suffix(F)
        Ms = _suffix(Mo) - _cx(pt, Fs)  # moment about each element's outer end
        e = geo.z_axis[:, sl]
        ce = np.conj(e) * Fs
        f[:, sl, 0] = ce.real
        f[:, sl, 1] = ce.imag
        f[:, sl, 2] = Ms
    return f


def nodal_deflections(topo: Topology, geo: Geometry, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """delta = beta^T d without forming beta, for element deformations d (n, E, 3).

    Returns node displacements (n, N, 2) [m] and the rotation of P (n,) [rad]: by virtual work the
    transpose of :func:`element_forces` (prefix sums along each chain)."""
    X = geo.z_nodes
    p, b = topo.p_index, topo.node_label.index("B")
    g = (d[..., 0] + 1j * d[..., 1]) * geo.z_axis  # (n, E)
    h = d[..., 2]
    delta = np.zeros(X.shape, dtype=complex)
    end_val = {}
    for lk, (sl, idx, end_pt) in _chain_ends(topo, geo).items():
        pt = np.concatenate([X[:, idx], (X[:, p] if end_pt is None else end_pt)[:, None]], axis=1)
        G = np.cumsum(g[:, sl] - 1j * h[:, sl] * geo.z_end[:, sl], axis=1)
        H = np.cumsum(h[:, sl], axis=1)
        val = G + 1j * pt * H  # adjoint value at each chain position (interior nodes, then the end)
        delta[:, idx] += val[:, :-1]
        end_val[lk] = val[:, -1]
        if lk == "extender":
            rot = H[:, -1].copy()
    delta[:, p] += end_val["extender"]
    delta[:, b] += end_val["coupler"]
    delta += end_val["crank"][:, None] * topo.body  # the body's loads reach the crank through pin A
    rho = end_val["coupler"] - end_val["follower"] + end_val["crank"]
    lam = np.einsum("aji,aj->ai", _pin_force_map(geo), np.stack([rho.real, rho.imag], -1))
    delta += lam[:, 0, None] * topo.body * 1j * (X - geo.zA[:, None])
    delta += lam[:, 1, None] * topo.on_follower * 1j * (X - geo.zQ[:, None])
    return _xy(delta), rot + lam[:, 0]
