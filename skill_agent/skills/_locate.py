"""``locate``: find an object with the robot's sensors and write its pose to the world model.

The sensing skill of SkiROS (used by ``pick`` in its ``pre_sense``): every bound sensor
(``sensor``, and ``platform`` when given) is asked at once; each one that sees the object
contributes one observation of its pose (source = the sensor's element id, with the
detection's confidence), replacing older observations, and ``seenAt`` is stamped. If the
object is now outside the element that holds it in the world model (it fell, someone moved
it), its spatial parent becomes the smallest container or surface around where it was seen.
Not seen by any sensor: if a person reported where the object is (an observation of its pose
whose source is an ``Operator`` element, written when the operator answers a request with
``skimesh operator --seen``; FRIEND II's user as the last sensor) less than
:data:`OPERATOR_SIGHTING_AGE` seconds ago, that is where it is, and the run says so; otherwise
the run fails (``execution``) and the world model is left as it was.
"""

from __future__ import annotations

import time

from skill_agent._errors import SkillFailure
from skill_agent._skill import Skill, SkillContext
from skill_agent.protocol._skills import HasPropertyCond, SkillDescription
from skill_agent.skills._params import OBJECT, PLATFORM, SENSOR
from skill_agent.skills._sensing import (
    Sensors,
    containing,
    look,
    move_ops,
    observation_ops,
    sensors_of,
    still_inside,
)
from skill_agent.skills._support import element_id, wm_of
from wm_store import WmClient, display_name
from wm_store.ontology import Cls, Prop
from wm_store.protocol import Observation

__all__ = ["OPERATOR_SIGHTING_AGE", "Locate", "locate_object", "operator_sighting"]

OPERATOR_SIGHTING_AGE = 300.0
"""How long a person's report of where an object is stands in for the sensors, s."""


def operator_sighting(wm: WmClient, element: str, now: float | None = None) -> Observation | None:
    """The newest pose observation of ``element`` by an ``Operator`` element, if it is younger
    than :data:`OPERATOR_SIGHTING_AGE` seconds."""
    found = wm.get_element(element).observations.get(Prop.pose, [])
    stamp = time.time() if now is None else now
    best: Observation | None = None
    for obs in found:
        source = wm.find_element(obs.source)
        if source is None or not wm.ontology.is_a(source.type, Cls.Operator):
            continue
        if stamp - obs.stamp <= OPERATOR_SIGHTING_AGE and (best is None or obs.stamp > best.stamp):
            best = obs
    return best


async def locate_object(ctx: SkillContext, param: str = "object") -> None:
    """Sense the element bound to ``param`` with the run's sensors and record it (see the
    module doc). Raises SkillFailure when no sensor sees it."""
    wm = wm_of(ctx)
    target = wm.get_element(element_id(ctx, param))
    sensors = sensors_of(ctx)
    if not sensors.devices:
        raise SkillFailure(
            f"{ctx.description.name}: no sensor bound to look for {display_name(target)}"
        )
    seen = await look(wm, target, sensors)
    if not seen:
        told = operator_sighting(wm, target.id)
        if told is None:
            raise SkillFailure(
                f"{ctx.description.name}: {display_name(target)} is not seen by "
                f"{_sensors(wm, sensors)}"
            )
        await ctx.progress(
            f"{display_name(target)} not seen by {_sensors(wm, sensors)}; where the operator "
            f"({_named(wm, told.source)}) saw it {time.time() - told.stamp:.0f} s ago",
            step="located",
        )
        return
    ops = observation_ops(target.id, seen)
    holder = wm.get_parent(target.id)
    inside = holder is None or still_inside(wm, holder.id, seen[0].pose)
    if not inside and (where := containing(wm, seen[0].pose, exclude=[target.id])) is not None:
        ops += move_ops(wm, target.id, where)
    await wm.transact(ops)
    best = seen[0]
    x, y, z = best.pose.translation
    await ctx.progress(
        f"{display_name(target)} seen by {_named(wm, best.source)} at "
        f"({x:.3f}, {y:.3f}, {z:.3f}) "
        f"(confidence {best.confidence:.2f}; {len(seen)} sighting(s))",
        step="located",
    )


def _named(wm: WmClient, element: str) -> str:
    """An element as messages name it (:func:`wm_store.display_name`)."""
    return display_name(wm.find_element(element), element)


def _sensors(wm: WmClient, sensors: Sensors) -> str:
    return ", ".join(_named(wm, source) for source, _ in sensors.devices) or "no sensor"


class Locate(Skill):
    """Find an object and record its pose (sensing skill)."""

    description = SkillDescription(
        name="locate",
        skill_type="locate",
        doc="Find an object with the robot's sensors and write its pose (with source and "
        "confidence) and seenAt to the world model; fails if no sensor sees it.",
        parameters=[OBJECT, SENSOR, PLATFORM],
        post=[HasPropertyCond(param="object", property=Prop.pose)],
        duration=0.5,
    )
    success_probability = 0.95

    async def execute(self, ctx: SkillContext) -> None:
        await locate_object(ctx)
