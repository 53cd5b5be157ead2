"""The frozen structure's stiffness condensed on the lumped masses, with optional geometric stiffness.

The same instantaneous structure as :mod:`ked_quasi.structure` (crank clamped at M and pinned at A,
coupler + extender one rigid-jointed body, pins at B and Q), built as a direct-stiffness model of
2-node Euler-Bernoulli frame elements with a node at every lump (the formulation of
:mod:`ked_quasi.stiffness`, assembled with index arrays).  Optionally each element also gets the
consistent geometric stiffness of its axial force N (tension > 0):

    K_G = N / (30 L) [[36, 3L, -36, 3L], [3L, 4L^2, -3L, -L^2], [-36, -3L, 36, -3L], [3L, -L^2, -3L, 4L^2]]

on its transverse dofs (v_i, th_i, v_j, th_j); for a pinned two-force member its rigid lateral
rotation costs exactly N/L, the truss geometric stiffness.  Static condensation on the translational
dofs of the mass nodes gives K_c (the inverse of :func:`ked_quasi.solver.flexibility_at_masses` when
N = 0) and the map from those displacements to (dx, dy, rotation) of the coupler point P.

Everything is vectorized over crank angles; units SI.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .framecache import REFERENCE_RPM, cached, load_scale
from .kinematics import loop
from .linkage import FourBar
from .massmodel import lumps
from .scene import Scene
from .solver import inertia_loads, node_masses
from .structure import Geometry, Topology, element_forces, geometry, topology


@dataclass(frozen=True)
class FrameDofs:
    """Angle-independent dof numbering of the frame model.

    elem_dofs (E, 6): global dof of (u_i, v_i, th_i, u_j, v_j, th_j) of each element in topology
    order, -1 where fixed (clamp at M, pin at Q); n_dofs: number of free dofs (node k: x at 2k, y at
    2k + 1; rotations after the translations); p_rotation: dof of the section rotation at P.
    """

    elem_dofs: np.ndarray
    n_dofs: int
    p_rotation: int


def frame_dofs(topo: Topology) -> FrameDofs:
    """Dof numbering: own rotation at interior nodes and P; at A one for the crank end and one for the
    coupler body; at B one per link end; a free rotation at the pin Q; M clamped."""
    rot: dict[tuple[str, str], int] = {}

    def rot_dof(key: tuple[str, str]) -> int:
        return rot.setdefault(key, 2 * topo.n_nodes + len(rot))

    p_rot = rot_dof(("node", "P"))

    def end(link: str, s: float) -> list[int]:
        if link == "crank" and s == 0.0:
            return [-1, -1, -1]
        if link == "follower" and s == 0.0:
            return [-1, -1, rot_dof(("follower", "Q"))]
        k = topo.node_of(link, s)
        label = topo.node_label[k]
        if label == "A":
            key = ("crank", "A") if link == "crank" else ("body", "A")
        elif label == "B":
            key = (link, "B")
        else:
            key = ("node", label)
        return [2 * k, 2 * k + 1, rot_dof(key)]

    dofs = [end(lk, s0) + end(lk, s1) for lk, s0, s1 in zip(topo.elem_link, topo.elem_s0, topo.elem_s1)]
    return FrameDofs(elem_dofs=np.array(dofs, dtype=int), n_dofs=2 * topo.n_nodes + len(rot), p_rotation=p_rot)


def _local_stiffness(L: np.ndarray, EA: np.ndarray, EI: np.ndarray, N: np.ndarray) -> np.ndarray:
    """Local 6x6 elastic + geometric stiffness, (n, E, 6, 6), dofs (u_i, v_i, th_i, u_j, v_j, th_j)."""
    k = np.zeros(np.broadcast_shapes(L.shape, N.shape) + (6, 6))
    a = EA / L
    k[..., 0, 0] = k[..., 3, 3] = a
    k[..., 0, 3] = k[..., 3, 0] = -a
    bend = np.array([[12, 6, -12, 6], [6, 4, -6, 2], [-12, -6, 12, -6], [6, 2, -6, 4]], float)
    geo = np.array([[36, 3, -36, 3], [3, 4, -3, -1], [-36, -3, 36, -3], [3, -1, -3, 4]], float)
    Ls = np.stack([np.ones_like(L), L, np.ones_like(L), L], axis=-1)
    scale = Ls[..., :, None] * Ls[..., None, :]
    idx = np.ix_([1, 2, 4, 5], [1, 2, 4, 5])
    k[(..., *idx)] = (EI / L**3)[..., None, None] * bend * scale + (N / (30.0 * L))[..., None, None] * geo * scale
    return k


def _rotate(k: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """Local -> global: T^T k T with T the rotation to the element axis (complex unit, (n, E))."""
    c, s = axis.real, axis.imag
    T = np.zeros(axis.shape + (6, 6))
    for o in (0, 3):
        T[..., o, o], T[..., o, o + 1] = c, s
        T[..., o + 1, o], T[..., o + 1, o + 1] = -s, c
        T[..., o + 2, o + 2] = 1.0
    return np.swapaxes(T, -1, -2) @ k @ T


def assemble(fourbar: FourBar, topo: Topology, dofs: FrameDofs, geo: Geometry,
             axial_force: np.ndarray | None = None, elastic: bool = True) -> np.ndarray:
    """Global stiffness (n, n_dofs, n_dofs) [N/m, N, N m] in the frozen geometry ``geo`` (n crank
    angles): the elastic part (``elastic``) plus the geometric stiffness of ``axial_force`` (n, E)
    [N, tension > 0] if given."""
    n = geo.z_axis.shape[0]
    lengths = np.array([(s1 - s0) * fourbar.length(lk) for lk, s0, s1 in
                        zip(topo.elem_link, topo.elem_s0, topo.elem_s1)])
    EA = np.array([fourbar.section(lk).axial_stiffness for lk in topo.elem_link]) * elastic
    EI = np.array([fourbar.section(lk).bending_stiffness for lk in topo.elem_link]) * elastic
    N = np.zeros((n, lengths.size)) if axial_force is None else axial_force
    ke = _rotate(_local_stiffness(lengths, EA, EI, N), geo.z_axis)  # (n, E, 6, 6)
    d = dofs.elem_dofs
    keep = (d[:, :, None] >= 0) & (d[:, None, :] >= 0)  # (E, 6, 6)
    e, a, b = np.nonzero(keep)
    flat = d[e, a] * dofs.n_dofs + d[e, b]
    order = np.argsort(flat, kind="stable")
    target, first = np.unique(flat[order], return_index=True)
    K = np.zeros((n, dofs.n_dofs**2))
    K[:, target] = np.add.reduceat(ke[:, e[order], a[order], b[order]], first, axis=1)  # sums coincident entries
    return K.reshape(n, dofs.n_dofs, dofs.n_dofs)


@dataclass(frozen=True)
class CondensedStructure:
    """The frozen structure condensed on the mass coordinates, at n crank angles.

    Coordinates: translations of the mass nodes in the order (x1, y1, x2, y2, ...) of
    :func:`ked_quasi.solver.flexibility_at_masses`.  stiffness (n, k, k) [N/m]: static condensation of
    the frame (with the geometric stiffness if prestressed); material_stiffness (n, k, k) [N/m]: the
    unstressed (elastic) part on the same static modes, Psi^T K_E Psi (equal to ``stiffness`` without
    prestress); mass (k,) [kg]: the diagonal mass; load (n, k) [N]: d'Alembert loads -m a of the rigid
    motion at the scene's speed; output (n, 3, k): (dx [m], dy [m], rotation [rad]) of P per unit
    mass-node displacement (the massless dofs follow the masses statically); mass_node (K,): structural
    node of each mass (topology order).
    """

    stiffness: np.ndarray
    material_stiffness: np.ndarray
    mass: np.ndarray
    load: np.ndarray
    output: np.ndarray
    mass_node: np.ndarray


def condensed_structure(scene: Scene, crank_angle: np.ndarray | None = None,
                        prestress: bool = False) -> CondensedStructure:
    """Static condensation of the frame model on the mass coordinates at the crank angles [rad] (default
    ``scene.crank_angles``); ``prestress``: add the geometric stiffness of the axial forces of the
    quasi-static inertia loads at the scene's speed (tension stiffens).  The speed-free parts (geometry,
    elastic stiffness, reference-speed loads and geometric stiffness, the unstressed condensation) are
    built once per linkage, mass model and set of angles (:func:`frame_parts`, cached by
    :mod:`ked_quasi.framecache`)."""
    theta = scene.crank_angles if crank_angle is None else np.atleast_1d(np.asarray(crank_angle, float))
    parts = frame_parts(scene, theta)
    scale = load_scale(scene)  # loads, axial forces and geometric stiffness go as the speed squared
    p, nodes = parts.topo.p_index, parts.nodes
    out_dofs = [2 * p, 2 * p + 1, parts.dofs.p_rotation]
    split = cached("split", scene, theta, lambda: _split(parts, geometric_stiffness(scene, theta), out_dofs)) \
        if prestress else None
    if split is not None:
        Kc, Km, out = split.condense(scale)
    elif prestress:  # the slave block of K_E not positive definite: a solve per speed
        K = parts.elastic + scale * geometric_stiffness(scene, theta)
        psi, Kc = _condense(K, parts.master)
        Km = _congruence(psi, parts.elastic)
        out = psi[:, out_dofs]
    else:  # the unstressed structure: no part depends on the speed
        psi, Kc = cached("unstressed", scene, theta, lambda: _condense(parts.elastic, parts.master))
        Kc = Km = Kc.copy()
        out = psi[:, out_dofs]
    return CondensedStructure(stiffness=Kc, material_stiffness=Km, mass=np.repeat(parts.node_mass[nodes], 2),
                              load=scale * parts.loads[:, nodes].reshape(theta.size, -1), output=out,
                              mass_node=nodes.copy())


def _condense(K: np.ndarray, master: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(Psi, Psi^T K Psi): the static modes of the masters and the condensed stiffness."""
    psi = _static_modes(K, master)
    return psi, _congruence(psi, K)


@dataclass(frozen=True)
class FrameParts:
    """The speed-free frame model at n crank angles.

    topo, dofs: the structure and its dof numbering; geo: the frozen geometry; node_mass (N,) [kg]; nodes:
    the mass-carrying nodes; master: their translational dofs (x1, y1, x2, y2, ...); elastic (n, d, d): the
    elastic stiffness K_E [N/m, N, N m]; loads (n, N, 2) [N] and axial (n, E) [N, tension > 0]: the
    d'Alembert loads and the elements' quasi-static axial forces at :data:`ked_quasi.framecache.REFERENCE_RPM`.
    """

    topo: Topology
    dofs: FrameDofs
    geo: Geometry
    node_mass: np.ndarray
    nodes: np.ndarray
    master: np.ndarray
    elastic: np.ndarray
    loads: np.ndarray
    axial: np.ndarray


def _build_parts(scene: Scene, theta: np.ndarray) -> FrameParts:
    lm = lumps(scene.fourbar, scene.mass_model)
    topo = topology(lm)
    dofs = frame_dofs(topo)
    lp = loop(scene.fourbar, theta)
    geo = geometry(scene.fourbar, topo, theta, lp)
    loads = inertia_loads(replace(scene, rpm=REFERENCE_RPM), topo, lm, theta, geo, lp)
    with np.errstate(divide="ignore", invalid="ignore"):
        axial = element_forces(topo, geo, loads)[..., 0]
    mass = node_masses(topo, lm)
    nodes = np.flatnonzero(mass > 0)
    master = np.stack([2 * nodes, 2 * nodes + 1], axis=1).ravel()
    return FrameParts(topo=topo, dofs=dofs, geo=geo, node_mass=mass, nodes=nodes, master=master,
                      elastic=assemble(scene.fourbar, topo, dofs, geo), loads=loads, axial=axial)


def frame_parts(scene: Scene, crank_angle: np.ndarray) -> FrameParts:
    """The speed-free :class:`FrameParts` of ``scene`` at ``crank_angle`` [rad] (cached)."""
    theta = np.atleast_1d(np.asarray(crank_angle, dtype=float))
    return cached("parts", scene, theta, lambda: _build_parts(scene, theta))


def geometric_stiffness(scene: Scene, crank_angle: np.ndarray) -> np.ndarray:
    """(n, d, d): the geometric stiffness of the quasi-static axial forces at
    :data:`ked_quasi.framecache.REFERENCE_RPM` (cached; at the scene's speed it is
    :func:`ked_quasi.framecache.load_scale` times this)."""
    theta = np.atleast_1d(np.asarray(crank_angle, dtype=float))

    def build() -> np.ndarray:
        p = frame_parts(scene, theta)
        return assemble(scene.fourbar, p.topo, p.dofs, p.geo, p.axial, elastic=False)

    return cached("geometric", scene, theta, build)


@dataclass(frozen=True)
class _Split:
    """The prestressed condensation's speed-free factors at n crank angles, for any load scale s (the speed
    squared, :func:`ked_quasi.framecache.load_scale`): K = K_E + s K_G split into master (m) and slave (s)
    dofs, K_E,ss = L L^T (Cholesky) and L^-1 K_G,ss L^-T = V diag(lam) V^T, so that K_ss^-1 =
    T diag(d) T^T with T = L^-T V, d = 1 / (1 + s lam): the slaves' static response X = K_ss^-1 K_sm =
    T diag(d) R with R = T^T K_sm = A + s B (A = T^T K_E,sm, B = T^T K_G,sm).  Then (T^T K_E,ss T = I)

        Psi^T K Psi   = K_mm - R^T diag(d) R,          K_mm = E_mm + s G_mm,
        Psi^T K_E Psi = E_mm - A^T D R - R^T D A + (D R)^T (D R),   D = diag(d),

    and the output rows of Psi, unit rows at master dofs, -X rows at slave dofs (``out_unit`` - ``out_t`` D R):
    per speed a few (k x slaves) products instead of a factorization per angle."""

    e_mm: np.ndarray
    g_mm: np.ndarray
    a: np.ndarray
    b: np.ndarray
    lam: np.ndarray
    out_unit: np.ndarray
    out_t: np.ndarray

    def condense(self, scale: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(Psi^T K Psi, Psi^T K_E Psi, the output rows of Psi) at load scale ``scale``, symmetrized."""
        R = self.a + scale * self.b
        DR = (1.0 / (1.0 + scale * self.lam))[..., None] * R
        Rt = np.swapaxes(R, 1, 2)
        Kc = self.e_mm + scale * self.g_mm - Rt @ DR
        AtDR = np.swapaxes(self.a, 1, 2) @ DR
        Km = self.e_mm - AtDR - np.swapaxes(AtDR, 1, 2) + np.swapaxes(DR, 1, 2) @ DR
        out = self.out_unit - self.out_t @ DR
        return 0.5 * (Kc + np.swapaxes(Kc, 1, 2)), 0.5 * (Km + np.swapaxes(Km, 1, 2)), out


def _split(parts: FrameParts, geometric: np.ndarray, out_dofs: list[int]) -> _Split | None:
    """The :class:`_Split` of ``parts`` with the reference geometric stiffness ``geometric``, or None if
    the elastic slave block is not positive definite at every angle."""
    E, G, master = parts.elastic, geometric, parts.master
    slave = _complement(E.shape[-1], master)
    try:
        L = np.linalg.cholesky(E[:, slave[:, None], slave])
    except np.linalg.LinAlgError:
        return None
    n = E.shape[0]
    Linv = np.linalg.solve(L, np.broadcast_to(np.eye(slave.size), L.shape))
    S = Linv @ G[:, slave[:, None], slave] @ np.swapaxes(Linv, 1, 2)
    lam, V = np.linalg.eigh(0.5 * (S + np.swapaxes(S, 1, 2)))
    Tt = np.swapaxes(V, 1, 2) @ Linv  # T^T = V^T L^-1
    where = {int(d): i for i, d in enumerate(slave)}
    out_unit = np.zeros((len(out_dofs), master.size))
    out_t = np.zeros((n, len(out_dofs), slave.size))
    for row, dof in enumerate(out_dofs):
        if dof in where:
            out_t[:, row] = Tt[:, :, where[dof]]  # the row of T = (T^T)^T
        else:
            out_unit[row, int(np.flatnonzero(master == dof)[0])] = 1.0
    return _Split(e_mm=E[:, master[:, None], master], g_mm=G[:, master[:, None], master],
                  a=Tt @ E[:, slave[:, None], master], b=Tt @ G[:, slave[:, None], master], lam=lam,
                  out_unit=out_unit, out_t=out_t)


def _complement(n: int, master: np.ndarray) -> np.ndarray:
    """The dofs 0 .. n - 1 not in ``master``, ascending (``np.setdiff1d(np.arange(n), master)``, without the
    import of ``numpy.ma`` that its first call costs a fresh process, ~10 ms)."""
    keep = np.ones(n, dtype=bool)
    keep[master] = False
    return np.flatnonzero(keep)


def _static_modes(K: np.ndarray, master: np.ndarray) -> np.ndarray:
    """Psi (n, n_dofs, k): all dofs per unit master displacement, the slaves carrying no load."""
    slave = _complement(K.shape[-1], master)
    psi = np.zeros((K.shape[0], K.shape[-1], master.size))
    psi[:, master, np.arange(master.size)] = 1.0
    psi[:, slave] = -np.linalg.solve(K[:, slave[:, None], slave], K[:, slave[:, None], master])
    return psi


def _congruence(psi: np.ndarray, K: np.ndarray) -> np.ndarray:
    """Psi^T K Psi, symmetrized."""
    Kc = np.swapaxes(psi, 1, 2) @ K @ psi
    return 0.5 * (Kc + np.swapaxes(Kc, 1, 2))


__all__ = ["CondensedStructure", "FrameDofs", "assemble", "condensed_structure", "frame_dofs"]
