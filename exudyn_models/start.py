"""Initial state of the constant-speed phase close to the periodic orbit (settings.start = "quasi_static" or
"linear").

The driven model is built in the rigid configuration at crank angle 0 (Drive with ramp_time 0) and
starts at full speed. Its ODE2 coordinates q (displacements from that reference), velocities and
accelerations at t = 0 are set to

    q0 = u(0),   v0 = s Omega (dq_r/dtheta + du/dtheta),   a0 = Omega^2 (d2q_r/dtheta2 + d2u/dtheta2)

with q_r(theta) the rigid-kinematics coordinates of every node (rigid_coordinates: nodes equally spaced on
the straight links, ANCF slopes the unit link directions, rotations the link angles, all from
ked_quasi.kinematics.joint_positions) and u(theta) the quasi-static deflection: an Exudyn static solve
(geometrically nonlinear) of the frozen linkage at theta under the d'Alembert loads -M a_r(theta)
(M: the model's own consistent mass matrix, so point masses and distributed mass are treated alike;
a_r = Omega^2 d2q_r/dtheta2 at constant speed). Derivatives in theta: central differences (5 points,
RIGID_STEP_RAD, for q_r; 3 static solves QS_STEP_RAD apart for u). Damping forces of the quasi-static
motion are left out (they are O(zeta) of the elastic ones). This starts the transient at the dynamic
part of the response (orbit minus quasi-static) instead of at the whole response plus the ramp's
own excitation.

start = "linear" (:func:`linear_state`) adds that dynamic part: the static solves carry the d'Alembert loads of
the whole motion, -M (a_r + a_e), with a_e the elastic accelerations of the linear model's periodic steady state
(``ked_linear.motion``: its masses, interpolated along each link to the model's nodes, zero at the ground
pivots).  A static solve under the loads of the whole motion is the mode-acceleration form of the dynamic
deflection (exact but for the damping forces, O(zeta)), so the start lies on the linear model's orbit, which is
within about 1 % of the peak of Exudyn's wherever the linear model's range holds.  Where the linear answer is
unavailable (not stable, not resolved, a failure) it falls back to the quasi-static start and says so.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import exudyn as exu
import exudyn.itemInterface as eii
import numpy as np

from .builder import LINK_ENDS, BuiltModel, build_model, rigid_joints
from .settings import DynamicSettings

RIGID_STEP_RAD = 1e-3
"""Crank-angle step [rad] of the 5-point differences of the rigid node coordinates (error ~1e-12 m)."""
QS_STEP_RAD = math.radians(5.0)
"""Crank-angle step [rad] between the three quasi-static solves whose differences give the deflection
rate (error of the rate ~ (5 deg)^2 / 6 of its third derivative: ~0.1 % of a start that is itself only
an approximation of the orbit)."""
LINEAR_STEP_RAD = math.radians(1.0)
"""The same step for the linear start, whose state is meant to lie on the orbit: the rate of crank harmonic k
is then within (k h)^2 / 6 = 0.5 % at k = 10 (3 % at 5 deg)."""


@dataclass(frozen=True)
class StartState:
    """ODE2 coordinates q [m, -, rad], velocities v and accelerations a (SI) of the model at t = 0, and
    a note of how they were obtained ("quasi-static" or why it fell back to the rigid motion)."""

    q: np.ndarray
    v: np.ndarray
    a: np.ndarray
    note: str


def _node_layout(model: BuiltModel) -> list[tuple[str, int, int, int]]:
    """(link or "hub", index along the link, node number, first ODE2 index) of every ODE2 node."""
    mbs = model.mbs
    out = []
    in_links = set()
    for link, nodes in model.link_nodes.items():
        for i, n in enumerate(nodes):
            out.append((link, i, n, int(mbs.GetNodeODE2Index(n))))
            in_links.add(n)
    for n in range(mbs.systemData.NumberOfNodes()):
        if n not in in_links and mbs.GetNode(n)["nodeType"] == "RigidBody2D":
            out.append(("hub", 0, n, int(mbs.GetNodeODE2Index(n))))
    return out


def _absolute_node_coordinates(model: BuiltModel, scene, theta: float) -> np.ndarray:
    """Absolute coordinates of every node of the rigid linkage at crank angle theta [rad] (ODE2 layout);
    link angles are made continuous relative to the model's reference by rigid_coordinates."""
    joints = rigid_joints(scene.fourbar, theta)
    n_el = model.settings.elements_per_link
    ancf = model.settings.element == "ancf"
    q = np.zeros(model.mbs.systemData.ODE2Size())
    for link, i, _, k in _node_layout(model):
        if link == "hub":
            d = joints["A"] - joints["M"]
            q[k:k + 3] = (joints["M"][0], joints["M"][1], math.atan2(d[1], d[0]))
            continue
        root, tip = (joints[j] for j in LINK_ENDS[link])
        d = tip - root
        length = float(np.hypot(*d))
        p = root + (i / n_el) * d
        if ancf:
            q[k:k + 4] = (p[0], p[1], d[0] / length, d[1] / length)
        else:
            q[k:k + 3] = (p[0], p[1], math.atan2(d[1], d[0]))
    return q


def _rotation_indices(model: BuiltModel) -> tuple[np.ndarray, np.ndarray]:
    """ODE2 indices of rotation coordinates: (turning with the crank, oscillating)."""
    crank, other = [], []
    for link, _, _, k in _node_layout(model):
        if link == "hub" or (link == "crank" and model.settings.element != "ancf"):
            crank.append(k + 2)
        elif model.settings.element != "ancf":
            other.append(k + 2)
    return np.array(crank, dtype=int), np.array(other, dtype=int)


def rigid_coordinates(model: BuiltModel, scene, theta: float) -> np.ndarray:
    """ODE2 coordinates (displacements from the model's reference configuration) of the rigid linkage at
    the unwrapped crank angle theta [rad]: rotations of the crank and hub are theta - start angle
    (they turn a full revolution per cycle), other rotations are wrapped to (-pi, pi]."""
    q = _absolute_node_coordinates(model, scene, theta) - _absolute_node_coordinates(model, scene, model.start_angle)
    crank, other = _rotation_indices(model)
    q[crank] = theta - model.start_angle
    q[other] = np.mod(q[other] + math.pi, 2.0 * math.pi) - math.pi
    return q


def rigid_motion(model: BuiltModel, scene, theta: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(q, dq/dtheta, d2q/dtheta2) of the rigid linkage at crank angle theta (5-point differences)."""
    h = RIGID_STEP_RAD
    qs = [rigid_coordinates(model, scene, theta + j * h) for j in (-2, -1, 0, 1, 2)]
    d1 = (qs[0] - 8 * qs[1] + 8 * qs[3] - qs[4]) / (12 * h)
    d2 = (-qs[0] + 16 * qs[1] - 30 * qs[2] + 16 * qs[3] - qs[4]) / (12 * h * h)
    return qs[2], d1, d2


def mass_matrix(model: BuiltModel) -> np.ndarray:
    """The model's ODE2 mass matrix (dense) [kg, kg m, ...] from Exudyn."""
    solver = exu.MainSolverImplicitSecondOrder()
    sset = exu.SimulationSettings()
    sset.solution.file.write = False
    sset.solution.sensors.writePeriod = 1e30
    sset.linearSolver.solverType = exu.LinearSolverType.EXUdense
    sset.timeIntegration.generalizedAlpha.computeInitialAccelerations = False
    sset.timeIntegration.verboseMode = 0
    solver.InitializeSolver(model.mbs, sset)
    solver.ComputeMassMatrix(model.mbs)
    M = np.array(solver.GetSystemMassMatrix())
    solver.FinalizeSolver(model.mbs, sset)
    n = model.mbs.systemData.ODE2Size()
    return M[:n, :n]


def static_deflection(scene, settings: DynamicSettings, theta: float, loads: np.ndarray) -> np.ndarray:
    """ODE2 displacements u [m, -, rad] of the frozen linkage at crank angle theta under generalized loads
    (ODE2 layout of a model built at theta) by Exudyn's (nonlinear) static solver. Raises RuntimeError
    if it does not converge."""
    model = build_model(scene, settings, frozen_angle=theta, damping_beta=0.0, p_sensor=False)
    mbs = model.mbs
    for _, _, node, k in _node_layout(model):
        ncoord = 4 if (settings.element == "ancf" and node not in _hub_nodes(model)) else 3
        for c in range(ncoord):
            if loads[k + c] != 0.0:
                m = mbs.AddMarker(eii.MarkerNodeCoordinate(nodeNumber=node, coordinate=c))
                mbs.AddLoad(eii.LoadCoordinate(markerNumber=m, load=float(loads[k + c])))
    mbs.Assemble()
    sset = exu.SimulationSettings()
    sset.solution.file.write = False
    sset.solution.sensors.writePeriod = 1e30
    sset.staticSolver.verboseMode = 0
    sset.staticSolver.numberOfLoadSteps = 4
    sset.staticSolver.newton.absoluteTolerance = max(1e-8, 1e-13 * max(
        s.youngs_modulus * s.area for s in scene.fourbar.sections))
    sset.staticSolver.newton.relativeTolerance = 1e-10
    sset.linearSolver.solverType = exu.LinearSolverType.EXUdense
    solver = exu.MainSolverStatic()
    if not solver.SolveSystem(mbs, sset):
        raise RuntimeError("static solve did not converge")
    return np.array(mbs.systemData.GetODE2Coordinates())


def _hub_nodes(model: BuiltModel) -> set[int]:
    return {n for link, _, n, _ in _node_layout(model) if link == "hub"}


def quasi_static_state(model: BuiltModel, scene) -> StartState:
    """Start state at crank angle 0 and full speed (see module doc); if a static solve fails (e.g. near a
    toggle) the rigid motion alone (u = 0), with the reason in the note."""
    zero = np.zeros(model.mbs.systemData.ODE2Size())
    return _state_under_loads(model, scene, lambda j: zero, "quasi-static")


def set_initial_state(model: BuiltModel, q: np.ndarray, v: np.ndarray, a: np.ndarray,
                      ae: np.ndarray | None = None) -> None:
    """Write q, v, a (and optionally the algebraic coordinates) as the model's initial state."""
    sd = model.mbs.systemData
    init = exu.ConfigurationType.Initial
    sd.SetODE2Coordinates(np.asarray(q, dtype=float).tolist(), configuration=init)
    sd.SetODE2Coordinates_t(np.asarray(v, dtype=float).tolist(), configuration=init)
    sd.SetODE2Coordinates_tt(np.asarray(a, dtype=float).tolist(), configuration=init)
    if ae is not None and len(ae):
        sd.SetAECoordinates(np.asarray(ae, dtype=float).tolist(), configuration=init)


def _elastic_accelerations(model: BuiltModel, motion, j: int) -> np.ndarray:
    """ODE2 vector [m/s^2] of the elastic accelerations at the model's translation coordinates at angle j of
    ``motion`` (ked_linear.motion.MassMotion): per link, linear in s between the masses on it or at its end
    joints (constant beyond the outermost), zero at the ground pivots M and Q; slopes and rotations get none."""
    where: dict[str, list[tuple[float, np.ndarray]]] = {link: [] for link in LINK_ENDS}
    for link, s_k, acc in zip(motion.link, motion.s, motion.acceleration[j]):
        joint = LINK_ENDS[link][0] if s_k <= 1e-12 else LINK_ENDS[link][1] if s_k >= 1.0 - 1e-12 else None
        for other, ends in LINK_ENDS.items():  # a mass at a joint moves every link that meets there
            if other == link or joint in ends:
                s_o = float(s_k) if other == link else (0.0 if ends[0] == joint else 1.0)
                where[other].append((s_o, acc))
    for link, ends in LINK_ENDS.items():
        if ends[0] in ("M", "Q"):
            where[link].append((0.0, np.zeros(2)))
    out = np.zeros(model.mbs.systemData.ODE2Size())
    n_el = model.settings.elements_per_link
    for link, i, _, k in _node_layout(model):
        pts = sorted(where.get(link, []), key=lambda p: p[0])
        if link == "hub" or not pts:
            continue
        s_pts = np.array([p[0] for p in pts])
        a_pts = np.array([p[1] for p in pts])
        out[k:k + 2] = [np.interp(i / n_el, s_pts, a_pts[:, c]) for c in (0, 1)]
    return out


def linear_state(model: BuiltModel, scene, checked: bool = False) -> StartState:
    """Start state at crank angle 0 and full speed on the linear model's orbit (see the module doc); the
    quasi-static start, with the reason in its note, where the linear answer cannot start the run
    (:func:`linear_start_problem`, asked here unless the caller did: ``checked``) or its masses' motion is not
    resolved."""
    from ked_linear.motion import mass_motion

    angles = model.start_angle + LINEAR_STEP_RAD * np.arange(-1, 2)
    problem = "" if checked else linear_start_problem(scene, model.settings)
    try:
        if problem:
            raise ValueError(problem)
        motion = mass_motion(scene, _linear_settings(model.settings), angles)
    except (ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
        st = quasi_static_state(model, scene)
        return StartState(st.q, st.v, st.a, f"{st.note} (linear start unavailable: {str(exc)[:200]})")
    return _state_under_loads(model, scene, lambda j: _elastic_accelerations(model, motion, j), "linear",
                              LINEAR_STEP_RAD)


def _linear_settings(settings: DynamicSettings):
    """The linear model's settings of the same damping as an Exudyn run's."""
    from ked_linear import LinearSettings

    return LinearSettings(damping_ratio=settings.damping_ratio, damping_reference_hz=settings.damping_reference_hz)


def linear_start_problem(scene, settings: DynamicSettings) -> str:
    """Why the linear model's periodic answer cannot start this run ("" when it can): it is unavailable, not
    stable, or outside its range (its flags: small-deflection bounds, "unresolved", "weakly_damped",
    ``ked_linear.result_flags``).  The run then starts from the ramp, as without the linear start."""
    from ked_linear import result_flags, solve_linear

    try:
        res = solve_linear(scene, _linear_settings(settings))
    except (ValueError, ArithmeticError, np.linalg.LinAlgError) as exc:
        return f"linear answer unavailable: {str(exc)[:200]}"
    if not res.stable:
        return f"linear answer not stable: {res.message[:200]}"
    flags = result_flags(res, scene.linkage)
    return f"linear answer outside its range: {', '.join(flags)}" if flags else ""


def _state_under_loads(model: BuiltModel, scene, elastic, note: str, step: float = QS_STEP_RAD) -> StartState:
    """q, v, a at the start angle from static solves at the start angle and ``step`` [rad] either side under
    -M (a_r + elastic(j)) (j = 0, 1, 2 for the three angles); the rigid motion alone if a solve fails."""
    omega, sign, theta0 = model.drive.omega, model.drive.sign, model.start_angle
    q_r, dq_r, d2q_r = rigid_motion(model, scene, theta0)
    M = mass_matrix(model)
    try:
        u = {}
        for j in (-1, 0, 1):
            th = theta0 + j * step
            _, _, acc = rigid_motion(model, scene, th)
            u[j] = static_deflection(scene, model.settings, th, -M @ (omega * omega * acc + elastic(j + 1)))
        du = (u[1] - u[-1]) / (2.0 * step)
        d2u = (u[1] - 2.0 * u[0] + u[-1]) / step**2
    except RuntimeError as exc:
        u = {0: np.zeros_like(q_r)}
        du = d2u = np.zeros_like(q_r)
        note = f"rigid motion ({note} shape unavailable: {exc})"
    return StartState(q=q_r + u[0], v=sign * omega * (dq_r + du), a=omega * omega * (d2q_r + d2u), note=note)
