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
    centre."""

    x: Coord = 0.0
    y: Coord = 0.0
    z: Annotated[float, Meta(ge=0, le=10)] = 0.0
    yaw: float = 0.0


class RobotEntry(Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """A mobile manipulator (:class:`RobotSpec` fields under ``model``): generated, or with its
    arm and gripper from MJCF files (``[robots.model.mjcf]``, :class:`~device_drivers.
    robot_spec.MjcfArm`; an empty table means Menagerie's UR5e + Robotiq 2F-85, relative file
    paths are resolved against the scenario file). Its devices are ``arm``, ``gripper`` and
    ``base`` (world-model labels ``<name>-arm`` ...), plus any sensor mounted on it."""

    name: Label
    type: str = "MobileManipulator"
    pose: Pose2D = Pose2D()
    model: RobotSpec = RobotSpec()
    agent: str = ""
    """Skill-agent config of this robot (resolved against the scenario file)."""

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
    finger behind it). ``height``: of the box, m. Built by :mod:`mujoco_sim.models`."""

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
    with a ``drawer`` under its top opening at its front, +x)."""

    type: str
    label: Label
    pose: Pose2D = Pose2D()
    size: Size3
    shape: FurnitureShape | None = None
    """Default: ``area`` for a Station, ``shelf`` for a Shelf, ``table`` for a Table, else
    ``block``."""
    station: str = ""
    """The station (an ``area`` furniture label) this belongs to: world-model ``contain``."""
    rgba: RGBA = (0.62, 0.50, 0.38, 1.0)
    drawer: DrawerSpec | None = None
    """A ``cabinet``'s drawer (only a cabinet has one)."""

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
    others are free bodies that can be grasped."""

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
    vertical), cuboid ``[x, y, z]``, sphere ``[radius]``."""

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
    height z."""

    type: str = "Microwave"
    label: Label
    parent: str = ""
    pose: Placement = Placement()
    size: Size3 = (0.40, 0.50, 0.30)
    wall: Annotated[float, Meta(gt=0, le=0.1)] = 0.02
    hinge: Literal["left", "right"] = "left"
    """Door hinge side, seen from the front."""
    door_open_angle: Annotated[float, Meta(gt=0.1, le=2.5)] = 1.75
    door_speed: Annotated[float, Meta(gt=0, le=10)] = 1.2
    """Door speed of the motor, rad/s."""
    door_motor: bool = True
    """False: the door has no motor (the appliance cannot open it itself); it has a bar handle
    on its outer face instead (:data:`DOOR_HANDLE_INSET` from the free edge, at mid height,
    :data:`DOOR_HANDLE_STANDOFF` out), for an arm to swing it (``open_door`` of an arm)."""
    heating_power: Annotated[float, Meta(ge=0, le=3000)] = 800.0
    default_heating_time: Annotated[float, Meta(gt=0, le=3600)] = 30.0
    """What the ``start`` button heats for, s."""
    agent: str = ""
    rgba: RGBA = (0.85, 0.85, 0.88, 1.0)


class SensorEntry(Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """A camera (``kind = "camera"``: on a robot's camera site with ``mount``, or fixed at
    ``position`` looking at ``look_at``) or a smart platform (``kind = "platform"``: the
    tactile top of the furniture ``surface``)."""

    kind: Literal["camera", "platform"]
    label: Label
    type: str = ""
    """Ontology class; default ``Camera`` or ``SmartPlatform``."""
    mount: str = ""
    """Robot name for a robot-mounted camera; empty: fixed in the world."""
    site: Literal["front_camera", "wrist_camera"] = "front_camera"
    position: Vec3 | None = None
    look_at: Vec3 | None = None
    surface: str = ""
    fov: Annotated[float, Meta(gt=0, lt=180)] = 60.0
    """Vertical field of view, degrees (the horizontal one follows from a 4:3 image)."""
    range: Annotated[float, Meta(gt=0, le=50)] = 3.0
    noise_std: Annotated[float, Meta(ge=0, le=1)] = 0.004
    """Standard deviation of the position noise at 1 m (cameras: grows with depth), m."""
    rate: Annotated[float, Meta(gt=0, le=100)] = 5.0
    """Image rate when images are recorded, Hz."""
    occlusion: bool = True
    """Cameras: an object hidden behind another one (ray test to its centre) is not seen."""
    device: Label | None = None
    """Device key segment; default ``camera`` on a robot, ``sensor`` for a fixed one."""

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
    (checks references); constructing it directly checks only field types."""

    name: Label
    description: str = ""
    floor_size: Annotated[float, Meta(gt=1, le=100)] = 8.0
    """Half size of the floor, m."""
    prior_noise: Annotated[float, Meta(ge=0, le=0.2)] = 0.0
    """Rough prior knowledge (SkiROS): the standard deviation, m, of the error in x and y of the
    parts' initial world-model poses (the simulation places them exactly); each part's error
    is drawn from its label, so a scene is the same every time. Sensing (``locate``, which
    ``pick`` runs first) refines them. 0: the world model starts with the exact poses."""
    robots: list[RobotEntry] = []
    furniture: list[FurnitureEntry] = []
    containers: list[ContainerEntry] = []
    parts: list[PartEntry] = []
    appliances: list[ApplianceEntry] = []
    sensors: list[SensorEntry] = []
    goals: list[str] = []
    """Goal facts as text, e.g. ``contain(KitBox-1, Gear-1)``; the task layer parses them."""
    ontology: list[str] = []
    """Turtle files with the scenario's own ontology terms (classes such as a new part type,
    relations, data properties, templates), relative to the scenario file; taught to the
    world model's ontology, for the whole mesh, when the scene is loaded."""
    source: str = ""
    """The file it was read from (set by the loader)."""

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
