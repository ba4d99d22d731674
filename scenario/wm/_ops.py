"""A scenario's initial world-model scene: :func:`scenario_ops` turns a
:class:`~scenario.Scenario` into the ops of ONE transaction.

What it writes (element labels = scenario labels; device labels ``<robot>-arm``,
``-gripper``, ``-base``; classes = the scenario's ``type`` fields, which are ontology classes)::

    Station-1 contain Shelf-1 contain PartBox-1 contain Gear-1      (furniture -> station,
    Worktop-1 contain MealBox-1, Tray-1                               containers, parts)
    Table-1 contain Microwave-1 hasA Microwave-1-door (MicrowaveDoor)
    Cabinet-1 hasA Drawer-1
    r1 hasA r1-arm, r1-gripper, r1-base, r1-camera;  r1 contain KitBox-1
    r1 at r1-home (a Location at the robot's start pose)
    PartBox-1 at Station-1; Worktop-1, Table-1, Microwave-1, Tray-1 at friend-home

- **Poses** are world-frame :class:`~wm_store.protocol.Pose` values of each element's *centre*
  (the spatial reasoner's convention; a scenario places bottom centres, so ``z`` is raised by
  half the height). A robot's pose is its base frame on the floor (x forward, y left); a
  location's pose is where a robot parks to work there (a station: facing its yaw; a home:
  the robot's start pose). Containers a robot carries get world poses too: the ``navigate``
  skill moves its robot's descendants with it.
- **Prior knowledge**: parts' poses exact, or rough with the scenario's ``prior_noise`` (an
  error per part drawn from its label; ``locate`` refines them); each arm's home posture
  (``jointPositions``, :data:`HOME_6`, or the ``home`` of an arm from MJCF files);
  appliance doors get a pose and size (for an arm that swings them); a cabinet's drawer its
  pose, size, ``drawerOpen = false`` and its handle as ``graspPose`` / ``graspWidth``;
  closed containers (a meal box) a ``graspPose`` from the side facing the robot in the
  scenario layout (their -x face), so they can go into an appliance's cavity.
- **Sizes**: furniture and containers ``SizeCuboid`` (outside extents), parts by shape;
  **masses**; appliances ``doorOpen = false``, ``heating = false``, ``heatingPower``;
  containers the ``capacity`` of their class's default individual in the ontology (KitBox 6,
  Tray 2), so "not full" pre-conditions count against it.
- **at** (symbolic locations for the planner): every furniture, appliance and open container
  (not closed, not on a robot) is ``at`` its station (through the furniture it stands on), else
  ``at`` the home of a robot whose arm reaches it from its start pose, else nowhere. Closed
  containers (a meal box) are things to carry: they get no location. Robots are ``at`` their
  home.
- **Sensors**: robot-mounted cameras are devices of the robot (``hasA``); fixed cameras stand
  alone with their pose; a smart platform is the furniture element itself (same label, class
  ``SmartPlatform``).

Pure: no I/O (the ontology, default :meth:`Ontology.default`, is loaded once per process).
With ``existing`` (label -> element id of elements already in the world model,
e.g. robots registered by their agents first), those elements are not added again: their
pose is updated and relations point at them.
"""

from __future__ import annotations

import math
import random
import zlib
from collections.abc import Mapping

from scenario._drawer_layout import HANDLE_HALF, drawer_layout
from scenario._placement import WorldPlacement, resolve_placements
from scenario._schema import (
    ApplianceEntry,
    ContainerEntry,
    FurnitureEntry,
    PartEntry,
    RobotEntry,
    Scenario,
)
from wm_store import WmError
from wm_store.ontology import Cls, Ontology, Prop, Rel
from wm_store.protocol import (
    AddElement,
    Op,
    Orientation,
    Pose,
    Position,
    Relation,
    SetRelation,
    SizeCuboid,
    SizeCylinder,
    SizeSphere,
    UpdateElement,
    Value,
)
from wm_store.reasoners import Transform, quat_from_axes, quat_from_yaw

__all__ = [
    "DOOR_HALF_THICKNESS",
    "HOME_6",
    "HOME_7",
    "REACH_FRACTION",
    "SIDE_GRASP_BELOW_TOP",
    "SIDE_GRASP_INSET",
    "SIDE_GRASP_MAX_WIDTH",
    "device_label",
    "door_label",
    "home_label",
    "scenario_ops",
    "template_capacity",
]

REACH_FRACTION = 0.8
"""A robot's arm reaches what lies within this fraction of its shoulder-to-tcp length
(horizontally, from the arm mount) — the test that puts things ``at`` a robot's home."""
HOME_6: tuple[float, ...] = (0.0, -0.7, 1.7, 0.0, 2.1, 0.0)
"""Home posture of a 6-joint arm, rad, in joint order (``ARM_JOINTS_6``): the gripper points
down just in front of the arm's mount, ~0.6 m above the deck (the default robot: tcp 0.2 m
ahead of the base centre, 0.93 m high), clear of a table or shelf at a station. Written as the
arm's ``jointPositions``: skills pass through it between a pick in front and a place behind."""
HOME_7: tuple[float, ...] = (0.0, -0.7, 0.0, 1.7, 0.0, 2.1, 0.0)
"""The same for a 7-joint arm (``ARM_JOINTS_7``: an upper-arm roll after the shoulder)."""
DOOR_HALF_THICKNESS = 0.012
"""Half the thickness of an appliance door panel, m (as ``mujoco_sim.models`` builds
it)."""
SIDE_GRASP_INSET = 0.035
"""Closed boxes (things carried whole, e.g. into a microwave) get a side grasp as prior
knowledge: the pads this far in from the face the robot approaches, m."""
SIDE_GRASP_BELOW_TOP = 0.015
"""... and this far below the box's top, m."""
SIDE_GRASP_MAX_WIDTH = 0.077
"""... if the box is at most this wide across the fingers (the default gripper opens 85 mm)."""


def device_label(robot: str, device: str) -> str:
    """World-model label of a robot's device: ``r1-arm``, ``r1-gripper``, ``r1-base``."""
    return f"{robot}-{device}"


def home_label(robot: str) -> str:
    """Label of the Location at a robot's start pose."""
    return f"{robot}-home"


def door_label(appliance: str) -> str:
    return f"{appliance}-door"


def _pose(x: float, y: float, z: float, yaw: float = 0.0) -> Pose:
    s, c = math.sin(yaw / 2), math.cos(yaw / 2)
    return Pose(Position(x, y, z), Orientation(0.0, 0.0, s, c))


def _door(a: ApplianceEntry, p: WorldPlacement) -> dict[str, Value]:
    """Pose (centre of the closed panel; x out of the front, y from the hinge to the free
    edge) and size (thickness, width, height) of an appliance's door."""
    d, h = a.size[0] / 2, a.size[2]
    flip = (1.0, 0.0, 0.0, 0.0) if a.hinge == "right" else (0.0, 0.0, 0.0, 1.0)
    body = Transform((p.x, p.y, p.z), quat_from_yaw(p.yaw))
    centre = body.compose(Transform((d + DOOR_HALF_THICKNESS, 0.0, h / 2), flip))
    size = SizeCuboid(x=2 * DOOR_HALF_THICKNESS, y=a.size[1], z=h)
    return {Prop.pose: centre.to_pose(), Prop.size: size}


def _drawer(f: FurnitureEntry) -> dict[str, Value]:
    """A cabinet's closed drawer: pose (the box's centre; x out of the cabinet's front), size,
    ``drawerOpen = false``, and the handle as a grasp: tcp pointing down at the bar, fingers
    closing along the drawer's x (so one finger sits between the bar and the panel)."""
    assert f.drawer is not None
    layout = drawer_layout(f, f.drawer)
    cabinet = Transform((f.pose.x, f.pose.y, 0.0), quat_from_yaw(f.pose.yaw))
    centre = cabinet.compose(Transform(layout.centre))
    (hx, hy, hz), (cx, cy, cz) = layout.handle, layout.centre
    q = quat_from_axes((0.0, 1.0, 0.0), (1.0, 0.0, 0.0), (0.0, 0.0, -1.0))
    return {
        Prop.pose: centre.to_pose(),
        Prop.size: SizeCuboid(*layout.size),
        Prop.drawerOpen: False,
        Prop.graspPose: Pose(Position(hx - cx, hy - cy, hz - cz), Orientation(*q)),
        Prop.graspWidth: 2 * HANDLE_HALF[0],
    }


def _prior_error(label: str, noise: float) -> tuple[float, float]:
    """The x, y error of ``label``'s prior pose: Gaussian, ``noise`` m standard deviation,
    drawn from the label (the same scene every time), at most 3 standard deviations."""
    if noise <= 0:
        return 0.0, 0.0
    draw = random.Random(zlib.crc32(label.encode()))
    limit = 3 * noise
    dx, dy = (max(-limit, min(limit, draw.gauss(0.0, noise))) for _ in range(2))
    return dx, dy


def _side_grasp(depth: float, height: float) -> Pose:
    """The tcp relative to a box: approaching along the box's +x from its -x face, fingers
    closing across its y, the pads ``SIDE_GRASP_INSET`` m in from the face and
    ``SIDE_GRASP_BELOW_TOP`` m below its top (so the hand, 6 cm tall, clears the surface the
    box stands on)."""
    inset = min(SIDE_GRASP_INSET, depth / 2)
    up = max(0.0, height / 2 - SIDE_GRASP_BELOW_TOP)
    q = quat_from_axes((0.0, 0.0, -1.0), (0.0, 1.0, 0.0), (1.0, 0.0, 0.0))
    return Pose(Position(-depth / 2 + inset, 0.0, up), Orientation(*q))


def _part_size(p: PartEntry) -> Value:
    if p.shape == "cylinder":
        return SizeCylinder(radius=p.size[0], height=p.size[1])
    if p.shape == "sphere":
        return SizeSphere(radius=p.size[0])
    return SizeCuboid(x=p.size[0], y=p.size[1], z=p.size[2])


def _reach(robot: RobotEntry) -> float:
    m = robot.spec
    if m.mjcf is not None:
        return REACH_FRACTION * m.mjcf.reach
    return REACH_FRACTION * (
        m.upper_arm_length + m.forearm_length + m.wrist_length + m.gripper_length
    )


def _home(robot: RobotEntry) -> tuple[float, ...]:
    """The arm's home posture: its file's (``MjcfArm.home``) or the generated arm's."""
    m = robot.model
    if m.mjcf is not None:
        return m.mjcf.home
    return HOME_6 if m.arm_dof == 6 else HOME_7


def _near_point(footprint: tuple[float, float, float, float, float], x: float, y: float) -> float:
    """Distance from (x, y) to a rectangle (centre x, y, yaw, half sizes)."""
    cx, cy, yaw, hx, hy = footprint
    c, s = math.cos(yaw), math.sin(yaw)
    lx, ly = c * (x - cx) + s * (y - cy), -s * (x - cx) + c * (y - cy)
    return math.hypot(max(abs(lx) - hx, 0.0), max(abs(ly) - hy, 0.0))


def template_capacity(ontology: Ontology, cls: str) -> int | None:
    """The ``capacity`` of the nearest default individual of ``cls`` or a superclass that
    sets one (KitBox: 6), else None."""
    for name in ontology.superclasses(cls) if cls in ontology.classes else ():
        try:
            capacity = ontology.template(name).properties.get(Prop.capacity)
        except WmError:  # no (single) default individual of this class
            continue
        if isinstance(capacity, int) and not isinstance(capacity, bool):
            return capacity
    return None


class _Builder:
    def __init__(self, s: Scenario, existing: Mapping[str, str], ontology: Ontology) -> None:
        self.s, self.existing, self.ontology = s, existing, ontology
        self.ops: list[Op] = []
        self.placed: dict[str, WorldPlacement] = resolve_placements(s)
        self.furniture = {f.label: f for f in s.furniture}
        self.containers = {c.label: c for c in s.containers}
        self.appliance_parent = {a.label: a.parent for a in s.appliances}
        self.robots = {r.name for r in s.robots}
        self.added: set[str] = set()

    def ref(self, label: str) -> str:
        return self.existing.get(label, f"${label}")

    def add(
        self, cls: str, label: str, props: dict[str, Value], parent: str = "", via: str = ""
    ) -> None:
        """Add ``label`` (or update it if it exists), as ``via(parent, label)`` if given."""
        predicate = via or Rel.contain
        self.added.add(label)
        if label in self.existing:
            element = self.existing[label]
            if props:
                self.ops.append(UpdateElement(id=element, properties=props))
            if parent:
                self.ops.append(
                    SetRelation(subject=self.ref(parent), predicate=predicate, object=element)
                )
            return
        relations = [Relation(self.ref(parent), predicate, "$")] if parent else []
        self.ops.append(
            AddElement(
                type=cls, label=label, properties=props, relations=relations, ref=f"${label}"
            )
        )

    def relate(self, subject: str, predicate: str, obj: str) -> None:
        self.ops.append(
            SetRelation(subject=self.ref(subject), predicate=predicate, object=self.ref(obj))
        )

    # ------------------------------------------------------------------ elements

    def robots_and_homes(self) -> None:
        for r in self.s.robots:
            pose = _pose(r.pose.x, r.pose.y, 0.0, r.pose.yaw)
            self.add(Cls.Location, home_label(r.name), {Prop.pose: pose})
            self.add(r.type, r.name, {Prop.pose: pose})
            for device, cls in _DEVICES:
                props: dict[str, Value] = {}
                if cls == Cls.Arm:
                    props[Prop.jointPositions] = list(_home(r))
                self.add(cls, device_label(r.name, device), props, r.name, Rel.hasA)
            self.relate(r.name, Rel.at, home_label(r.name))

    def furniture_elements(self) -> None:
        stations_first = sorted(self.s.furniture, key=lambda f: f.kind != "area")
        for f in stations_first:
            height = max(f.size[2], 0.001)
            props: dict[str, Value] = {
                Prop.pose: _pose(f.pose.x, f.pose.y, height / 2, f.pose.yaw),
                Prop.size: SizeCuboid(x=f.size[0], y=f.size[1], z=height),
            }
            self.add(f.type, f.label, props, f.station)
            if f.drawer is not None:
                self.add(f.drawer.type, f.drawer.label, _drawer(f), f.label, Rel.hasA)

    def container(self, c: ContainerEntry) -> None:
        if c.label in self.added:
            return
        if c.parent in self.containers:  # the holder first
            self.container(self.containers[c.parent])
        p = self.placed[c.label]
        props: dict[str, Value] = {
            Prop.pose: _pose(p.x, p.y, p.z + c.size[2] / 2, p.yaw),
            Prop.size: SizeCuboid(x=c.size[0], y=c.size[1], z=c.size[2]),
            Prop.mass: c.mass,
        }
        capacity = template_capacity(self.ontology, c.type)
        if capacity is not None:
            props[Prop.capacity] = capacity
        if c.closed and c.size[1] <= SIDE_GRASP_MAX_WIDTH:
            props[Prop.graspPose] = _side_grasp(c.size[0], c.size[2])
        self.add(c.type, c.label, props, c.parent)

    def appliances(self) -> None:
        for a in self.s.appliances:
            p = self.placed[a.label]
            props: dict[str, Value] = {
                Prop.pose: _pose(p.x, p.y, p.z + a.size[2] / 2, p.yaw),
                Prop.size: SizeCuboid(x=a.size[0], y=a.size[1], z=a.size[2]),
                Prop.doorOpen: False,
                Prop.heating: False,
                Prop.heatingPower: a.heating_power,
            }
            self.add(a.type, a.label, props, a.parent)
            door = Cls.MicrowaveDoor if a.type == Cls.Microwave else Cls.Door
            self.add(door, door_label(a.label), _door(a, p), a.label, Rel.hasA)

    def parts(self) -> None:
        for part in self.s.parts:
            p = self.placed[part.label]
            dx, dy = _prior_error(part.label, self.s.prior_noise)
            props: dict[str, Value] = {
                Prop.pose: _pose(p.x + dx, p.y + dy, p.z + part.height / 2, p.yaw),
                Prop.size: _part_size(part),
                Prop.mass: part.mass,
            }
            self.add(part.type, part.label, props, part.parent)

    def sensors(self) -> None:
        for sensor in self.s.sensors:
            cls = sensor.ontology_type
            if sensor.kind == "platform":
                if sensor.label != sensor.surface:  # a separate board on the surface
                    self.add(cls, sensor.label, {}, sensor.surface, Rel.hasA)
            elif sensor.mount:
                self.add(cls, sensor.label, {}, sensor.mount, Rel.hasA)
            elif sensor.position is not None:
                x, y, z = sensor.position
                self.add(cls, sensor.label, {Prop.position: Position(x, y, z)})

    # ------------------------------------------------------------------ locations

    def station_of(self, label: str) -> str:
        """The station a furniture, container or appliance stands at (through its holders)."""
        for _ in range(64):  # holders form no cycle (checked at load); bound the walk anyway
            if label in self.furniture:
                return self.furniture[label].station
            if label in self.containers:
                label = self.containers[label].parent
            elif label in self.appliance_parent:
                label = self.appliance_parent[label]
            else:
                return ""
        return ""

    def home_reaching(self, footprint: tuple[float, float, float, float, float]) -> str:
        for r in self.s.robots:
            c, s = math.cos(r.pose.yaw), math.sin(r.pose.yaw)
            mx, my = r.pose.x + c * r.spec.arm_mount_x, r.pose.y + s * r.spec.arm_mount_x
            if _near_point(footprint, mx, my) <= _reach(r):
                return home_label(r.name)
        return ""

    def locations(self) -> None:
        things = [
            (f.label, (f.pose.x, f.pose.y, f.pose.yaw, f.size[0] / 2, f.size[1] / 2))
            for f in self.s.furniture
            if f.kind != "area"
        ]
        for c in self.s.containers:
            if not c.closed and c.parent not in self.robots:
                p = self.placed[c.label]
                things.append((c.label, (p.x, p.y, p.yaw, c.size[0] / 2, c.size[1] / 2)))
        for a in self.s.appliances:
            p = self.placed[a.label]
            things.append((a.label, (p.x, p.y, p.yaw, a.size[0] / 2, a.size[1] / 2)))
        for label, footprint in things:
            where = self.station_of(label) or self.home_reaching(footprint)
            if where:
                self.relate(label, Rel.at, where)

    def build(self) -> list[Op]:
        self.robots_and_homes()
        self.furniture_elements()
        for c in self.s.containers:
            self.container(c)
        self.appliances()
        self.parts()
        self.sensors()
        self.locations()
        return self.ops


_DEVICES = (("arm", Cls.Arm), ("gripper", Cls.Gripper), ("base", Cls.MobileBase))


def scenario_ops(
    scenario: Scenario,
    existing: Mapping[str, str] | None = None,
    *,
    ontology: Ontology | None = None,
) -> list[Op]:
    """The ops of one transaction that put ``scenario``'s initial scene into the world model
    (see the module doc). Refs are ``$<label>``: ``reply.ids["$Gear-1"]`` is Gear-1's id.
    ``existing``: label -> id of elements already there (updated, not added again).
    ``ontology``: where container capacities come from (default: the core ontology)."""
    onto = ontology if ontology is not None else Ontology.default()
    return _Builder(scenario, existing or {}, onto).build()
