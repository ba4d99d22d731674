"""Parameters and conditions the standard skills share (descriptions are data: planners see
them, the runtime checks them). Element parameters are typed by ontology classes (``Cls``);
relations and properties are named by ``Rel`` / ``Prop`` (generated from the ontology, so a
misspelt name fails at import).

Hardware parameters are the devices a run locks: ``robot`` (the whole robot: body motions of
one robot never overlap), ``arm``, ``gripper``, ``base``, ``sensor``. ``platform`` is an
optional second sensor (a smart platform), used when the caller binds it.
"""

from __future__ import annotations

from skill_agent.protocol._skills import (
    EmptyCond,
    IsTypeCond,
    NotCond,
    ParamSpec,
    PropertyCond,
    RelationCond,
)
from wm_store.ontology import Cls, Prop, Rel

__all__ = [
    "ARM",
    "BASE",
    "GRIPPER",
    "LOCATION",
    "OBJECT",
    "PLATFORM",
    "ROBOT",
    "SENSOR",
    "at",
    "contains",
    "door_is",
    "empty",
    "is_not",
    "not_full",
    "offline",
]

OBJECT = ParamSpec(name="object", type=Cls.PhysicalObject, doc="the object handled")
LOCATION = ParamSpec(
    name="location",
    type=Cls.Location,
    doc="where the robot stands to do it (a station, or the home of a robot that does not drive)",
)
ROBOT = ParamSpec(
    name="robot", type=Cls.Robot, kind="hardware", doc="the robot (one body motion at a time)"
)
ARM = ParamSpec(name="arm", type=Cls.Arm, kind="hardware", doc="the arm that moves")
GRIPPER = ParamSpec(name="gripper", type=Cls.Gripper, kind="hardware", doc="the gripper used")
BASE = ParamSpec(name="base", type=Cls.MobileBase, kind="hardware", doc="the mobile base")
SENSOR = ParamSpec(
    name="sensor", type=Cls.Sensor, kind="hardware", doc="the camera that finds the object"
)
PLATFORM = ParamSpec(
    name="platform",
    type=Cls.SmartPlatform,
    kind="hardware",
    optional=True,
    doc="a smart platform that also senses the object (FRIEND II), when given",
)


def offline(name: str, kind: str, default: float | bool, doc: str) -> ParamSpec:
    """A configuration parameter with a default (units in ``doc``)."""
    return ParamSpec(name=name, type=kind, kind="offline", default=default, doc=doc)


def contains(holder: str, thing: str, holds: bool = True) -> RelationCond:
    """``contain(holder, thing)`` (spatial: setting it moves ``thing``)."""
    return RelationCond(subject=holder, predicate=Rel.contain, object=thing, holds=holds)


def at(thing: str, location: str, holds: bool = True) -> RelationCond:
    return RelationCond(subject=thing, predicate=Rel.at, object=location, holds=holds)


def empty(param: str) -> EmptyCond:
    """``param`` contains nothing (a gripper: holds nothing)."""
    return EmptyCond(param=param, predicate=Rel.contain)


def not_full(param: str) -> EmptyCond:
    """Room left in a container (against its ``capacity``, else the ontology's maximum).
    Run time only: the planner cannot count."""
    return EmptyCond(param=param, predicate=Rel.contain, full=True, holds=False)


def is_not(param: str, cls: str) -> NotCond:
    """The element is not of class ``cls`` (static; subclasses count)."""
    return NotCond(item=IsTypeCond(param=param, cls=cls))


def door_is(appliance: str, open_: bool) -> PropertyCond:
    """``doorOpen(appliance) == open_`` (the ontology puts the property on the appliance)."""
    return PropertyCond(param=appliance, property=Prop.doorOpen, op="eq", value=open_)
