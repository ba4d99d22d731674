"""Finding objects with the robot's sensors and writing what was seen to the world model.

A sensor (:class:`~device_drivers.interfaces.ObjectSensor`: a camera, a smart platform)
reports :class:`~device_drivers.interfaces.Detection` s of the objects in its view, each named
by its world name, which is the element's world-model label. A detection's pose is the
object's body origin in the world frame: a part's centre, but a container's or an appliance's
*bottom* centre (``device_drivers.scene_model``); :func:`sightings` turns it into the centre
(the world model's convention) using the element's size.

:func:`observation_ops` writes one ``Observe`` of ``pose`` per sensor that saw the object
(``source`` = the sensor's element id, so both sources are world-model elements; the
property's resolution policy, ``most_confident``, picks the value) after dropping the earlier
observations (they describe where the object *was*), and stamps ``seenAt``.
"""

from __future__ import annotations

import time
from collections.abc import Sequence

import anyio
from msgspec import Struct

from device_drivers.interfaces import Detection, ObjectSensor
from wm_store.client import WmClient
from wm_store.protocol import Element, Observe, Op, Pose, SetRelation, UnsetRelation, UpdateElement
from wm_store.reasoners.spatial import Transform
from wm_store.vocab import Cls, Prop, Rel

from ..primitives import extents
from ..primitives.poses import to_transform, to_wm_pose
from ..skill import SkillContext
from .support import device as driver
from .support import world_transform

__all__ = [
    "Sighting",
    "containing",
    "detect_all",
    "move_ops",
    "observation_ops",
    "sensors_of",
    "sightings",
    "still_inside",
]


class Sighting(Struct, frozen=True):
    """One sensor's report of an element: the sensor's element id, the element's centre pose
    (world), the detection's confidence."""

    source: str
    pose: Transform
    confidence: float


def sensors_of(ctx: SkillContext, *params: str) -> list[tuple[str, ObjectSensor]]:
    """(element id, driver) of every bound sensor parameter among ``params`` (unbound optional
    ones are skipped)."""
    found = []
    for param in params:
        device = ctx.params.get(param)
        if isinstance(device, str) and device:
            found.append((device, driver(ctx, param, ObjectSensor)))  # type: ignore[type-abstract]
    return found


async def detect_all(sensors: Sequence[tuple[str, ObjectSensor]]) -> dict[str, list[Detection]]:
    """Every sensor's detections (concurrently), by sensor element id."""
    results: dict[str, list[Detection]] = {}

    async def one(source: str, sensor: ObjectSensor) -> None:
        results[source] = await sensor.detect()

    async with anyio.create_task_group() as tg:
        for source, sensor in sensors:
            tg.start_soon(one, source, sensor)
    return results


def sightings(
    wm: WmClient, element: Element, detections: dict[str, list[Detection]]
) -> list[Sighting]:
    """The detections of ``element`` (matched by label), as centre poses, most confident
    first."""
    lift = 0.0
    onto = wm.ontology
    if onto.is_a(element.type, Cls.Container) or onto.is_a(element.type, Cls.Appliance):
        ext = extents(element.properties.get(Prop.size))
        lift = ext[2] / 2 if ext is not None else 0.0
    found = []
    for source, seen in detections.items():
        for d in seen:
            if d.name == element.label:
                origin = to_transform(d.pose)
                centre = origin.compose(Transform((0.0, 0.0, lift)))
                found.append(Sighting(source, centre, d.confidence))
    return sorted(found, key=lambda s: -s.confidence)


def observation_ops(element: str, seen: Sequence[Sighting], now: float | None = None) -> list[Op]:
    """Replace the element's pose observations by ``seen`` and stamp ``seenAt`` (epoch s)."""
    stamp = time.time() if now is None else now
    ops: list[Op] = [UpdateElement(id=element, properties={Prop.seenAt: stamp}, remove=[Prop.pose])]
    ops += [
        Observe(
            id=element,
            property=Prop.pose,
            value=to_wm_pose(s.pose),
            source=s.source,
            confidence=s.confidence,
            stamp=stamp,
        )
        for s in seen
    ]
    return ops


def containing(wm: WmClient, point: Transform, *, exclude: Sequence[str] = ()) -> str | None:
    """The smallest container, appliance or surface whose volume (grown by 2 cm) holds
    ``point``'s position: where an object found there lies. None if nothing does."""
    best: tuple[float, str] | None = None
    probe = Element(id="", type=Cls.PhysicalObject, properties={Prop.pose: _pose(point)})
    for cls in (Cls.Container, Cls.Appliance, Cls.Furniture):
        for candidate in wm.resolve_element(type=cls):
            ext = extents(candidate.properties.get(Prop.size))
            if candidate.id in exclude or ext is None or world_transform(wm, candidate.id) is None:
                continue
            try:
                inside = wm.spatial.is_inside(probe, candidate.id, tolerance=0.02)
            except Exception:  # a pose the reasoner cannot read: not a candidate
                continue
            volume = ext[0] * ext[1] * ext[2]
            if inside and (best is None or volume < best[0]):
                best = (volume, candidate.id)
    return None if best is None else best[1]


def still_inside(wm: WmClient, holder: str, point: Transform) -> bool:
    """Whether ``point`` lies in the holder's volume (grown by 3 cm); True when the holder has
    no pose or size (a gripper, a robot): nothing to second-guess then."""
    h = wm.get_element(holder)
    if h.properties.get(Prop.size) is None or world_transform(wm, holder) is None:
        return True
    probe = Element(id="", type=Cls.PhysicalObject, properties={Prop.pose: _pose(point)})
    try:
        return wm.spatial.is_inside(probe, holder, tolerance=0.03)
    except Exception:  # frames the reasoner cannot chain
        return True


def move_ops(wm: WmClient, element: str, new_parent: str | None) -> list[Op]:
    """Ops making ``new_parent`` contain ``element`` (None: no spatial parent)."""
    ops: list[Op] = []
    parent = wm.get_parent(element)
    if parent is not None and parent.id == new_parent:
        return ops
    if parent is not None:
        for rel in wm.query_relation(parent.id, "", element):
            if rel.predicate in (Rel.contain, Rel.hasA):
                ops.append(
                    UnsetRelation(subject=rel.subject, predicate=rel.predicate, object=element)
                )
    if new_parent is not None:
        ops.append(SetRelation(subject=new_parent, predicate=Rel.contain, object=element))
    return ops


def _pose(t: Transform) -> Pose:
    return to_wm_pose(t)
