"""SliderScene -> Exudyn MainSystem of the elastic slider-crank (no graphics, no files).

Topology (geometry and kinematics only from ked_quasi.slidercrank; crank angles as there: CCW from +x,
the slider line y = offset parallel to x):
    drive hub  rigid 2D node at the crank pivot M: x, y fixed, rotation prescribed by the crank drive
               (exudyn_models.drive, a CoordinateConstraint with a user offset), reference rotation the
               crank angle, so the hub's local x axis points along the crank
    crank      rigid (``rigid = true``, Simeon's crank): the hub body itself; the crank pin A is a body
               marker at local (crank, 0) of the hub; its motion is prescribed, so its mass and inertia
               never enter (they load only the drive).  Flexible: a straight beam M -> A clamped to the
               hub (JointGeneric x, y, rotation), as the four-bar's crank
    coupler    A -> B, a straight beam of `elements_per_link` elements (ObjectANCFCable2D by default, or
               ObjectBeamGeometricallyExact2D: the same templates and damping as the four-bar,
               exudyn_models.builder.beam_template), pinned at A (ObjectJointRevolute2D)
    slider     the rod end B constrained normal to the slider line: a CoordinateConstraint holding the
               y displacement of B's node at 0 (the node starts on the line y = offset); B is free along
               the line
Masses: the slider mass and the payload at P, and for "tip"/"joints" every lump of
ked_quasi.slidercrank.slider_lumps, as exact point masses on the beam element that holds them (an
ObjectGenericODE2 with m S^T S, as in exudyn_models.builder); "distributed" uses the beams' consistent
mass (density x area) instead of the link lumps.  Lumps on a rigid crank are left out (prescribed motion).
A rigid coupler is not modelled (the coupler is the elastic member): refused with a ValueError.

Output sensor: one SensorUserFunction storing the node coordinates (displacements from the reference
configuration) of A, B, and of the coupler elements holding P and the midspan; SliderSampler turns them
into the deflection of P and the midspan deflection (exudyn_models.slider_simulate).

Units SI.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import exudyn as exu
import exudyn.itemInterface as eii
import numpy as np
from exudyn.beams import GenerateBeamElementsAlongLine

from ked_quasi.slidercrank import SliderScene, slider_kinematics, slider_lumps

from .builder import (
    HUB_INERTIA_KGM2,
    HUB_MASS_KG,
    _clamp,
    _fix,
    _pin,
    _rigid_marker_at_root,
    _shape_matrix,
    beam_template,
)
from .drive import Drive
from .settings import DynamicSettings

MIDSPAN = 0.5
"""Fraction of the coupler from A at which the midspan deflection is read."""


class SliderInputError(ValueError):
    """A slider-crank scene or settings the Exudyn slider model does not take (failure class "input")."""

    failure_class = "input"


@dataclass
class SliderModel:
    """An assembled slider-crank model plus what is needed to run and read it.

    start_angle [rad]: crank angle of the reference (stress-free, rigid) configuration; drive: the crank
    drive; p_sensor: the output sensor (columns: coordinates of the nodes in `sensor_nodes`, in order);
    sensor_nodes: node numbers stored by the sensor; node_reference: node -> reference coordinates
    (absolute: x, y, and slopes (ANCF) or rotation); coupler_nodes: the coupler's nodes from A to B;
    element_length [m]: coupler element length.
    """

    system_container: exu.SystemContainer
    mbs: exu.MainSystem
    settings: DynamicSettings
    start_angle: float
    drive: Drive
    damping_beta: float
    p_sensor: int
    sensor_nodes: list[int]
    node_reference: dict[int, np.ndarray]
    coupler_nodes: list[int]
    element_length: float
    link_nodes: dict[str, list[int]] = field(default_factory=dict)
    link_elements: dict[str, list[int]] = field(default_factory=dict)

    @property
    def ncoord(self) -> int:
        """Coordinates per beam node: 4 (ANCF x, y, x', y') or 3 (x, y, rotation)."""
        return 4 if self.settings.element == "ancf" else 3

    def locate(self, s: float) -> tuple[int, float]:
        """(element index along the coupler, local xi in [0, 1]) of the coupler point at fraction s."""
        n_el = len(self.coupler_nodes) - 1
        j = min(int(s * n_el), n_el - 1)
        return j, s * n_el - j


def make_slider_drive(scene: SliderScene, settings: DynamicSettings) -> Drive:
    """The crank drive: the smooth ramp over ramp_cycles (whole time steps), as the four-bar's."""
    omega = scene.omega
    sign = float(scene.linkage.sign)
    ramp_steps = max(1, round(settings.ramp_cycles * settings.steps_per_cycle))
    ramp_time = ramp_steps / settings.steps_per_cycle * 2.0 * math.pi / omega
    return Drive(omega=omega, ramp_time=ramp_time, sign=sign)


def check_slider_settings(scene, settings: DynamicSettings) -> None:
    """SliderInputError for what the slider model does not take (a rigid coupler; the quasi-static start or
    the periodic solve; start = "linear" runs from the ramp)."""
    if scene.linkage.is_rigid("coupler"):
        raise SliderInputError("the Exudyn slider-crank model needs an elastic coupler (rigid = false): a rigid "
                               "coupler has no coupler deflection to simulate")
    if settings.start == "quasi_static" or settings.periodic != "off":
        raise SliderInputError(f"the Exudyn slider-crank model runs with start = 'ramp' or 'linear' (from the "
                               f"ramp) and periodic = 'off' "
                               f"(got start = {settings.start!r}, periodic = {settings.periodic!r})")


def rigid_points(scene: SliderScene, theta: float) -> dict[str, np.ndarray]:
    """Rigid-kinematics positions (M, A, B -> (2,) [m]) at one crank angle [rad]."""
    kin = slider_kinematics(scene.linkage, np.array([theta]), scene.rpm)
    return {"M": np.zeros(2), "A": kin.A[0], "B": kin.B[0]}


def build_slider_model(scene: SliderScene, settings: DynamicSettings, damping_beta: float) -> SliderModel:
    """Build and assemble the driven Exudyn model of a slider-crank scene (module doc)."""
    check_slider_settings(scene, settings)
    sc = scene.linkage
    drive = make_slider_drive(scene, settings)
    start = drive.start_angle
    pts = rigid_points(scene, start)
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    n_ground = mbs.AddNode(eii.NodePointGround(visualization=eii.VNodePointGround(show=False)))
    m_ground = mbs.AddMarker(eii.MarkerNodeCoordinate(nodeNumber=n_ground, coordinate=0))
    n_hub, b_hub = _add_hub(mbs, m_ground, start, drive)
    link_nodes: dict[str, list[int]] = {}
    link_elements: dict[str, list[int]] = {}
    distributed = scene.mass_model.name == "distributed"
    links = ("coupler",) if sc.is_rigid("crank") else ("crank", "coupler")
    ends = {"crank": ("M", "A"), "coupler": ("A", "B")}
    for link in links:
        section = sc.section(link)
        template = beam_template(settings.element, section, section.mass_per_length if distributed else 0.0,
                                 damping_beta)
        p0, p1 = (pts[k] for k in ends[link])
        made = GenerateBeamElementsAlongLine(mbs, [p0[0], p0[1], 0.0], [p1[0], p1[1], 0.0],
                                             settings.elements_per_link, template)
        link_nodes[link] = [int(n) for n in made["nodes"]]
        link_elements[link] = [int(o) for o in made["elements"]]
        for n in link_nodes[link]:
            mbs.SetNodeParameter(n, "VdrawSize", 0.0)
    coupler = link_nodes["coupler"]
    if sc.is_rigid("crank"):  # the pin A on the hub body, at the crank's length along its local x
        m_a = mbs.AddMarker(eii.MarkerBodyPosition(bodyNumber=b_hub, localPosition=[sc.crank, 0.0, 0.0]))
        m_c = mbs.AddMarker(eii.MarkerNodePosition(nodeNumber=coupler[0]))
        mbs.AddObject(eii.ObjectJointRevolute2D(markerNumbers=[m_a, m_c],
                                                visualization=eii.VObjectJointRevolute2D(show=False)))
    else:
        root = _rigid_marker_at_root(mbs, settings.element, link_nodes["crank"][0], link_elements["crank"][0])
        _clamp(mbs, mbs.AddMarker(eii.MarkerNodeRigid(nodeNumber=n_hub)), root)
        _pin(mbs, link_nodes["crank"][-1], coupler[0])
    _fix(mbs, m_ground, coupler[-1], 1)  # the slider: B stays on its line
    _add_point_masses(mbs, scene, settings, link_nodes)
    ref = _node_reference(settings.element, link_nodes, pts)
    model = SliderModel(system_container=SC, mbs=mbs, settings=settings, start_angle=start, drive=drive,
                        damping_beta=float(damping_beta), p_sensor=-1, sensor_nodes=[], node_reference=ref,
                        coupler_nodes=coupler, element_length=sc.coupler / settings.elements_per_link,
                        link_nodes=link_nodes, link_elements=link_elements)
    _add_sensor(model, scene)
    mbs.Assemble()
    return model


def _add_hub(mbs, m_ground: int, start: float, drive: Drive) -> tuple[int, int]:
    """Rigid hub node and body at M (reference rotation = the start crank angle), x, y fixed, rotation
    prescribed by the drive; returns (node, body)."""
    n_hub = mbs.AddNode(eii.NodeRigidBody2D(referenceCoordinates=[0.0, 0.0, start],
                                            visualization=eii.VNodeRigidBody2D(show=False)))
    b_hub = mbs.AddObject(eii.ObjectRigidBody2D(nodeNumber=n_hub, mass=HUB_MASS_KG, inertia=HUB_INERTIA_KGM2,
                                                visualization=eii.VObjectRigidBody2D(show=False)))
    _fix(mbs, m_ground, n_hub, 0)
    _fix(mbs, m_ground, n_hub, 1)
    offset, offset_t = drive.user_functions()
    _fix(mbs, m_ground, n_hub, 2, offsetUserFunction=offset, offsetUserFunction_t=offset_t)
    return int(n_hub), int(b_hub)


def _point_mass_items(scene: SliderScene) -> list[tuple[str, float, float]]:
    """(link, s, mass [kg]) carried as point masses: the slider and payload always, the link lumps for the
    lumped mass models; none on a rigid crank."""
    sc, mm = scene.linkage, scene.mass_model
    lm = slider_lumps(sc, mm)
    items = []
    for link, s, m in zip(lm.link, lm.s, lm.mass):
        if link == "crank" and sc.is_rigid("crank"):
            continue
        items.append((str(link), float(s), float(m)))
    if mm.name == "distributed":  # the beams carry the links' mass: keep only the payload and the slider
        items = [("coupler", sc.coupler_point, float(mm.payload))] if mm.payload > 0.0 else []
        if sc.slider_mass > 0.0:
            items.append(("coupler", 1.0, float(sc.slider_mass)))
    return items


def _add_point_masses(mbs, scene: SliderScene, settings: DynamicSettings, link_nodes: dict[str, list[int]]) -> None:
    """One ObjectGenericODE2 per element that carries point masses, mass matrix sum of m S(xi)^T S(xi)."""
    n_el = settings.elements_per_link
    per_element: dict[tuple[str, int], np.ndarray] = {}
    for link, s, m in _point_mass_items(scene):
        if m == 0.0 or link not in link_nodes or (link == "crank" and s <= 1e-12):
            continue
        j = min(int(s * n_el), n_el - 1)
        xi = s * n_el - j
        S = _shape_matrix(settings.element, xi, scene.linkage.length(link) / n_el)
        per_element[(link, j)] = per_element.get((link, j), 0.0) + m * S.T @ S
    for (link, j), M_e in per_element.items():
        mbs.AddObject(eii.ObjectGenericODE2(name=f"point masses {link} element {j}",
                                            nodeNumbers=link_nodes[link][j:j + 2], massMatrix=M_e,
                                            visualization=eii.VObjectGenericODE2(show=False)))


def _node_reference(element: str, link_nodes: dict[str, list[int]],
                    pts: dict[str, np.ndarray]) -> dict[int, np.ndarray]:
    """Absolute reference coordinates of every beam node (straight links in the start configuration)."""
    ends = {"crank": ("M", "A"), "coupler": ("A", "B")}
    out = {}
    for link, nodes in link_nodes.items():
        p0, p1 = (pts[k] for k in ends[link])
        d = p1 - p0
        t = d / float(np.hypot(*d))
        for i, n in enumerate(nodes):
            p = p0 + i / (len(nodes) - 1) * d
            out[n] = np.array([p[0], p[1], t[0], t[1]]) if element == "ancf" else \
                np.array([p[0], p[1], math.atan2(t[1], t[0])])
    return out


def _add_sensor(model: SliderModel, scene: SliderScene) -> None:
    """One internal-storage sensor of the coordinates of A, B and the elements holding P and the midspan."""
    mbs, nodes = model.mbs, model.coupler_nodes
    wanted = [nodes[0], nodes[-1]]
    for s in (scene.linkage.coupler_point, MIDSPAN):
        j, _ = model.locate(s)
        wanted += nodes[j:j + 2]
    model.sensor_nodes = list(dict.fromkeys(wanted))
    coords = exu.OutputVariableType.Coordinates
    node_sensors = [int(mbs.AddSensor(eii.SensorNode(nodeNumber=n, outputVariableType=coords, storeInternal=False,
                                                     writeToFile=False, visualization=eii.VSensorNode(show=False))))
                    for n in model.sensor_nodes]

    def combined(mbs, t, sensorNumbers, factors, configuration):  # noqa: ARG001 - Exudyn's signature
        out = []
        for s in sensorNumbers:
            out.extend(mbs.GetSensorValues(s, configuration=configuration))
        return out

    model.p_sensor = int(mbs.AddSensor(eii.SensorUserFunction(
        sensorNumbers=node_sensors, factors=[1.0] * len(node_sensors), sensorUserFunction=combined,
        storeInternal=True, writeToFile=False)))
