"""Scene -> Exudyn MainSystem of the elastic four-bar (no graphics, no files, only needed items).

Topology (geometry and kinematics only from ked_quasi; crank angles as in ked_quasi):
    crank    M -> A    clamped at M to the drive hub (JointGeneric x, y, rotation)
    coupler  A -> B    pinned to the crank end at A (ObjectJointRevolute2D on node positions)
    extender A -> P    rigidly joined to the coupler at A at the rigid coupler angle
                       (JointGeneric x, y, rotation between MarkerBodyRigid frames)
    follower Q -> B    pinned to ground at Q (CoordinateConstraints on the node's x, y) and to the
                       coupler end at B (ObjectJointRevolute2D)
Every link is a straight elastic beam of `elements_per_link` ObjectANCFCable2D (default) or
ObjectBeamGeometricallyExact2D elements, built in the rigid configuration at the start crank angle,
which is also the stress-free reference configuration. The drive hub is a rigid 2D node at M whose
x, y are fixed and whose rotation is prescribed by a CoordinateConstraint with a user offset
(exudyn_models.drive), or held fixed for a frozen model.

Masses (same lumps as ked_quasi.massmodel.lumps): for "tip", "joints", "extender" every lump is an
exact point mass on the beam element that contains it: an ObjectGenericODE2 per element with the
constant mass matrix m * S(xi)^T S(xi), S being the element's position interpolation (cubic Hermite
for ANCF, linear for the geometrically exact beam), so a lump anywhere along a link is modelled
without an extra node. The links carry no mass of their own in these models (exactly zero mass is
fine for time integration with zero initial accelerations; eigenvalue analysis passes a tiny
`massless_link_mass_per_length`). Lumps at the fixed pivots M and Q are left out (they cannot move).
"distributed" uses the beams' own consistent distributed mass (density * area, plus rotary inertia
for the geometrically exact beam) instead of lumps, plus the payload (if any) as a point mass at P.

Units SI; global frame as in ked_quasi.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import exudyn as exu
import exudyn.itemInterface as eii
import numpy as np
from exudyn.beams import GenerateBeamElementsAlongLine

from ked_quasi.kinematics import joint_positions
from ked_quasi.massmodel import lumps as mass_lumps

from .damping import rayleigh_beta, reference_frequency
from .drive import Drive
from .settings import DynamicSettings

LINK_ENDS = {"crank": ("M", "A"), "coupler": ("A", "B"), "extender": ("A", "P"), "follower": ("Q", "B")}
"""Root and tip joint of each link; lumps' `s` is the fraction from the root (as in ked_quasi)."""

POISSON_RATIO = 0.3
"""Used only by the geometrically exact beam: shear modulus G = E / (2 (1 + nu))."""
SHEAR_CORRECTION = 5.0 / 6.0
"""Shear correction factor of the (rectangular) link sections, geometrically exact beam only."""
HUB_MASS_KG = 1.0
HUB_INERTIA_KGM2 = 1.0
"""The hub is fully prescribed, so its inertia never enters the motion; values are arbitrary."""


@dataclass
class BuiltModel:
    """An assembled Exudyn system plus the indices needed to run and read it.

    start_angle [rad]: crank angle of the reference (stress-free, rigid) configuration.
    drive: the crank drive, or None for a frozen model (crank held at start_angle).
    p_node: node at the coupler point P (tip of the extender); p_sensor: its coordinate sensor
    (None if not requested). p_reference: (x, y, slope angle) of P in the reference configuration.
    """

    system_container: exu.SystemContainer
    mbs: exu.MainSystem
    settings: DynamicSettings
    start_angle: float
    drive: Drive | None
    damping_beta: float
    p_node: int
    p_sensor: int | None
    p_reference: np.ndarray
    link_nodes: dict[str, list[int]] = field(default_factory=dict)
    link_elements: dict[str, list[int]] = field(default_factory=dict)
    mass_objects: list[int] = field(default_factory=list)


def _shape_matrix(element: str, xi: float, length: float) -> np.ndarray:
    """2 x ncoord position interpolation r(xi) = S q of one element (q = both nodes' coordinates)."""
    if element == "ancf":  # node coordinates (x, y, x', y'); cubic Hermite in xi, slopes scaled by L
        h = (1 - 3 * xi**2 + 2 * xi**3, length * (xi - 2 * xi**2 + xi**3),
             3 * xi**2 - 2 * xi**3, length * (-(xi**2) + xi**3))
        S = np.zeros((2, 8))
        for k, hk in enumerate(h):
            S[0, 2 * k], S[1, 2 * k + 1] = hk, hk
        return S
    S = np.zeros((2, 6))  # node coordinates (x, y, phi); linear position interpolation
    S[0, 0] = S[1, 1] = 1.0 - xi
    S[0, 3] = S[1, 4] = xi
    return S


def beam_template(element: str, section, mass_per_length: float, beta: float):
    """Exudyn beam-element template of one link: stiffness from `section` (ked_quasi Section),
    mass per length [kg/m] as given, stiffness-proportional damping beta [s] (exudyn_models.damping)."""
    E, A, I = section.youngs_modulus, section.area, section.second_moment
    if element == "ancf":
        return eii.ObjectANCFCable2D(
            massPerLength=mass_per_length, bendingStiffness=E * I, axialStiffness=E * A,
            bendingDamping=beta * E * I, axialDamping=beta * E * A,
            visualization=eii.VObjectANCFCable2D(show=False))
    G = E / (2.0 * (1.0 + POISSON_RATIO))
    rotary = mass_per_length * I / A if A > 0 else 0.0  # rho*I, scaled with the used mass per length
    return eii.ObjectBeamGeometricallyExact2D(
        nodeNumbers=[-1, -1], massPerLength=mass_per_length, crossSectionInertia=rotary,
        bendingStiffness=E * I, axialStiffness=E * A, shearStiffness=SHEAR_CORRECTION * G * A,
        bendingDamping=beta * E * I, axialDamping=beta * E * A,
        shearDamping=beta * SHEAR_CORRECTION * G * A,
        visualization=eii.VObjectBeamGeometricallyExact2D(show=False))


def build_model(scene, settings: DynamicSettings | None = None, *,
                frozen_angle: float | None = None, damping_beta: float | None = None,
                massless_link_mass_per_length: float = 0.0, p_sensor: bool = True) -> BuiltModel:
    """Build and assemble the Exudyn model of `scene` (a ked_quasi.solver.Scene).

    frozen_angle: if given [rad], the crank is held at that angle (frozen structure, e.g. for
        eigenvalues or static checks); otherwise it is driven by the drive of `settings` (make_drive):
        from rest at Drive.start_angle through the ramp, or at full speed from crank angle 0.
    damping_beta: stiffness-proportional damping coefficient [s]; None -> from settings
        (damping_ratio at damping_reference_hz, see exudyn_models.damping).
    massless_link_mass_per_length [kg/m]: mass per length given to links that are massless in the
        mass model (0 = exactly massless; eigenvalue analysis needs a tiny positive value).
    p_sensor: add one internal-storage coordinate sensor at P.
    """
    settings = DynamicSettings() if settings is None else settings
    if not isinstance(settings, DynamicSettings):
        raise TypeError("settings must be a DynamicSettings")
    if massless_link_mass_per_length < 0.0:
        raise ValueError("massless_link_mass_per_length must be non-negative")
    fourbar = scene.fourbar
    if not fourbar.extender > 0.0:
        raise ValueError("extender must be positive: the coupler point P is the extender tip")
    if damping_beta is None:
        damping_beta = rayleigh_beta(settings.damping_ratio, reference_frequency(scene, settings)) \
            if settings.damping_ratio > 0.0 else 0.0
    drive = None if frozen_angle is not None else make_drive(scene, settings)
    start_angle = float(frozen_angle) if drive is None else drive.start_angle
    joints = rigid_joints(fourbar, start_angle)

    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    link_nodes, link_elements = _add_links(mbs, scene, settings, joints, damping_beta,
                                           massless_link_mass_per_length)
    mass_objects = _add_point_masses(mbs, scene, settings, link_nodes)
    _add_joints(mbs, settings.element, joints, drive, link_nodes, link_elements)
    p_node = link_nodes["extender"][-1]
    sensor = _add_p_sensor(mbs, p_node) if p_sensor else None
    mbs.Assemble()
    ap = joints["P"] - joints["A"]
    p_reference = np.array([joints["P"][0], joints["P"][1], math.atan2(ap[1], ap[0])])
    return BuiltModel(system_container=SC, mbs=mbs, settings=settings, start_angle=start_angle,
                      drive=drive, damping_beta=float(damping_beta), p_node=int(p_node),
                      p_sensor=sensor, p_reference=p_reference, link_nodes=link_nodes,
                      link_elements=link_elements, mass_objects=mass_objects)


def make_drive(scene, settings: DynamicSettings) -> Drive:
    """The crank drive of a driven model: the smooth ramp over ramp_cycles (in whole time steps) for
    settings.start = "ramp", constant speed from crank angle 0 at t = 0 (ramp_time 0) otherwise."""
    if not scene.rpm > 0.0:
        raise ValueError(f"rpm must be positive, got {scene.rpm!r}")
    omega = 2.0 * math.pi * scene.rpm / 60.0
    sign = 1.0 if scene.fourbar.direction == "ccw" else -1.0
    if settings.start != "ramp":
        return Drive(omega=omega, ramp_time=0.0, sign=sign)
    ramp_steps = max(1, round(settings.ramp_cycles * settings.steps_per_cycle))  # whole steps
    ramp_time = ramp_steps / settings.steps_per_cycle * 2.0 * math.pi / omega
    return Drive(omega=omega, ramp_time=ramp_time, sign=sign)


def rigid_joints(fourbar, crank_angle: float) -> dict[str, np.ndarray]:
    """Rigid-kinematics joint positions (M, A, B, Q, P -> (2,) [m]) at one crank angle [rad]."""
    return {k: np.asarray(v, dtype=float)[0] for k, v in
            joint_positions(fourbar, np.array([crank_angle])).items()}


def _add_links(mbs, scene, settings: DynamicSettings, joints: dict[str, np.ndarray], damping_beta: float,
               massless_link_mass_per_length: float) -> tuple[dict[str, list[int]], dict[str, list[int]]]:
    """Every link as a straight beam of elements_per_link elements from its root to its tip joint;
    returns link -> node numbers and link -> element (object) numbers, both from the root."""
    distributed = scene.mass_model.name == "distributed"
    link_nodes: dict[str, list[int]] = {}
    link_elements: dict[str, list[int]] = {}
    for link, (root, tip) in LINK_ENDS.items():
        section = scene.fourbar.section(link)
        mu = section.mass_per_length if distributed else massless_link_mass_per_length
        template = beam_template(settings.element, section, mu, damping_beta)
        p0, p1 = joints[root], joints[tip]
        created = GenerateBeamElementsAlongLine(mbs, [p0[0], p0[1], 0.0], [p1[0], p1[1], 0.0],
                                                settings.elements_per_link, template)
        link_nodes[link] = [int(n) for n in created["nodes"]]
        link_elements[link] = [int(o) for o in created["elements"]]
        for n in link_nodes[link]:
            mbs.SetNodeParameter(n, "VdrawSize", 0.0)
    return link_nodes, link_elements


def _point_mass_items(scene) -> list[tuple[str, float, float]]:
    """(link, s, mass [kg]) of every lump carried as a point mass: the mass model's lumps, or for
    "distributed" only the payload at P (the beams carry the rest)."""
    mass_model = scene.mass_model
    if mass_model.name == "distributed":
        return [("extender", 1.0, float(mass_model.payload))] if mass_model.payload > 0.0 else []
    lp = mass_lumps(scene.fourbar, mass_model)
    return [(str(k), float(s), float(m)) for k, s, m in zip(lp.link, lp.s, lp.mass)]


def _add_point_masses(mbs, scene, settings: DynamicSettings, link_nodes: dict[str, list[int]]) -> list[int]:
    """One ObjectGenericODE2 per element that carries lumps, mass matrix sum of m S(xi)^T S(xi)."""
    element, n_el = settings.element, settings.elements_per_link
    per_element: dict[tuple[str, int], np.ndarray] = {}
    for link, s, m in _point_mass_items(scene):
        if m == 0.0 or (s <= 1e-12 and link in ("crank", "follower")):
            continue  # no mass, or a lump at a fixed pivot (M or Q): it never moves
        j = min(int(s * n_el), n_el - 1)
        xi = s * n_el - j
        S = _shape_matrix(element, xi, scene.fourbar.length(link) / n_el)
        key = (link, j)
        per_element[key] = per_element.get(key, 0.0) + m * S.T @ S
    mass_objects: list[int] = []
    for (link, j), M_e in per_element.items():
        nodes = link_nodes[link][j:j + 2]
        o = mbs.AddObject(eii.ObjectGenericODE2(
            name=f"point masses {link} element {j}", nodeNumbers=nodes, massMatrix=M_e,
            visualization=eii.VObjectGenericODE2(show=False)))
        mass_objects.append(int(o))
    return mass_objects


def _fix(mbs, m_ground: int, node: int, coordinate: int, **kw) -> int:
    """CoordinateConstraint of one node coordinate to ground (kw: offset user functions)."""
    m = mbs.AddMarker(eii.MarkerNodeCoordinate(nodeNumber=node, coordinate=coordinate))
    return int(mbs.AddObject(eii.CoordinateConstraint(markerNumbers=[m_ground, m],
                                                      visualization=eii.VCoordinateConstraint(show=False), **kw)))


def _add_drive_hub(mbs, m_ground: int, joints: dict[str, np.ndarray], drive: Drive | None) -> int:
    """Rigid hub node at M: x, y fixed, rotation prescribed by the drive (or held for a frozen model)."""
    crank_dir = joints["A"] - joints["M"]
    n_hub = mbs.AddNode(eii.NodeRigidBody2D(
        referenceCoordinates=[joints["M"][0], joints["M"][1], math.atan2(crank_dir[1], crank_dir[0])],
        visualization=eii.VNodeRigidBody2D(show=False)))
    mbs.AddObject(eii.ObjectRigidBody2D(nodeNumber=n_hub, mass=HUB_MASS_KG, inertia=HUB_INERTIA_KGM2,
                                        visualization=eii.VObjectRigidBody2D(show=False)))
    _fix(mbs, m_ground, n_hub, 0)
    _fix(mbs, m_ground, n_hub, 1)
    if drive is None:
        _fix(mbs, m_ground, n_hub, 2)
    else:
        offset, offset_t = drive.user_functions()
        _fix(mbs, m_ground, n_hub, 2, offsetUserFunction=offset, offsetUserFunction_t=offset_t)
    return int(n_hub)


def _rigid_marker_at_root(mbs, element: str, node: int, body: int, rotation=None) -> int:
    """Rigid frame at a link root: the ANCF element's (slope-based) frame (`body`), or the geometrically
    exact beam's rigid root `node` (its element does not provide body-rigid marker velocities);
    optionally rotated by the 3x3 `rotation` (local frame of the marker)."""
    ht = None if rotation is None else exu.HT(rotation=rotation, translation=[0.0, 0.0, 0.0])
    if element == "ancf":
        if ht is None:
            return int(mbs.AddMarker(eii.MarkerBodyRigid(bodyNumber=body, localPosition=[0.0, 0.0, 0.0])))
        return int(mbs.AddMarker(eii.MarkerBodyRigid(bodyNumber=body, localHT=ht)))
    if ht is None:
        return int(mbs.AddMarker(eii.MarkerNodeRigid(nodeNumber=node)))
    return int(mbs.AddMarker(eii.MarkerNodeRigid(nodeNumber=node, localHT=ht)))


def _clamp(mbs, marker0: int, marker1: int) -> None:
    """JointGeneric locking x, y and the rotation between two rigid markers."""
    mbs.AddObject(eii.ObjectJointGeneric(markerNumbers=[marker0, marker1], constrainedAxes=[1, 1, 0, 0, 0, 1],
                                         visualization=eii.VObjectJointGeneric(show=False)))


def _pin(mbs, node0: int, node1: int) -> None:
    """Revolute joint between two node positions."""
    m0 = mbs.AddMarker(eii.MarkerNodePosition(nodeNumber=node0))
    m1 = mbs.AddMarker(eii.MarkerNodePosition(nodeNumber=node1))
    mbs.AddObject(eii.ObjectJointRevolute2D(markerNumbers=[m0, m1],
                                            visualization=eii.VObjectJointRevolute2D(show=False)))


def _add_joints(mbs, element: str, joints: dict[str, np.ndarray], drive: Drive | None,
                link_nodes: dict[str, list[int]], link_elements: dict[str, list[int]]) -> None:
    """Ground pin Q, drive hub and crank clamp at M, pins A and B, rigid extender joint at A."""
    n_ground = mbs.AddNode(eii.NodePointGround(visualization=eii.VNodePointGround(show=False)))
    m_ground = mbs.AddMarker(eii.MarkerNodeCoordinate(nodeNumber=n_ground, coordinate=0))
    q_node = link_nodes["follower"][0]
    _fix(mbs, m_ground, q_node, 0)
    _fix(mbs, m_ground, q_node, 1)
    n_hub = _add_drive_hub(mbs, m_ground, joints, drive)

    def root_marker(link: str, rotation=None) -> int:
        return _rigid_marker_at_root(mbs, element, link_nodes[link][0], link_elements[link][0], rotation)

    _clamp(mbs, mbs.AddMarker(eii.MarkerNodeRigid(nodeNumber=n_hub)), root_marker("crank"))
    _pin(mbs, link_nodes["crank"][-1], link_nodes["coupler"][0])       # A
    _pin(mbs, link_nodes["coupler"][-1], link_nodes["follower"][-1])   # B
    # extender rigidly joined to the coupler at A, at the rigid angle gamma (AB -> AP, CCW)
    ab, ap = joints["B"] - joints["A"], joints["P"] - joints["A"]
    gamma = math.atan2(ab[0] * ap[1] - ab[1] * ap[0], ab @ ap)
    c, s = math.cos(gamma), math.sin(gamma)
    _clamp(mbs, root_marker("coupler", np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])),
           root_marker("extender"))


def _add_p_sensor(mbs, p_node: int) -> int:
    """Internal-storage coordinate sensor of the node at P (no file)."""
    return int(mbs.AddSensor(eii.SensorNode(
        nodeNumber=p_node, outputVariableType=exu.OutputVariableType.Coordinates,
        storeInternal=True, writeToFile=False, visualization=eii.VSensorNode(show=False))))


def p_pose(model: BuiltModel, coordinates: np.ndarray) -> np.ndarray:
    """(k, 3) absolute (x, y, slope angle [rad], unwrapped later) of P from (k, ncoord) node coordinates
    (displacements relative to the reference configuration, as stored by the P sensor)."""
    q = np.atleast_2d(coordinates)
    ref = model.p_reference
    x = ref[0] + q[:, 0]
    y = ref[1] + q[:, 1]
    if model.settings.element == "ancf":  # slope vector (reference slope is the unit tangent)
        phi = np.arctan2(math.sin(ref[2]) + q[:, 3], math.cos(ref[2]) + q[:, 2])
    else:
        phi = ref[2] + q[:, 2]
    return np.column_stack([x, y, phi])
