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
  Tray 2), so "not full" pre-conditions count against it; furniture its ``robot_capacity``
  as ``robotCapacity``, when given (robots a station holds at once; absent: the ontology's
  default, one at a station, none at a surface); each robot's home ``robotCapacity`` 1 (its
  parking place: no other robot is sent there while it stands in it).
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

This module builds the transaction; the values it writes come from
:mod:`scenario.wm._furnishings` (doors, drawers, side grasps, capacities),
:mod:`scenario.wm._robots` (labels, home postures, reach) and :mod:`scenario.wm._parts`
(sizes, prior noise).
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from scenario._placement import WorldPlacement, resolve_placements
from scenario._schema import ContainerEntry, Scenario
from scenario.wm._furnishings import (
    SIDE_GRASP_MAX_WIDTH,
    door_label,
    door_props,
    drawer_props,
    pose_at,
    side_grasp,
    template_capacity,
)
from scenario.wm._parts import part_size, prior_error
from scenario.wm._robots import (
    arm_home,
    arm_reach,
    device_label,
    distance_to_footprint,
    home_label,
    robot_devices,
)
from wm_store.ontology import Cls, Ontology, Prop, Rel
from wm_store.protocol import (
    AddElement,
    Op,
    Position,
    Relation,
    SetRelation,
    SizeCuboid,
    UpdateElement,
    Value,
)

__all__ = ["scenario_ops"]


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
            pose = pose_at(r.pose.x, r.pose.y, 0.0, r.pose.yaw)
            home: dict[str, Value] = {Prop.pose: pose, Prop.robotCapacity: 1}  # its parking place
            self.add(Cls.Location, home_label(r.name), home)
            self.add(r.type, r.name, {Prop.pose: pose})
            for device, cls in robot_devices(r):
                props: dict[str, Value] = {}
                if cls == Cls.Arm:
                    props[Prop.jointPositions] = list(arm_home(r))
                self.add(cls, device_label(r.name, device), props, r.name, Rel.hasA)
            self.relate(r.name, Rel.at, home_label(r.name))

    def furniture_elements(self) -> None:
        stations_first = sorted(self.s.furniture, key=lambda f: f.kind != "area")
        for f in stations_first:
            height = max(f.size[2], 0.001)
            props: dict[str, Value] = {
                Prop.pose: pose_at(f.pose.x, f.pose.y, height / 2, f.pose.yaw),
                Prop.size: SizeCuboid(x=f.size[0], y=f.size[1], z=height),
            }
            if f.robot_capacity is not None:
                props[Prop.robotCapacity] = f.robot_capacity
            self.add(f.type, f.label, props, f.station)
            if f.drawer is not None:
                self.add(f.drawer.type, f.drawer.label, drawer_props(f), f.label, Rel.hasA)

    def container(self, c: ContainerEntry) -> None:
        if c.label in self.added:
            return
        if c.parent in self.containers:  # the holder first
            self.container(self.containers[c.parent])
        p = self.placed[c.label]
        props: dict[str, Value] = {
            Prop.pose: pose_at(p.x, p.y, p.z + c.size[2] / 2, p.yaw),
            Prop.size: SizeCuboid(x=c.size[0], y=c.size[1], z=c.size[2]),
            Prop.mass: c.mass,
        }
        capacity = template_capacity(self.ontology, c.type)
        if capacity is not None:
            props[Prop.capacity] = capacity
        if c.closed and c.size[1] <= SIDE_GRASP_MAX_WIDTH:
            props[Prop.graspPose] = side_grasp(c.size[0], c.size[2])
        self.add(c.type, c.label, props, c.parent)

    def appliances(self) -> None:
        for a in self.s.appliances:
            p = self.placed[a.label]
            props: dict[str, Value] = {
                Prop.pose: pose_at(p.x, p.y, p.z + a.size[2] / 2, p.yaw),
                Prop.size: SizeCuboid(x=a.size[0], y=a.size[1], z=a.size[2]),
                Prop.doorOpen: False,
                Prop.heating: False,
                Prop.heatingPower: a.heating_power,
            }
            self.add(a.type, a.label, props, a.parent)
            door = Cls.MicrowaveDoor if a.type == Cls.Microwave else Cls.Door
            self.add(door, door_label(a.label), door_props(a, p), a.label, Rel.hasA)

    def parts(self) -> None:
        for part in self.s.parts:
            p = self.placed[part.label]
            dx, dy = prior_error(part.label, self.s.prior_noise)
            props: dict[str, Value] = {
                Prop.pose: pose_at(p.x + dx, p.y + dy, p.z + part.height / 2, p.yaw),
                Prop.size: part_size(part),
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
            if distance_to_footprint(footprint, mx, my) <= arm_reach(r):
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
