"""Independent check: a direct-stiffness linear frame model of the same frozen structure.

Standard 2-node Euler-Bernoulli frame elements (axial + bending, 6 dofs each) assembled in the
global frame; pins are modelled by giving each element end its own rotation dof at A (crank end),
B (coupler end, follower end) and Q; M is clamped, Q pinned.  Solving K u = P must reproduce the
flexibility method's beta^T F beta P: a different formulation (stiffness, compatibility built in)
of the same physics.  Batched over crank angles with numpy.linalg.solve.
"""

from __future__ import annotations

import numpy as np

from .massmodel import lumps
from .scene import Scene
from .solver import inertia_loads
from .structure import Topology, geometry, topology


def _frame_element(xi: np.ndarray, xj: np.ndarray, EA: float, EI: float) -> np.ndarray:
    """Global 6x6 stiffness for ends at xi, xj (n, 2): dofs (ui, vi, thi, uj, vj, thj)."""
    d = xj - xi
    L = np.linalg.norm(d, axis=-1)
    c, s = d[:, 0] / L, d[:, 1] / L
    n = L.size
    k = np.zeros((n, 6, 6))
    a = EA / L
    b = EI / L**3
    k[:, 0, 0] = k[:, 3, 3] = a
    k[:, 0, 3] = k[:, 3, 0] = -a
    loc = np.array([[12, 6, -12, 6], [6, 4, -6, 2], [-12, -6, 12, -6], [6, 2, -6, 4]], float)
    scale = np.stack([np.ones(n), L, np.ones(n), L], axis=1)
    kb = b[:, None, None] * loc[None] * scale[:, :, None] * scale[:, None, :]
    idx = [1, 2, 4, 5]
    k[:, np.ix_(idx, idx)[0], np.ix_(idx, idx)[1]] = kb
    T = np.zeros((n, 6, 6))
    for o in (0, 3):
        T[:, o, o], T[:, o, o + 1] = c, s
        T[:, o + 1, o], T[:, o + 1, o + 1] = -s, c
        T[:, o + 2, o + 2] = 1.0
    return np.einsum("nji,njk,nkl->nil", T, k, T)


def assemble(scene: Scene, theta: np.ndarray) -> tuple[np.ndarray, int, Topology]:
    """Global stiffness (n, ndof, ndof) of the frozen frame at the crank angles ``theta`` [rad]: dofs
    0..2N-1 are x, y of the structural nodes in topology order, then rotation dofs (pins give each
    element end its own); also the index of the rotation dof of P, and the topology."""
    lm = lumps(scene.fourbar, scene.mass_model)
    topo = topology(lm)
    geo = geometry(scene.fourbar, topo, theta)
    n, N = theta.size, topo.n_nodes

    # translational dofs: node k -> (2k, 2k+1); ground points fixed (-1)
    ndof = 2 * N
    rot: dict[tuple[str, str], int] = {}

    def rot_dof(key: tuple[str, str]) -> int:
        nonlocal ndof
        if key not in rot:
            rot[key] = ndof
            ndof += 1
        return rot[key]

    p_rot = rot_dof(("node", "P"))
    elements = []  # (xi, xj, dofs(6), section)
    for lk in ("crank", "coupler", "extender", "follower"):
        sel = [e for e, l2 in enumerate(topo.elem_link) if l2 == lk]
        for e in sel:
            s0, s1 = topo.elem_s0[e], topo.elem_s1[e]

            def point(s: float, lk: str = lk) -> tuple[np.ndarray, list[int]]:
                if lk == "crank" and s == 0.0:
                    M = np.tile(scene.fourbar.crank_pivot, (n, 1))
                    return M, [-1, -1, -1]  # clamped
                if lk == "follower" and s == 0.0:
                    return geo.Q, [-1, -1, rot_dof(("follower", "Q"))]  # pinned
                k = topo.node_of(lk, s)
                tr = [2 * k, 2 * k + 1]
                label = topo.node_label[k]
                if label == "A":
                    r = rot_dof(("crank", "A")) if lk == "crank" else rot_dof(("body", "A"))
                elif label == "B":
                    r = rot_dof((lk, "B"))
                elif label == "P":
                    r = p_rot
                else:
                    r = rot_dof(("node", label))
                return geo.nodes[:, k], [*tr, r]

            xi, di = point(s0)
            xj, dj = point(s1)
            elements.append((xi, xj, di + dj, scene.fourbar.section(lk)))

    K = np.zeros((n, ndof, ndof))
    for xi, xj, dofs, sec in elements:
        ke = _frame_element(xi, xj, sec.axial_stiffness, sec.bending_stiffness)
        for a, da in enumerate(dofs):
            if da < 0:
                continue
            for b, db in enumerate(dofs):
                if db >= 0:
                    K[:, da, db] += ke[:, a, b]
    return K, p_rot, topo


def stiffness_deflections(scene: Scene, crank_angle: np.ndarray | None = None) -> np.ndarray:
    """Deflections of all structural nodes and the rotation of P under the inertia loads, by direct
    stiffness: an array (n, 2N + 1), x, y of each node in topology order, then the rotation of P."""
    theta = scene.crank_angles if crank_angle is None else np.atleast_1d(np.asarray(crank_angle, float))
    K, p_rot, topo = assemble(scene, theta)
    n, N = theta.size, topo.n_nodes
    loads = inertia_loads(scene, topo, lumps(scene.fourbar, scene.mass_model), theta)
    rhs = np.zeros((n, K.shape[1]))
    rhs[:, : 2 * N] = loads.reshape(n, -1)
    u = np.linalg.solve(K, rhs[..., None])[..., 0]
    return np.concatenate([u[:, : 2 * N], u[:, p_rot : p_rot + 1]], axis=1)


def unit_load_flexibility(scene: Scene, crank_angle: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Flexibility on the translational coordinates of the lumped masses by unit-load solves of the
    stiffness model: (D (n, 2K, 2K) [m/N] in the order (x1, y1, x2, y2, ...), m (2K,) [kg]).  The
    independent counterpart of :func:`ked_quasi.solver.flexibility_at_masses`."""
    from .solver import node_masses

    theta = scene.crank_angles if crank_angle is None else np.atleast_1d(np.asarray(crank_angle, float))
    K, _, topo = assemble(scene, theta)
    mass = node_masses(topo, lumps(scene.fourbar, scene.mass_model))
    nodes = np.flatnonzero(mass > 0)
    cols = np.stack([2 * nodes, 2 * nodes + 1], axis=1).ravel()
    unit = np.zeros((K.shape[1], cols.size))
    unit[cols, np.arange(cols.size)] = 1.0
    U = np.linalg.solve(K, np.broadcast_to(unit, (theta.size, *unit.shape)))
    return U[:, cols, :], np.repeat(mass[nodes], 2)
