"""Scenario files: what a simulated world holds, read from TOML (strict; pure, no MuJoCo).

A scenario lists robots, furniture (stations, shelves, tables, worktops), containers (part
boxes, kit boxes, trays, meal boxes), parts, appliances (a microwave), sensors (cameras, a smart
platform) and goals. Every element has a ``label``: the name the world model uses for it, the
MuJoCo body name in the simulation and, for device owners, a key segment. Example::

    name = "kitting"
    goals = ["contain(KitBox-1, Gear-1)"]

    [[robots]]
    name = "r1"
    pose = { x = -0.6, y = -1.0 }
    agent = "agents/r1.toml"                # relative to this file

    [[furniture]]
    type = "Shelf"
    label = "Shelf-1"
    pose = { x = 1.2, y = -1.0 }
    size = [0.6, 1.0, 0.7]                  # footprint x, y and top height, m

    [[containers]]
    type = "KitBox"
    label = "KitBox-1"
    parent = "r1"                           # on r1's deck, carried with it
    size = [0.26, 0.30, 0.07]

    [[parts]]
    type = "Gear"
    label = "Gear-1"
    parent = "PartBox-1"
    pose = { x = -0.06 }                    # on the parent's floor, in its frame
    shape = "cylinder"
    size = [0.028, 0.025]                   # radius, height

Frames: a child's ``pose`` (:class:`Placement`) is relative to its parent's *support surface*
(a furniture top, a container's inner floor, a robot's deck, an appliance's cavity floor) and
places the child's bottom centre; without a parent it is in the world frame, on the floor.
:func:`resolve_placements` turns that into world poses. Units: metres, kilograms, radians
(sensor ``fov`` in degrees), watts, seconds.

Errors: :func:`load_scenario` raises :class:`ScenarioError` naming the file and the field path
(``$.parts[3].size``) or, for a bad reference, the labels that exist.

Keys (of :class:`~device_drivers.Pose2D`, the ``pose`` of robots and furniture;
``scripts/gen_reference.py`` reads them for the scenario reference):
    Pose2D.x (m): World x of the element's reference point.
    Pose2D.y (m): World y of the element's reference point.
    Pose2D.yaw (rad): Heading about +z, counter-clockwise from +x seen from above.
"""

from __future__ import annotations

import re
from typing import Annotated, Literal

import msgspec
from msgspec import Meta, Struct

from device_drivers import Pose2D
from scenario._robot_spec import RGBA, RobotSpec

__all__ = [
    "CABINET_TOP",
    "DOOR_HANDLE_INSET",
    "DOOR_HANDLE_STANDOFF",
    "DRAWER_CLEARANCE",
    "ApplianceEntry",
    "ContainerEntry",
    "DrawerSpec",
    "FurnitureEntry",
    "PartEntry",
    "Placement",
    "RobotEntry",
    "Scenario",
    "SensorEntry",
]

Label = Annotated[str, Meta(pattern=r"^[A-Za-z][A-Za-z0-9_.-]*$", max_length=64)]
"""A label: also a MuJoCo body name and a Zenoh key segment, so no spaces or slashes."""
Coord = Annotated[float, Meta(ge=-100, le=100)]
Length = Annotated[float, Meta(gt=0, le=20)]
Mass = Annotated[float, Meta(gt=0, le=1000)]
Size3 = tuple[Length, Length, Length]
Vec3 = tuple[Coord, Coord, Coord]


class Placement(Struct, frozen=True, forbid_unknown_fields=True):
    """Where an element stands: ``x``, ``y`` in its parent's frame (the world without a
    parent), ``z`` above the parent's support surface, ``yaw`` about +z; all of its bottom
    centre.

    Attributes:
        x (m): Along the parent's x axis (the world's without a parent).
        y (m): Along the parent's y axis (the world's without a parent).
        z (m): Height above the parent's support surface (the floor without a parent).
        yaw (rad): Turn about +z, counter-clockwise seen from above.
    """

    x: Coord = 0.0
    y: Coord = 0.0
    z: Annotated[float, Meta(ge=0, le=10)] = 0.0
    yaw: float = 0.0


class RobotEntry(Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """A mobile manipulator (:class:`RobotSpec` fields under ``model``): generated, or with its
    arm and gripper from MJCF files (``[robots.model.mjcf]``, :class:`~device_drivers.
    robot_spec.MjcfArm`; an empty table means Menagerie's UR5e + Robotiq 2F-85, relative file
    paths are resolved against the scenario file). Its devices are ``arm``, ``gripper`` and
    ``base`` (world-model labels ``<name>-arm`` ...), plus any sensor mounted on it.

    Attributes:
        name: Robot name: world-model label of the robot, prefix of its device labels
            (``<name>-arm``) and its key segment under ``devices/``.
        type: Ontology class of the robot.
        pose: Start pose of the base frame in the world: ``x``, ``y`` (m) of the point on the floor
            under the base centre, ``yaw`` (rad, about +z; 0 = facing +x). Also the robot's home
            location.
        model: The robot model: base, arm and gripper dimensions, or arm and gripper from MJCF files
            (``[robots.model.mjcf]``).
        agent: Skill-agent config file of this robot (resolved against the scenario file); empty:
            none.
    """

    name: Label
    type: str = "MobileManipulator"
    pose: Pose2D = Pose2D()
    model: RobotSpec = RobotSpec()
    agent: str = ""

    def __post_init__(self) -> None:
        if self.model.name not in ("robot", self.name):
            raise ValueError(f"model.name {self.model.name!r} differs from name {self.name!r}")

    @property
    def spec(self) -> RobotSpec:
        """The robot model with this robot's name."""
        return msgspec.structs.replace(self.model, name=self.name)


FurnitureShape = Literal["table", "shelf", "block", "area", "cabinet"]
_DEFAULT_SHAPE: dict[str, FurnitureShape] = {
    "Station": "area",
    "Shelf": "shelf",
    "Table": "table",
    "Cabinet": "cabinet",
}


DOOR_HANDLE_INSET = 0.08
"""Distance of a motorless door's handle (its centre) from the door's free edge, m."""
DOOR_HANDLE_STANDOFF = 0.05
"""How far out of a motorless door's outer face its handle bar stands (its centre), m."""
CABINET_TOP = 0.02
"""Thickness of a cabinet's top board, m."""
DRAWER_CLEARANCE = 0.01
"""Gap between a drawer and its slot, above and below, m."""


class DrawerSpec(Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """The drawer of a ``cabinet`` furniture, right under its top: an open box on a slide
    joint that pulls out towards the cabinet's front (+x of its frame) by at most ``travel``,
    with a bar handle on its front panel, ``handle_standoff`` m out from the panel (room for a
    finger behind it). ``height``: of the box, m. Built by :mod:`mujoco_sim.models`.

    Attributes:
        label: World-model label and MuJoCo body name of the drawer.
        type: Ontology class of the drawer.
        height (m): Height of the drawer box; it must fit under the cabinet's top.
        travel (m): How far the drawer pulls out (at most 0.8 of the cabinet's depth).
        handle_standoff (m): How far the handle bar stands out of the front panel (its centre).
        rgba: Colour: red, green, blue, alpha, each 0..1.
    """

    label: Label
    type: str = "Drawer"
    height: Annotated[float, Meta(ge=0.05, le=0.5)] = 0.12
    travel: Annotated[float, Meta(gt=0.02, le=1.0)] = 0.30
    handle_standoff: Annotated[float, Meta(ge=0.03, le=0.15)] = 0.05
    rgba: RGBA = (0.80, 0.72, 0.58, 1.0)


class FurnitureEntry(Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """Fixed furniture or a location. ``size`` = footprint x, y and top height. Shapes:
    ``table`` (top and legs), ``shelf`` (top, lower board, sides), ``block`` (solid, e.g. a
    worktop), ``area`` (a floor marking with no collision: a station), ``cabinet`` (solid,
    with a ``drawer`` under its top opening at its front, +x).

    Attributes:
        type: Ontology class, e.g. ``Station``, ``Shelf``, ``Table``, ``Worktop``, ``Cabinet``.
        label: World-model label and MuJoCo body name.
        pose: World pose of the footprint centre: ``x``, ``y`` (m) and ``yaw`` (rad, about +z). A
            station's pose is where a robot parks to work there, and its ``yaw`` the direction the
            robot faces when it does (0 = +x).
        size (m): Footprint along x, along y (in the furniture's own frame) and top height.
        shape: ``table`` (top and legs), ``shelf`` (top, lower board, sides), ``block`` (solid, e.g.
            a worktop), ``area`` (a floor marking without collision: a station), ``cabinet`` (solid,
            with a ``drawer`` under its top). Default: ``area`` for a Station, ``shelf`` for a
            Shelf, ``table`` for a Table, ``cabinet`` for a Cabinet, else ``block``.
        station: Label of the station (an ``area`` furniture) this furniture belongs to: the station
            ``contain`` s it in the world model and everything on it is ``at`` that station for the
            planner. Empty: none.
        rgba: Colour: red, green, blue, alpha, each 0..1.
        drawer: The drawer of a ``cabinet`` (only a cabinet has one).
        robot_capacity: How many robots may stand at it at once (the world model's
            ``robotCapacity``): a station's work spot holds one, a shelf or a table none (the
            defaults, when this is not given; other locations have no limit); 0: no robot goes
            there.
    """

    type: str
    label: Label
    pose: Pose2D = Pose2D()
    size: Size3
    shape: FurnitureShape | None = None
    station: str = ""
    rgba: RGBA = (0.62, 0.50, 0.38, 1.0)
    drawer: DrawerSpec | None = None
    robot_capacity: Annotated[int, Meta(ge=0)] | None = None

    @property
    def kind(self) -> FurnitureShape:
        return self.shape or _DEFAULT_SHAPE.get(self.type, "block")

    @property
    def top(self) -> float:
        """Height of the support surface above the floor, m (0 for an area)."""
        return 0.0 if self.kind == "area" else self.size[2]


class ContainerEntry(Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """An open box (floor and four walls) or, ``closed``, a lidded box. ``size`` is outside
    x, y, z. A container on a robot's deck is carried rigidly; ``fixed`` ones never move; the
    others are free bodies that can be grasped.

    Attributes:
        type: Ontology class, e.g. ``PartBox``, ``KitBox``, ``Tray``, ``MealBox``.
        label: World-model label and MuJoCo body name.
        parent: What it stands on: a robot name (carried on its deck), a furniture or a container
            label. Empty: the floor.
        pose: Bottom centre in the parent's frame, on its support surface.
        size (m): Outside extents x, y, z.
        wall (m): Thickness of the floor and walls (and lid).
        mass (kg): Mass of the empty container.
        closed: A lidded box (e.g. a meal box): a thing to carry, with a grasp pose from its -x
            side; it gets no location.
        fixed: Welded where it stands: never moves, cannot be grasped (e.g. a part box on a shelf).
            Otherwise a free body (or, on a robot's deck, carried rigidly).
        rgba: Colour: red, green, blue, alpha, each 0..1.
    """

    type: str
    label: Label
    parent: str = ""
    pose: Placement = Placement()
    size: Size3
    wall: Annotated[float, Meta(gt=0, le=0.1)] = 0.008
    mass: Mass = 0.5
    closed: bool = False
    fixed: bool = False
    rgba: RGBA = (0.30, 0.45, 0.75, 1.0)


PartShape = Literal["cylinder", "cuboid", "sphere"]
_SIZE_FIELDS = {"cylinder": "[radius, height]", "cuboid": "[x, y, z]", "sphere": "[radius]"}


class PartEntry(Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """A part: a free rigid body of one shape. ``size``: cylinder ``[radius, height]`` (axis
    vertical), cuboid ``[x, y, z]``, sphere ``[radius]``.

    Attributes:
        type: Ontology class, e.g. ``Gear``, ``Shaft``, ``Bolt``.
        label: World-model label and MuJoCo body name.
        parent: What it lies on or in: a container, furniture or appliance label.
        pose: Bottom centre in the parent's frame, on its support surface.
        shape: Shape of the rigid body; decides what ``size`` holds.
        size (m): cylinder: ``[radius, height]`` (axis vertical); cuboid: ``[x, y, z]``; sphere:
            ``[radius]``.
        mass (kg): Mass of the part.
        rgba: Colour: red, green, blue, alpha, each 0..1.
    """

    type: str
    label: Label
    parent: str
    pose: Placement = Placement()
    shape: PartShape = "cuboid"
    size: tuple[Length, ...]
    mass: Mass = 0.1
    rgba: RGBA = (0.80, 0.25, 0.20, 1.0)

    def __post_init__(self) -> None:
        expected = {"cylinder": 2, "cuboid": 3, "sphere": 1}[self.shape]
        if len(self.size) != expected:
            raise ValueError(
                f"a {self.shape} needs size {_SIZE_FIELDS[self.shape]}, got {list(self.size)}"
            )

    @property
    def height(self) -> float:
        return {"cylinder": self.size[-1], "cuboid": self.size[-1]}.get(
            self.shape, 2 * self.size[0]
        )


class ApplianceEntry(Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """A microwave: a box with a cavity open at its front (+x of its frame) closed by a door
    hinged on a vertical edge, driven by a motor. ``size``: outside depth x, width y,
    height z.

    Attributes:
        type: Ontology class of the appliance.
        label: World-model label, MuJoCo body name and device owner key segment (its door is
            ``<label>-door``).
        parent: Furniture label it stands on. Empty: the floor.
        pose: Bottom centre in the parent's frame, on its support surface.
        size (m): Outside depth x, width y, height z.
        wall (m): Thickness of the walls.
        hinge: Door hinge side, seen from the front.
        door_open_angle (rad): Door angle when fully open.
        door_speed (rad/s): Door speed of the motor.
        door_motor: False: the door has no motor (the appliance cannot open it itself); it has a bar
            handle on its outer face instead (0.08 m from the free edge, at mid height, 0.05 m out),
            for an arm to swing it (``open_door`` of an arm).
        heating_power (W): Heating power.
        default_heating_time (s): What the ``start`` button heats for.
        agent: Skill-agent config file of this appliance (resolved against the scenario file);
            empty: none.
        rgba: Colour: red, green, blue, alpha, each 0..1.
    """

    type: str = "Microwave"
    label: Label
    parent: str = ""
    pose: Placement = Placement()
    size: Size3 = (0.40, 0.50, 0.30)
    wall: Annotated[float, Meta(gt=0, le=0.1)] = 0.02
    hinge: Literal["left", "right"] = "left"
    door_open_angle: Annotated[float, Meta(gt=0.1, le=2.5)] = 1.75
    door_speed: Annotated[float, Meta(gt=0, le=10)] = 1.2
    door_motor: bool = True
    heating_power: Annotated[float, Meta(ge=0, le=3000)] = 800.0
    default_heating_time: Annotated[float, Meta(gt=0, le=3600)] = 30.0
    agent: str = ""
    rgba: RGBA = (0.85, 0.85, 0.88, 1.0)


class SensorEntry(Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """A camera (``kind = "camera"``: on a robot's camera site with ``mount``, or fixed at
    ``position`` looking at ``look_at``) or a smart platform (``kind = "platform"``: the
    tactile top of the furniture ``surface``).

    Attributes:
        kind: ``camera``: detects objects in its field of view; ``platform``: a smart platform, the
            tactile top of the furniture ``surface``.
        label: World-model label of the sensor (a platform: the label of its furniture element).
        type: Ontology class; default ``Camera`` or ``SmartPlatform``.
        mount: Cameras: robot name for a robot-mounted camera; empty: fixed in the world at
            ``position``.
        site: Cameras on a robot: the robot's camera site it sits on.
        position (m): Fixed cameras: world position x, y, z (required without ``mount``).
        look_at (m): Fixed cameras: the world point x, y, z it looks at (required without
            ``mount``).
        surface: Platforms: label of the furniture whose top is the platform (required for a
            platform).
        fov (deg): Cameras: vertical field of view (the horizontal one follows from a 4:3 image).
        range (m): Cameras: farthest distance at which objects are detected.
        noise_std (m): Standard deviation of the Gaussian position noise per axis: cameras at 1 m
            depth (it grows with depth), platforms in x and y.
        rate (Hz): Cameras: image rate when images are recorded.
        occlusion: Cameras: a part hidden behind another object (a ray from the camera to the part's
            centre hits something else first) is not seen. Boxes and appliances are always seen.
        device: Device key segment (``devices/<owner>/<device>``); default ``camera`` on a robot,
            ``sensor`` for a fixed camera or a platform.
    """

    kind: Literal["camera", "platform"]
    label: Label
    type: str = ""
    mount: str = ""
    site: Literal["front_camera", "wrist_camera"] = "front_camera"
    position: Vec3 | None = None
    look_at: Vec3 | None = None
    surface: str = ""
    fov: Annotated[float, Meta(gt=0, lt=180)] = 60.0
    range: Annotated[float, Meta(gt=0, le=50)] = 3.0
    noise_std: Annotated[float, Meta(ge=0, le=1)] = 0.004
    rate: Annotated[float, Meta(gt=0, le=100)] = 5.0
    occlusion: bool = True
    device: Label | None = None

    @property
    def owner(self) -> str:
        """Key segment of the device owner: the robot it is mounted on, else its label."""
        return self.mount or self.label

    @property
    def device_name(self) -> str:
        return self.device or ("camera" if self.mount else "sensor")

    @property
    def ontology_type(self) -> str:
        return self.type or ("Camera" if self.kind == "camera" else "SmartPlatform")


class Scenario(Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """A whole scenario. Build it with :func:`~scenario.load_scenario`
    (checks references); constructing it directly checks only field types.

    Attributes:
        name: Scenario name (``--scenario NAME`` finds ``configs/scenarios/NAME/scenario.toml``).
        description: Free text shown to people.
        floor_size (m): Half size of the square floor.
        prior_noise (m): Rough prior knowledge (SkiROS): the standard deviation of the error in x
            and y of the parts' initial world-model poses (the simulation places them exactly); each
            part's error is drawn from its label, so a scene is the same every time. Sensing
            (``locate``, which ``pick`` runs first) refines them. 0: the world model starts with the
            exact poses.
        robots: Mobile manipulators.
        furniture: Stations, shelves, tables, worktops, cabinets.
        containers: Part boxes, kit boxes, trays, meal boxes.
        parts: Parts: free rigid bodies.
        appliances: Appliances with a motorised (or handled) door: a microwave.
        sensors: Cameras and smart platforms.
        goals: Goal facts as text, e.g. ``contain(KitBox-1, Gear-1)``; ``!`` negates one. The task
            layer parses them.
        ontology: Turtle files with the scenario's own ontology terms (a new part type, a
            relation, a data property, templates), relative to the scenario file; taught to the
            world model's ontology, for the whole mesh, when the scene is loaded.
        source: The file it was read from (set by the loader; leave it out).
    """

    name: Label
    description: str = ""
    floor_size: Annotated[float, Meta(gt=1, le=100)] = 8.0
    prior_noise: Annotated[float, Meta(ge=0, le=0.2)] = 0.0
    robots: list[RobotEntry] = []
    furniture: list[FurnitureEntry] = []
    containers: list[ContainerEntry] = []
    parts: list[PartEntry] = []
    appliances: list[ApplianceEntry] = []
    sensors: list[SensorEntry] = []
    goals: list[str] = []
    ontology: list[str] = []
    source: str = ""

    def robot(self, name: str) -> RobotEntry:
        for robot in self.robots:
            if robot.name == name:
                return robot
        raise KeyError(f"no robot {name!r}; robots: {[r.name for r in self.robots]}")

    @property
    def agents(self) -> dict[str, str]:
        """Skill-agent config paths by robot name / appliance label (those that set one)."""
        found = {r.name: r.agent for r in self.robots if r.agent}
        found.update({a.label: a.agent for a in self.appliances if a.agent})
        return found

    @property
    def labels(self) -> list[str]:
        """Every element label, robots first."""
        groups: list[list[str]] = [
            [r.name for r in self.robots],
            [f.label for f in self.furniture],
            [f.drawer.label for f in self.furniture if f.drawer is not None],
            [c.label for c in self.containers],
            [p.label for p in self.parts],
            [a.label for a in self.appliances],
            [s.label for s in self.sensors],
        ]
        return [label for group in groups for label in group]


GOAL = re.compile(r"\s*!?\s*[A-Za-z_][A-Za-z0-9_]*\s*\(([^()]*)\)\s*")
