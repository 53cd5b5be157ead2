"""The linear time-periodic KED model of a slider-crank (``ked_quasi.slidercrank.SliderScene``).

The same equations as the four-bar's (:mod:`ked_linear.linkage`, docs/linear_model.md),

    M u'' + C(theta) u' + K(theta) u = -M a_rigid(theta),   theta = theta0 + s Omega t,

on the slider-crank's own frozen structure (:mod:`ked_quasi.slider_static`): the crank clamped at the pivot
M and pinned at A to the coupler, the coupler pinned at B to the slider, which holds B on its line (B's
motion normal to the line is fixed, its motion along the line is free and carries the slider's mass).  A
link declared rigid does not deform: a rigid crank holds A and its own lumps fixed (only the coupler's
elastic coordinates remain); a rigid coupler is not modelled here (ValueError).

u: the absolute elastic displacements (global x, y) of the lumped masses of the mass model that the frozen
structure lets move (``ked_quasi.slidercrank.slider_lumps``: lumps at M, on a rigid crank or at a fixed A
drop out; the slider and a lump at B keep only the coordinate along the line).  K(theta): the frame of
2-node Euler-Bernoulli elements with a node at every lump, at P and at the coupler's midspan (the topology
of the quasi-static solver), assembled by direct stiffness with pins as separate rotation dofs and
condensed statically on u; its inverse is the quasi-static flexibility at the masses (test).  Prestress
and damping as for the four-bar: the consistent geometric stiffness of the elements' axial forces under
the quasi-static inertia loads at the scene's speed (``prestress``), C = beta Psi^T K_E Psi with
beta = 2 zeta / (2 pi f_ref) (:mod:`ked_quasi.damping`), f_ref by default the first natural frequency of
the frozen structure averaged over the grid.

Output: (dx, dy, rotation) of the section at P, as for the four-bar, plus the coupler's midspan deflection
normal to its chord (``ked_quasi.slider_static.midspan_deflection``), all from u by static condensation.
SI units; vectorized over crank angles.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ked_quasi.damping import rayleigh_beta
from ked_quasi.frame import _congruence, _local_stiffness, _rotate, _static_modes
from ked_quasi.slider_static import (
    SliderTopology,
    force_transformation,
    inertia_loads,
    node_masses,
    node_positions,
    slider_natural_frequencies,
    slider_topology,
)
from ked_quasi.slidercrank import SliderScene, slider_kinematics, slider_lumps
from ked_quasi.stress import StressHistory
from ked_quasi.units import omega1_min, speed_ratio

from .floquet import floquet
from .periodic import Coefficients, PeriodicSystem, steady_state
from .result import MAX_COORDINATES, LinearResult, _message
from .sampled import SampledCoefficients
from .settings import LinearSettings

OUTPUTS = ("dx", "dy", "rotation", "midspan")
"""Rows of the output map: dx, dy [m] and rotation [rad] of the section at P, the midspan deflection [m]."""

OUTPUT_GROUPS = (slice(0, 2), slice(2, 3), slice(3, 4))
"""Error measure of the history: (dx, dy) as a vector, the rotation, the midspan deflection, each against
its own peak."""


@dataclass(frozen=True)
class SliderFrame:
    """Angle-independent dof numbering of the slider-crank frame.

    elem_dofs (E, 6): dofs (u_i, v_i, th_i, u_j, v_j, th_j) of each element (topology order), -1 at the
    clamp M; n_dofs: all dofs (node k: x at 2k, y at 2k + 1, rotations after); free: the dofs the frozen
    structure lets move (without B's normal to the slider line, and without a rigid crank's dofs);
    elastic (E,): whether the element deforms (not on a rigid link); p_rotation: the dof of the section
    rotation at P; master (k,): the free translational dofs of nodes with mass (the coordinates u);
    mass (k,) [kg]: their masses.
    """

    topology: SliderTopology
    elem_dofs: np.ndarray
    n_dofs: int
    free: np.ndarray
    elastic: np.ndarray
    p_rotation: int
    master: np.ndarray
    mass: np.ndarray


def slider_frame(scene: SliderScene) -> SliderFrame:
    """The frame model of ``scene``'s frozen slider-crank (ValueError for a rigid coupler)."""
    sc = scene.linkage
    if sc.is_rigid("coupler"):
        raise ValueError("SliderCrank.rigid: the linear KED model of a slider-crank needs an elastic coupler "
                         "(rigid = false for the coupler); a rigid coupler is analysed by 'ked quasi' only")
    lm = slider_lumps(sc, scene.mass_model)
    topo = slider_topology(sc, lm)
    N = topo.n_nodes
    rot: dict[tuple[str, int], int] = {}

    def rot_dof(key: tuple[str, int]) -> int:
        return rot.setdefault(key, 2 * N + len(rot))

    a, b = topo.node_of("coupler", 0.0), topo.node_of("coupler", 1.0)
    p_rot = rot_dof(("node", topo.p_index))

    def end(link: str, s: float) -> list[int]:
        if link == "crank" and s == 0.0:
            return [-1, -1, -1]  # clamped at M
        k = topo.node_of(link, s)
        key = (link, k) if k in (a, b) else ("node", k)  # pins at A and B: one rotation per link end
        return [2 * k, 2 * k + 1, rot_dof(key)]

    elem = np.array([end(lk, s0) + end(lk, s1) for lk, s0, s1 in zip(topo.elem_link, topo.elem_s0, topo.elem_s1)])
    n_dofs = 2 * N + len(rot)
    fixed = {2 * b + 1}  # the slider holds B on its line (the line is parallel to x)
    if sc.is_rigid("crank"):  # a rigid crank clamped at M holds its points and A fixed
        for k in [k for k in range(N) if topo.node_link[k] == "crank"] + [a]:
            fixed |= {2 * k, 2 * k + 1}
        fixed |= {d for key, d in rot.items() if key[0] == "crank"
                  or (key[0] == "node" and topo.node_link[key[1]] == "crank")}
    free = np.array([d for d in range(n_dofs) if d not in fixed])
    m_node = node_masses(topo, lm)
    master, mass = [], []
    for k in np.flatnonzero(m_node > 0.0):
        for d in (2 * k, 2 * k + 1):
            if d not in fixed:
                master.append(d)
                mass.append(m_node[k])
    elastic = np.array([not sc.is_rigid(lk) for lk in topo.elem_link])
    return SliderFrame(topology=topo, elem_dofs=elem, n_dofs=n_dofs, free=free, elastic=elastic, p_rotation=p_rot,
                       master=np.array(master, dtype=int), mass=np.array(mass, float))


def elastic_coordinates(scene: SliderScene) -> int:
    """Number of elastic coordinates u of the linear model of ``scene`` (no frame solve)."""
    return int(slider_frame(scene).master.size)


def _element_axes(scene: SliderScene, topo: SliderTopology, kin) -> tuple[np.ndarray, np.ndarray]:
    """Element lengths (E,) [m] and unit axes (n, E) (complex, root to tip)."""
    sc = scene.linkage
    lengths = np.array([(s1 - s0) * sc.length(lk) for lk, s0, s1 in zip(topo.elem_link, topo.elem_s0, topo.elem_s1)])
    crank = np.exp(1j * kin.crank_angle)
    rod = (kin.zB - kin.zA) / np.abs(kin.zB - kin.zA)
    on_crank = np.array([lk == "crank" for lk in topo.elem_link])
    return lengths, np.where(on_crank, crank[:, None], rod[:, None])


def assemble(scene: SliderScene, frame: SliderFrame, axes: np.ndarray, lengths: np.ndarray,
             axial_force: np.ndarray | None = None, elastic: bool = True) -> np.ndarray:
    """Global stiffness (n, n_dofs, n_dofs) of the frozen frame: the elastic part (``elastic``) plus the
    geometric stiffness of ``axial_force`` (n, E) [N, tension > 0]; rigid links contribute nothing."""
    sc, topo = scene.linkage, frame.topology
    n = axes.shape[0]
    EA = np.array([sc.section(lk).axial_stiffness for lk in topo.elem_link]) * elastic
    EI = np.array([sc.section(lk).bending_stiffness for lk in topo.elem_link]) * elastic
    Nax = np.zeros((n, lengths.size)) if axial_force is None else axial_force
    ke = _rotate(_local_stiffness(lengths, EA, EI, Nax), axes)  # (n, E, 6, 6)
    K = np.zeros((n, frame.n_dofs, frame.n_dofs))
    for e, dofs in enumerate(frame.elem_dofs):
        if not frame.elastic[e]:
            continue
        ok = np.flatnonzero(dofs >= 0)
        K[:, dofs[ok][:, None], dofs[ok][None, :]] += ke[:, e][:, ok[:, None], ok[None, :]]
    return K


def axial_forces(scene: SliderScene, topo: SliderTopology, X: np.ndarray, kin, loads: np.ndarray) -> np.ndarray:
    """Axial force N (n, E) [N, tension > 0] of each element under the d'Alembert ``loads`` (n, N, 2), from
    the quasi-static force transformation (statically determinate)."""
    n = loads.shape[0]
    P = np.concatenate([loads.reshape(n, -1), np.zeros((n, 1))], axis=1)
    beta = force_transformation(topo, X, kin)
    return np.einsum("nmd,nd->nm", beta, P).reshape(n, -1, 3)[..., 0]


@dataclass(frozen=True)
class SliderCondensed:
    """The frozen slider-crank condensed on u at n crank angles: stiffness, material_stiffness (n, k, k)
    [N/m] (with and without the geometric stiffness), mass (k,) [kg], load (n, k) [N], output (n, 4, k):
    :data:`OUTPUTS` per unit u."""

    stiffness: np.ndarray
    material_stiffness: np.ndarray
    mass: np.ndarray
    load: np.ndarray
    output: np.ndarray


def condensed_slider(scene: SliderScene, crank_angle: np.ndarray | None = None,
                     prestress: bool = False) -> SliderCondensed:
    """Static condensation of the slider-crank frame on the mass coordinates at the crank angles [rad]
    (default ``scene.crank_angles``); ``prestress``: add the geometric stiffness of the axial forces of the
    quasi-static inertia loads at the scene's speed."""
    theta = scene.crank_angles if crank_angle is None else np.atleast_1d(np.asarray(crank_angle, float))
    frame = slider_frame(scene)
    topo = frame.topology
    lm = slider_lumps(scene.linkage, scene.mass_model)
    kin = slider_kinematics(scene.linkage, theta, scene.rpm)
    X = node_positions(topo, kin)
    loads = inertia_loads(scene, topo, lm, kin)  # (n, N, 2)
    lengths, axes = _element_axes(scene, topo, kin)
    K_E = assemble(scene, frame, axes, lengths)
    K = K_E
    if prestress:
        K = K_E + assemble(scene, frame, axes, lengths, axial_forces(scene, topo, X, kin, loads), elastic=False)
    free = frame.free
    master = np.searchsorted(free, frame.master)  # positions of the masters among the free dofs
    Kf = K[:, free[:, None], free[None, :]]
    psi = _static_modes(Kf, master)
    full = np.zeros((theta.size, frame.n_dofs, master.size))
    full[:, free] = psi
    Kc = _congruence(psi, Kf)
    Km = Kc if not prestress else _congruence(psi, K_E[:, free[:, None], free[None, :]])
    p, mid = topo.p_index, topo.mid_index
    a, b = topo.node_of("coupler", 0.0), topo.node_of("coupler", 1.0)
    z = full[:, 0::2][:, :topo.n_nodes] + 1j * full[:, 1::2][:, :topo.n_nodes]  # (n, N, k) complex node moves
    normal = 1j * (kin.zB - kin.zA) / np.abs(kin.zB - kin.zA)
    rel = z[:, mid] - 0.5 * (z[:, a] + z[:, b])
    midspan = (np.conj(normal)[:, None] * rel).real
    out = np.stack([full[:, 2 * p], full[:, 2 * p + 1], full[:, frame.p_rotation], midspan], axis=1)
    flat = loads.reshape(theta.size, -1)
    return SliderCondensed(stiffness=Kc, material_stiffness=Km, mass=frame.mass, load=flat[:, frame.master],
                           output=out)


def slider_damping_reference_hz(scene: SliderScene) -> float:
    """Default damping reference frequency [Hz]: the first natural frequency of the frozen slider-crank
    (``ked_quasi.slider_static.slider_natural_frequencies``) averaged over ``scene.crank_angles``."""
    return float(np.nanmean(slider_natural_frequencies(scene, n_modes=1)[:, 0]))


@dataclass(frozen=True)
class SliderSystem:
    """The slider-crank's periodic system plus its damping: reference frequency [Hz] and beta [s]."""

    system: PeriodicSystem
    damping_reference_hz: float
    damping_beta: float


def slider_system(scene: SliderScene, settings: LinearSettings) -> SliderSystem:
    """The linear KED equations of a slider-crank ``scene`` as a :class:`~ked_linear.periodic.PeriodicSystem`
    (output rows :data:`OUTPUTS`)."""
    f_ref = settings.damping_reference_hz
    f_ref = slider_damping_reference_hz(scene) if f_ref is None else float(f_ref)
    beta = rayleigh_beta(settings.damping_ratio, f_ref)

    def direct(theta: np.ndarray) -> Coefficients:
        cs = condensed_slider(scene, theta, prestress=settings.prestress)
        return Coefficients(stiffness=cs.stiffness, damping=beta * cs.material_stiffness, load=cs.load,
                            output=cs.output)

    system = PeriodicSystem(mass=slider_frame(scene).mass, speed=scene.linkage.sign * scene.omega,
                            coefficients=SampledCoefficients(direct))
    return SliderSystem(system=system, damping_reference_hz=f_ref, damping_beta=beta)


def slider_frozen_frequencies(scene: SliderScene, crank_angle: np.ndarray | None = None, prestress: bool = False,
                              n_modes: int = 1) -> np.ndarray:
    """Natural frequencies [Hz] (n, n_modes) of (M, K(theta)), lowest first; an imaginary one (a buckled
    prestressed structure) is returned negative."""
    theta = scene.crank_angles if crank_angle is None else np.atleast_1d(np.asarray(crank_angle, float))
    cs = condensed_slider(scene, theta, prestress=prestress)
    w = 1.0 / np.sqrt(cs.mass)
    lam = np.linalg.eigvalsh(w[:, None] * cs.stiffness * w[None, :])[:, :n_modes]
    return np.sign(lam) * np.sqrt(np.abs(lam)) / (2.0 * np.pi)


def solve_slider_linear(scene: SliderScene, settings: LinearSettings | None = None) -> SliderLinearResult:
    """Periodic steady state and Floquet stability of the linear KED model of a slider-crank ``scene``:
    a :class:`SliderLinearResult` (the four-bar's :class:`~ked_linear.solver.LinearResult` plus the
    midspan deflection)."""
    t0 = time.perf_counter()
    settings = LinearSettings() if settings is None else settings
    if not isinstance(settings, LinearSettings):
        raise TypeError(f"settings must be a LinearSettings, got {type(settings).__name__}")
    size = elastic_coordinates(scene)
    if size == 0:
        raise ValueError("slider-crank: no elastic coordinate carries mass (give the coupler mass, a payload or "
                         "a slider mass): the linear KED model has nothing to move")
    if size > MAX_COORDINATES:
        raise ValueError(f"mass model: the linear KED model takes at most {MAX_COORDINATES} elastic coordinates "
                         f"(its memory grows as their square times the Floquet steps); this slider-crank has "
                         f"{size}: use fewer lumps per link")
    ls = slider_system(scene, settings)
    theta = scene.crank_angles
    ss = steady_state(ls.system, theta, settings.tolerance, settings.harmonics, settings.max_harmonics,
                      OUTPUT_GROUPS)
    fl = floquet(ls.system, settings.floquet_tolerance, settings.floquet_steps)
    err = fl.error_estimate if np.isfinite(fl.error_estimate) else 0.0
    stable = bool(fl.max_abs + err < 1.0)
    marginal = not stable and settings.damping_ratio == 0.0 and fl.max_abs - 1.0 <= err
    status = "ok" if stable else "marginal" if marginal else "unstable"
    out = ss.output if stable else np.full_like(ss.output, np.nan)
    f1 = slider_natural_frequencies(scene, n_modes=1)[:, 0]
    return SliderLinearResult(
        crank_angle=theta, deflection=out[:, :3], midspan=out[:, 3], status=status, stable=stable,
        message=_message(status, fl.max_abs, fl.error_estimate, ss.error_estimate, settings.tolerance,
                         ss.solution.harmonics),
        floquet_max_abs=fl.max_abs, floquet_error=fl.error_estimate, floquet_steps=fl.steps,
        harmonics=ss.solution.harmonics, collocation_points=ss.solution.points, error_estimate=ss.error_estimate,
        damping_reference_hz=ls.damping_reference_hz, damping_beta=ls.damping_beta,
        speed_ratio=speed_ratio(scene.omega, omega1_min(f1)),
        frozen_f1_hz=slider_frozen_frequencies(scene, theta, settings.prestress)[:, 0], settings=settings,
        wall_s=time.perf_counter() - t0,
    )


@dataclass(frozen=True)
class SliderLinearResult(LinearResult):
    """:class:`~ked_linear.solver.LinearResult` of a slider-crank, plus ``midspan`` (n,) [m]: the coupler's
    midspan deflection normal to its chord (CCW normal of A->B), NaN when not stable."""

    midspan: np.ndarray | None = None


def dynamic_stress(scene: SliderScene, settings: LinearSettings, theta: np.ndarray) -> StressHistory:
    """The slider-crank model's stress under -M (a_rigid + u'') at ``theta`` [rad], on the model that carries the
    dynamics (:func:`ked_linear.lumping.dynamic_scene`; no static correction here: :mod:`ked_linear.stress`)."""
    from ked_quasi.slider_static import _frozen, inertia_loads
    from ked_quasi.stress import slider_stress

    from .lumping import dynamic_scene
    from .motion import MAX_ERROR, STEP_RAD
    from .periodic import steady_state

    scene, settings = dynamic_scene(scene, settings)
    system = slider_system(scene, settings).system
    offsets = STEP_RAD * np.arange(-2, 3)
    ss = steady_state(system, (theta[:, None] + offsets).ravel(), settings.tolerance, settings.harmonics,
                      settings.max_harmonics)
    if not ss.error_estimate <= MAX_ERROR:
        raise ValueError(f"linear steady state not resolved (estimated error {ss.error_estimate:.2g} of the peak)")
    u = np.asarray(ss.displacement).reshape(theta.size, offsets.size, -1)
    d2 = (-u[:, 0] + 16 * u[:, 1] - 30 * u[:, 2] + 16 * u[:, 3] - u[:, 4]) / (12 * STEP_RAD**2)
    frame = slider_frame(scene)
    lm, topo, kin, _ = _frozen(scene, theta)
    loads = inertia_loads(scene, topo, lm, kin)
    loads[:, frame.master // 2, frame.master % 2] -= frame.mass * system.speed**2 * d2
    return slider_stress(scene, theta, loads, tier="linear")


def reduced_stability(scene: SliderScene, system: PeriodicSystem, settings: LinearSettings,
                      reductions: object = None) -> None:
    """None: the slider-crank has no reduced system in co-rotating frames; its full propagator decides."""
    return None


__all__ = ["OUTPUTS", "SliderCondensed", "SliderFrame", "SliderLinearResult", "SliderSystem", "condensed_slider",
           "elastic_coordinates", "slider_damping_reference_hz", "slider_frame", "slider_frozen_frequencies",
           "slider_system", "solve_slider_linear"]
