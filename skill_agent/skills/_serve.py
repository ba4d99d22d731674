"""Variants of ``place``: ``serve`` (onto a tray at the robot's location, FRIEND II's "serve the
meal"), ``place_at`` (into a container at the robot's location: a box on the table beside a
fixed arm) and ``put_in`` (into an empty appliance through its open door, in and out along its
front). They share :class:`~skill_agent.skills.Place`'s execution and honest checks."""

from __future__ import annotations

from device_drivers import WorldPose
from skill_agent._skill import SkillContext
from skill_agent.primitives.poses import Vec3
from skill_agent.protocol._skills import ParamSpec, SkillDescription
from skill_agent.skills._manipulation import depth_inside, front_of
from skill_agent.skills._params import (
    LOCATION,
    OBJECT,
    at,
    contains,
    door_is,
    empty,
    not_full,
    offline,
)
from skill_agent.skills._place import DEVICES, TUNING, Place
from skill_agent.skills._support import element_id, float_param, wm_of
from wm_store.ontology import Cls

__all__ = ["PlaceAt", "PutIn", "Serve"]


def _put_down(name: str, doc: str, target: str, cls: str, what: str) -> SkillDescription:
    """A place into ``target`` (of class ``cls``) standing at the robot's location."""
    return SkillDescription(
        name=name,
        skill_type="place",
        doc=doc,
        parameters=[
            OBJECT,
            ParamSpec(name=target, type=cls, doc=what),
            LOCATION,
            *DEVICES,
            *TUNING,
        ],
        pre=[
            contains("gripper", "object"),
            at("robot", "location"),
            at(target, "location"),
            not_full(target),
        ],
        hold=[contains("gripper", "object")],
        post=[contains(target, "object"), contains("gripper", "object", holds=False)],
        duration=4.0,
    )


class Serve(Place):
    """Put the held object on a tray at the robot's location (FRIEND II: serve the meal)."""

    description = _put_down(
        "serve", "Put the held object down on a tray within reach (serve it).",
        "tray", Cls.Tray, "the tray",
    )  # fmt: skip
    target_param = "tray"


class PlaceAt(Place):
    """Put the held object into a container at the robot's location, not carried by it (a box
    on the table beside a fixed arm)."""

    description = _put_down(
        "place_at",
        "Put the held object down into a container within reach at the robot's location "
        "(a box on a table beside the arm).",
        "container", Cls.Container, "where it goes",
    )  # fmt: skip
    success_probability = 0.95
    target_param = "container"


class PutIn(Place):
    """Put the held object into an appliance through its open door."""

    description = SkillDescription(
        name="put_in",
        skill_type="place",
        doc="Put the held object into an empty appliance (a microwave) through its open door.",
        parameters=[
            OBJECT,
            ParamSpec(name="appliance", type=Cls.Appliance, doc="where it goes"),
            LOCATION,
            *DEVICES,
            *[p for p in TUNING if p.name != "wall"],
            offline("wall", "float", 0.02, "wall and floor thickness of the appliance, m"),
        ],
        pre=[
            contains("gripper", "object"),
            door_is("appliance", True),
            empty("appliance"),
            at("robot", "location"),
            at("appliance", "location"),
        ],
        hold=[contains("gripper", "object"), door_is("appliance", True)],
        post=[contains("appliance", "object"), contains("gripper", "object", holds=False)],
        duration=5.0,
    )
    target_param = "appliance"

    def travel(self, ctx: SkillContext, goal: WorldPose) -> tuple[Vec3 | None, float, Vec3, float]:
        """In through the front from ``approach`` m back; out until ``approach`` m clear of
        the front (a joint motion home from inside the cavity would sweep the hand through
        its walls)."""
        wm, appliance = wm_of(ctx), element_id(ctx, "appliance")
        front, inside = front_of(wm, appliance), depth_inside(wm, appliance, goal)
        offset = float_param(ctx, "approach")
        return (-front[0], -front[1], 0.0), offset, front, inside + offset
