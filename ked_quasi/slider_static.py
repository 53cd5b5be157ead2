"""Quasi-static KED of the slider-crank: the frozen structure, the flexibility method and its check.

At each crank angle the slider-crank is frozen: the crank is a cantilever clamped at the pivot M and
pinned at A to the coupler; the coupler is pinned at B to the slider, which resists only motion normal to
its line (the slider line is parallel to x, so the slider reacts a force R along y).  The structure is
statically determinate: R follows from the moment about A of the loads on the coupler; the pin force at A
(all coupler loads plus R) loads the crank.  Each link is a chain of straight Euler-Bernoulli elements
between nodes: the joints A, B, the coupler point P, the coupler's midspan and the lumps.  Element forces
(N, V, M at each element's outer end) per unit system load make the force transformation beta, and with
the cantilever element flexibility F (zero for a rigid link) the deflections are beta^T F beta P (the
same flexibility method as the four-bar's :mod:`ked_quasi.structure`).

The independent check (:func:`stiffness_deflections`) assembles 2-node frame elements by direct stiffness,
with pins as separate rotation dofs, the slider as a constraint on B's y, and rigid links as linear
constraints (a rigid crank is fixed; a rigid coupler moves as a rigid body), solved as a saddle-point
system.

System coordinates: x, y of every node, then the rotation of the section at P.  SI units; vectorized over
crank angles.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .slidercrank import SLIDER_LINKS, SliderCrank, SliderKinematics, SliderLumps, SliderScene, slider_kinematics
from .slidercrank import slider_lumps as _lumps

MIDSPAN = 0.5


@dataclass(frozen=True)
class SliderTopology:
    """Nodes and elements of the frozen slider-crank (angle independent).

    Nodes 0..3: A (coupler s=0), B (coupler s=1), P (coupler s=coupler_point), the coupler's midspan (the
    same node as P when P is at midspan), then the lumps' nodes.  ``node_link``/``node_s`` place each node
    (crank nodes by their fraction from M).  Elements: the crank chain M -> A, then the coupler chain
    A -> B; ``elem_link``, ``elem_s0``, ``elem_s1`` describe them.
    """

    node_label: tuple[str, ...]
    node_link: tuple[str, ...]
    node_s: np.ndarray
    elem_link: tuple[str, ...]
    elem_s0: np.ndarray
    elem_s1: np.ndarray
    p_index: int
    mid_index: int

    @property
    def n_nodes(self) -> int:
        return len(self.node_label)

    @property
    def n_dofs(self) -> int:
        return 2 * self.n_nodes + 1

    def node_of(self, link: str, s: float) -> int:
        if link == "crank" and s == 1.0:
            link, s = "coupler", 0.0
        for i, (lk, ss) in enumerate(zip(self.node_link, self.node_s)):
            if lk == link and abs(ss - s) < 1e-12:
                return i
        raise KeyError(f"no node at {link} s={s}")


def slider_topology(sc: SliderCrank, lm: SliderLumps) -> SliderTopology:
    """The structure's topology with a node at every lump, at P and at the coupler's midspan."""
    links, ss, labels = ["coupler", "coupler"], [0.0, 1.0], ["A", "B"]

    def add(link: str, s: float, label: str) -> None:
        if link == "crank" and s == 1.0:
            link, s = "coupler", 0.0
        if any(lk == link and abs(x - s) < 1e-12 for lk, x in zip(links, ss)):
            return
        links.append(link)
        ss.append(float(s))
        labels.append(label)

    add("coupler", sc.coupler_point, "P")
    add("coupler", MIDSPAN, "midspan")
    for lk, s in zip(lm.link, lm.s):
        add(lk, float(s), f"{lk}@{float(s):.6g}")
    elem_link, e0, e1 = [], [], []
    for lk in SLIDER_LINKS:
        pts = [0.0, *sorted(s for l2, s in zip(links, ss) if l2 == lk and 0.0 < s < 1.0), 1.0]
        for a, b in zip(pts[:-1], pts[1:]):
            elem_link.append(lk)
            e0.append(a)
            e1.append(b)
    topo = SliderTopology(tuple(labels), tuple(links), np.array(ss), tuple(elem_link), np.array(e0), np.array(e1),
                          p_index=0, mid_index=0)
    object.__setattr__(topo, "p_index", topo.node_of("coupler", sc.coupler_point))
    object.__setattr__(topo, "mid_index", topo.node_of("coupler", MIDSPAN))
    return topo


def node_masses(topo: SliderTopology, lm: SliderLumps) -> np.ndarray:
    """Mass [kg] at each structural node."""
    mass = np.zeros(topo.n_nodes)
    for lk, s, m in zip(lm.link, lm.s, lm.mass):
        mass[topo.node_of(lk, float(s))] += m
    return mass


def node_positions(topo: SliderTopology, kin: SliderKinematics) -> np.ndarray:
    """Complex positions of the nodes (n, N) [m]."""
    on_crank = np.array([lk == "crank" for lk in topo.node_link])
    rod, crank = kin.zB - kin.zA, kin.zA
    return np.where(on_crank, crank[:, None] * topo.node_s, kin.zA[:, None] + rod[:, None] * topo.node_s)


def inertia_loads(scene: SliderScene, topo: SliderTopology, lm: SliderLumps, kin: SliderKinematics) -> np.ndarray:
    """d'Alembert loads -m a at the nodes, (n, N, 2) [N], from the rigid accelerations."""
    on_crank = np.array([lk == "crank" for lk in topo.node_link])
    acc_crank = kin.aA[:, None] * topo.node_s  # the crank turns at constant speed about M
    _, acc_rod = kin.point(topo.node_s)
    acc = np.where(on_crank, acc_crank, acc_rod)
    load = -node_masses(topo, lm) * acc
    return np.stack([load.real, load.imag], axis=-1)


def element_flexibility(sc: SliderCrank, topo: SliderTopology) -> np.ndarray:
    """Cantilever flexibility (E, 3, 3) for (N, V, M) at each element's outer end; zero on a rigid link."""
    out = np.zeros((len(topo.elem_link), 3, 3))
    for i, (lk, s0, s1) in enumerate(zip(topo.elem_link, topo.elem_s0, topo.elem_s1)):
        if sc.is_rigid(lk):
            continue
        sec = sc.section(lk)
        L = (s1 - s0) * sc.length(lk)
        EA, EI = sec.axial_stiffness, sec.bending_stiffness
        out[i] = [[L / EA, 0, 0], [0, L**3 / (3 * EI), L**2 / (2 * EI)], [0, L**2 / (2 * EI), L / EI]]
    return out


def force_transformation(topo: SliderTopology, z_nodes: np.ndarray, kin: SliderKinematics) -> np.ndarray:
    """beta (n, 3E, 2N + 1): element forces (N, V, M per element) per unit system load (x, y of node k at
    2k, 2k + 1; a moment at P last)."""
    n, N, E, D = z_nodes.shape[0], topo.n_nodes, len(topo.elem_link), topo.n_dofs
    X = z_nodes
    zA, zB = kin.zA, kin.zB
    on_crank = np.array([lk == "crank" for lk in topo.node_link])
    # the slider's reaction R (along +y at B) per unit load, from the moment about A of the coupler's loads
    arm = X - zA[:, None]
    TA = np.zeros((n, D))
    TA[:, 0:2 * N:2] = -arm.imag * ~on_crank
    TA[:, 1:2 * N:2] = arm.real * ~on_crank
    TA[:, -1] = 1.0
    R = -TA / (zB - zA).real[:, None]  # (n, D)
    elem_crank = np.array([lk == "crank" for lk in topo.elem_link])
    z_end = np.where(elem_crank, zA[:, None] * topo.elem_s1, zA[:, None] + (zB - zA)[:, None] * topo.elem_s1)
    same = np.array([[lk == ln for ln in topo.node_link] for lk in topo.elem_link])
    beyond = same & (topo.node_s[None, :] >= topo.elem_s1[:, None] - 1e-12)
    via_A = elem_crank[:, None] & ~on_crank[None, :]  # coupler loads reach the crank through the pin A
    free = (beyond | via_A).astype(float)  # (E, N)
    app = np.where(via_A[None], zA[:, None, None], X[:, None, :])  # (n, E, N)
    la = app - z_end[..., None]
    Fx = np.zeros((n, E, D))
    Fy = np.zeros((n, E, D))
    Mz = np.zeros((n, E, D))
    Fx[:, :, 0:2 * N:2] = free
    Fy[:, :, 1:2 * N:2] = free
    Mz[:, :, 0:2 * N:2] = -la.imag * free
    Mz[:, :, 1:2 * N:2] = la.real * free
    Mz[:, :, -1] = (~elem_crank & (topo.node_s[topo.p_index] >= topo.elem_s1 - 1e-12)).astype(float)
    r_pt = np.where(elem_crank, zA[:, None], zB[:, None])  # R acts at B, reaching the crank through A
    Fy += R[:, None, :]
    Mz += (r_pt - z_end).real[..., None] * R[:, None, :]
    e = np.where(elem_crank, np.exp(1j * np.angle(zA))[:, None], ((zB - zA) / np.abs(zB - zA))[:, None])
    ex, ey = e.real[..., None], e.imag[..., None]
    beta = np.stack([Fx * ex + Fy * ey, -Fx * ey + Fy * ex, Mz], axis=2)  # (n, E, 3, D)
    return beta.reshape(n, 3 * E, D)


@dataclass(frozen=True)
class SliderQuasiStaticResult:
    """Quasi-static elastic deflections over the crank-angle grid.

    crank_angle (n,) [rad]; deflection (n, 3): dx, dy [m] (global frame) and rotation [rad, CCW] of the
    section at P; node_label; node_deflection (n, N, 2) [m]; loads (n, N, 2) d'Alembert forces [N];
    midspan (n,) [m]: the coupler's midspan deflection normal to its chord (CCW normal of A->B, the chord
    through the deflected A and B); transmission_angle (n,) [rad]: angle at B between B->A and the slider
    line's normal; condition (n,) = 1/|sin(transmission angle)|; flagged (n,): near-toggle angles (none for
    a linkage accepted by :class:`SliderCrank`).
    """

    crank_angle: np.ndarray
    deflection: np.ndarray
    node_label: tuple[str, ...]
    node_deflection: np.ndarray
    loads: np.ndarray
    midspan: np.ndarray
    transmission_angle: np.ndarray
    condition: np.ndarray
    flagged: np.ndarray


def _frozen(scene: SliderScene, theta: np.ndarray):
    lm = _lumps(scene.linkage, scene.mass_model)
    topo = slider_topology(scene.linkage, lm)
    kin = slider_kinematics(scene.linkage, theta, scene.rpm)
    return lm, topo, kin, node_positions(topo, kin)


def _system_flexibility(F: np.ndarray, beta: np.ndarray) -> np.ndarray:
    n, m, k = beta.shape
    Fb = np.einsum("eij,nejk->neik", F, beta.reshape(n, m // 3, 3, k)).reshape(n, m, k)
    return np.swapaxes(beta, 1, 2) @ Fb


def _angles(scene: SliderScene, crank_angle: np.ndarray | None) -> np.ndarray:
    return scene.crank_angles if crank_angle is None else np.atleast_1d(np.asarray(crank_angle, float))


def midspan_deflection(node_deflection: np.ndarray, topo: SliderTopology, kin: SliderKinematics) -> np.ndarray:
    """The coupler's midspan deflection normal to its chord [m], (n,): the midspan node's displacement minus
    the mean of A's and B's, along the CCW normal of A->B (small deflections)."""
    u = node_deflection[..., 0] + 1j * node_deflection[..., 1]
    rel = u[:, topo.mid_index] - 0.5 * (u[:, topo.node_of("coupler", 0.0)] + u[:, topo.node_of("coupler", 1.0)])
    normal = 1j * (kin.zB - kin.zA) / np.abs(kin.zB - kin.zA)
    return (np.conj(normal) * rel).real


CHUNK_ENTRIES = 2_000_000
"""Numbers of beta (crank angles x 3 elements x dofs) formed at once: about 16 MB, a few times that with the
temporaries, whatever the number of lumps."""


def _chunk(topo: SliderTopology) -> int:
    return max(1, CHUNK_ENTRIES // (3 * len(topo.elem_link) * topo.n_dofs))


def solve_slider_quasi_static(scene: SliderScene, crank_angle: np.ndarray | None = None) -> SliderQuasiStaticResult:
    """Quasi-static elastic deflections of a slider-crank scene (default grid: ``scene.crank_angles``), by
    the flexibility method delta = beta^T F beta P, a few crank angles at a time."""
    theta = _angles(scene, crank_angle)
    lm, topo, kin, X = _frozen(scene, theta)
    chunk = _chunk(topo)
    F = element_flexibility(scene.linkage, topo)
    loads = inertia_loads(scene, topo, lm, kin)
    N = topo.n_nodes
    delta = np.zeros((theta.size, topo.n_dofs))
    P = np.concatenate([loads.reshape(theta.size, -1), np.zeros((theta.size, 1))], axis=1)
    for lo in range(0, theta.size, chunk):
        sl = slice(lo, lo + chunk)
        sub = _sub(kin, sl)
        beta = force_transformation(topo, X[sl], sub)
        f = np.einsum("nmd,nd->nm", beta, P[sl]).reshape(-1, len(topo.elem_link), 3)
        d = np.einsum("eij,nej->nei", F, f).reshape(f.shape[0], -1)
        delta[sl] = np.einsum("nmd,nm->nd", beta, d)
    nodes = delta[:, :2 * N].reshape(theta.size, N, 2)
    p = topo.p_index
    mu = np.pi / 2.0 - np.abs(kin.rod_angle)
    return SliderQuasiStaticResult(
        crank_angle=theta, deflection=np.column_stack([nodes[:, p, 0], nodes[:, p, 1], delta[:, -1]]),
        node_label=topo.node_label, node_deflection=nodes, loads=loads, midspan=midspan_deflection(nodes, topo, kin),
        transmission_angle=mu, condition=1.0 / np.abs(np.sin(mu)), flagged=np.zeros(theta.size, dtype=bool))


def _sub(kin: SliderKinematics, sl: slice) -> SliderKinematics:
    from dataclasses import fields, replace

    return replace(kin, **{f.name: getattr(kin, f.name)[sl] for f in fields(kin) if f.name != "omega"})


def _flexibility_chunks(scene: SliderScene, theta: np.ndarray):
    """(slice of the angles, D (chunk, 2K, 2K) [m/N]) over the crank angles, and the masses (2K,) [kg]."""
    lm, topo, kin, X = _frozen(scene, theta)
    mass = node_masses(topo, lm)
    nodes = np.flatnonzero(mass > 0)
    cols = np.stack([2 * nodes, 2 * nodes + 1], axis=1).ravel()
    F = element_flexibility(scene.linkage, topo)
    chunk = _chunk(topo)

    def chunks():
        for lo in range(0, theta.size, chunk):
            sl = slice(lo, lo + chunk)
            yield sl, _system_flexibility(F, force_transformation(topo, X[sl], _sub(kin, sl))[:, :, cols])

    return chunks(), np.repeat(mass[nodes], 2)


def flexibility_at_masses(scene: SliderScene, crank_angle: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Flexibility (n, 2K, 2K) [m/N] on the translations (x1, y1, x2, y2, ...) of the K lumped masses, and
    their masses (2K,) [kg]."""
    theta = _angles(scene, crank_angle)
    chunks, m = _flexibility_chunks(scene, theta)
    D = np.empty((theta.size, m.size, m.size))
    for sl, d in chunks:
        D[sl] = d
    return D, m


def slider_natural_frequencies(scene: SliderScene, n_modes: int = 3,
                               crank_angle: np.ndarray | None = None) -> np.ndarray:
    """Lowest natural frequencies [Hz] of the frozen lumped-mass structure, (n, n_modes); coordinates the
    structure holds rigidly (the slider's normal, a rigid link's lumps) give no mode; missing modes are NaN.
    Computed a few angles at a time (only the n_modes largest eigenvalues of sqrt(M) D sqrt(M))."""
    from scipy.linalg import eigh
    from scipy.sparse.linalg import eigsh

    theta = _angles(scene, crank_angle)
    chunks, m = _flexibility_chunks(scene, theta)
    sq = np.sqrt(m)
    k = min(n_modes, m.size)
    out = np.full((theta.size, n_modes), np.nan)
    for sl, D in chunks:
        for i, d in zip(range(sl.start, sl.start + D.shape[0]), D):
            a = sq[:, None] * d * sq[None, :]
            moving = np.flatnonzero(np.any(a != 0.0, axis=1))  # coordinates the frozen structure lets move
            if moving.size == 0:
                continue
            a = a[np.ix_(moving, moving)]
            kk = min(k, moving.size)
            if moving.size <= 64:
                lam = eigh(a, eigvals_only=True, subset_by_index=[moving.size - kk, moving.size - 1])[::-1]
            else:  # Lanczos for the few largest eigenvalues of a large matrix
                lam = np.sort(eigsh(a, k=kk, which="LA", return_eigenvectors=False, tol=0.0))[::-1]
            lam = np.concatenate([lam, np.zeros(k - kk)])
            top = max(lam[0], 0.0)
            with np.errstate(divide="ignore", invalid="ignore"):
                out[i, :k] = np.where(lam > 1e-14 * top, 1.0 / np.sqrt(np.abs(lam)) / (2.0 * np.pi), np.nan)
    return out


# -- the independent check: direct stiffness ----------------------------------------------------
def _frame_element(zi: np.ndarray, zj: np.ndarray, EA: float, EI: float) -> np.ndarray:
    """Global 6x6 stiffness (n, 6, 6) of an Euler-Bernoulli frame element, dofs (ui, vi, thi, uj, vj, thj)."""
    d = zj - zi
    L = np.abs(d)
    c, s = d.real / L, d.imag / L
    a, b = EA / L, EI / L**3
    k = np.zeros((L.size, 6, 6))
    k[:, 0, 0] = k[:, 3, 3] = a
    k[:, 0, 3] = k[:, 3, 0] = -a
    bend = np.array([[12, 6, -12, 6], [6, 4, -6, 2], [-12, -6, 12, -6], [6, 2, -6, 4]], float)
    sc = np.stack([np.ones_like(L), L, np.ones_like(L), L], axis=1)
    idx = np.array([1, 2, 4, 5])
    k[:, idx[:, None], idx[None, :]] = b[:, None, None] * bend * sc[:, :, None] * sc[:, None, :]
    T = np.zeros((L.size, 6, 6))
    for o in (0, 3):
        T[:, o, o], T[:, o, o + 1], T[:, o + 1, o], T[:, o + 1, o + 1], T[:, o + 2, o + 2] = c, s, -s, c, 1.0
    return np.einsum("nji,njk,nkl->nil", T, k, T)


def stiffness_deflections(scene: SliderScene, crank_angle: np.ndarray | None = None) -> np.ndarray:
    """Deflections by direct stiffness: (n, 2N + 1), x, y of each node in topology order, then the rotation of
    the section at P.  Independent of the flexibility method: stiffness assembly, pins as separate rotation
    dofs, the slider and rigid links as constraints C u = 0 in a saddle-point solve."""
    theta = _angles(scene, crank_angle)
    sc = scene.linkage
    lm, topo, kin, X = _frozen(scene, theta)
    n, N = theta.size, topo.n_nodes
    rot: dict[tuple[str, int], int] = {}

    def rdof(key: tuple[str, int]) -> int:
        return rot.setdefault(key, 2 * N + len(rot))

    a, b = topo.node_of("coupler", 0.0), topo.node_of("coupler", 1.0)
    elements = []
    for lk, s0, s1 in zip(topo.elem_link, topo.elem_s0, topo.elem_s1):
        ends = []
        for s in (s0, s1):
            if lk == "crank" and s == 0.0:
                ends.append((np.zeros(n, complex), [-1, -1, -1]))  # clamped at M
                continue
            k = topo.node_of(lk, s)
            r = rdof((lk, k)) if k in (a, b) else rdof(("node", k))  # pins: one rotation per link end
            ends.append((X[:, k], [2 * k, 2 * k + 1, r]))
        elements.append((lk, ends))
    n_u = 2 * N + len(rot)
    K = np.zeros((n, n_u, n_u))
    for lk, ((zi, di), (zj, dj)) in elements:
        if sc.is_rigid(lk):
            continue
        sec = sc.section(lk)
        ke = _frame_element(zi, zj, sec.axial_stiffness, sec.bending_stiffness)
        dofs = di + dj
        for p_, dp in enumerate(dofs):
            for q_, dq in enumerate(dofs):
                if dp >= 0 and dq >= 0:
                    K[:, dp, dq] += ke[:, p_, q_]
    rows: list[np.ndarray] = []

    def fix(d: int) -> None:
        r = np.zeros((n, n_u))
        r[:, d] = 1.0
        rows.append(r)

    fix(2 * b + 1)  # the slider resists motion normal to its line (y)
    node_dofs = {k: [2 * k, 2 * k + 1] for k in range(N)}
    crank_nodes = [k for k in range(N) if topo.node_link[k] == "crank"]
    coupler_nodes = [k for k in range(N) if topo.node_link[k] == "coupler"]
    if sc.is_rigid("crank"):  # a rigid crank clamped at M holds its points and A fixed
        for k in [*crank_nodes, a]:
            for d in node_dofs[k]:
                fix(d)
        for key, d in rot.items():
            if key[0] == "crank" or (key[0] == "node" and key[1] in crank_nodes):
                fix(d)
    if sc.is_rigid("coupler"):  # every coupler point follows A's translation and the body rotation
        th = rdof(("coupler", a)) if ("coupler", a) in rot else None
        for k in coupler_nodes:
            if k == a:
                continue
            d = X[:, k] - X[:, a]
            for axis, lever in ((0, -d.imag), (1, d.real)):
                r = np.zeros((n, n_u))
                r[:, 2 * k + axis], r[:, 2 * a + axis], r[:, th] = 1.0, -1.0, -lever
                rows.append(r)
            rk = rot.get(("coupler", k), rot.get(("node", k)))
            r = np.zeros((n, n_u))
            r[:, rk], r[:, th] = 1.0, -1.0
            rows.append(r)
    C = np.stack(rows, axis=1)  # (n, c, n_u)
    scale = np.max(np.abs(np.diagonal(K, axis1=1, axis2=2)), initial=1.0)
    C = C * scale
    c = C.shape[1]
    kkt = np.zeros((n, n_u + c, n_u + c))
    kkt[:, :n_u, :n_u] = K
    kkt[:, :n_u, n_u:] = np.swapaxes(C, 1, 2)
    kkt[:, n_u:, :n_u] = C
    rhs = np.zeros((n, n_u + c))
    rhs[:, :2 * N] = inertia_loads(scene, topo, lm, kin).reshape(n, -1)
    u = np.linalg.solve(kkt, rhs[..., None])[..., 0]
    p_rot = rot.get(("node", topo.p_index))
    return np.concatenate([u[:, :2 * N], u[:, p_rot:p_rot + 1]], axis=1)


__all__ = ["SliderQuasiStaticResult", "SliderTopology", "flexibility_at_masses", "force_transformation",
           "midspan_deflection", "slider_natural_frequencies", "slider_topology", "solve_slider_quasi_static",
           "stiffness_deflections"]
