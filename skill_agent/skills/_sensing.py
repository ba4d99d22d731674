"""Finding objects with the robot's sensors and writing what was seen to the world model.

A sensor (:class:`~device_drivers.ObjectSensor`: a camera, a smart platform)
reports :class:`~device_drivers.Detection` s of the objects in its view, each named
by its world name, which is the element's world-model label. A camera reports the object's
*centre* (the world model's convention, ``mujoco_sim.control``); a smart platform reports
the centre of the object's *footprint on its surface*, so :func:`sightings` raises a
platform's report by half the object's height (from its size in the world model).

:func:`observation_ops` writes one ``Observe`` of ``pose`` per sensor that saw the object
(``source`` = the sensor's element id, so both sources are world-model elements; the
property's resolution policy, ``most_confident``, picks the value) after dropping the earlier
observations (they describe where the object *was*), and stamps ``seenAt``.
"""

from __future__ import annotations

import time
from collections.abc import Sequence

import anyio
import msgspec
from msgspec import Struct

from device_drivers import Detection, ObjectSensor
from skill_agent._skill import SkillContext
from skill_agent.primitives._grasp import extents
from skill_agent.primitives.poses import to_transform, to_wm_pose
from skill_agent.skills._support import device as driver
from skill_agent.skills._support import world_transform
from wm_store import WmClient
from wm_store.ontology import Cls, Prop, Rel
from wm_store.protocol import Element, Observe, Op, Pose, SetRelation, UnsetRelation, UpdateElement
from wm_store.reasoners import Transform

__all__ = [
    "FRAMES",
    "Sensors",
    "Sighting",
    "containing",
    "detect_all",
    "lies_in",
    "look",
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


class Sensors(Struct, frozen=True):
    """The run's sensors: (element id, driver) pairs, and which of them are platforms."""

    devices: list[tuple[str, ObjectSensor]]
    platforms: list[str]

    @property
    def names(self) -> str:
        return ", ".join(source for source, _ in self.devices) or "no sensor"


def sensors_of(ctx: SkillContext) -> Sensors:
    """The bound ``sensor`` and ``platform`` parameters of the run (unbound optional ones are
    skipped)."""
    found, platforms = [], []
    for param in ("sensor", "platform"):
        device = ctx.params.get(param)
        if isinstance(device, str) and device:
            found.append((device, driver(ctx, param, ObjectSensor)))  # type: ignore[type-abstract]
            if param == "platform":
                platforms.append(device)
    return Sensors(found, platforms)


async def look(wm: WmClient, element: Element, sensors: Sensors) -> list[Sighting]:
    """Ask every sensor at once; the element's sightings (see :func:`sightings`)."""
    return sightings(wm, element, await detect_all(sensors.devices), footprints=sensors.platforms)


FRAMES = 8
"""Detections averaged per sensor and look: a camera's position noise shrinks by
``sqrt(FRAMES)`` (the simulated overhead camera's noise: see docs/benchmarks.md, section
Simulation, "Sensing noise")."""


async def detect_all(
    sensors: Sequence[tuple[str, ObjectSensor]], *, frames: int = FRAMES
) -> dict[str, list[Detection]]:
    """Every sensor's detections (concurrently), by sensor element id; each sensor is asked
    ``frames`` times and the positions of each object are averaged (orientation and type of
    the last frame, the mean confidence)."""
    results: dict[str, list[Detection]] = {}

    async def one(source: str, sensor: ObjectSensor) -> None:
        batches = [await sensor.detect() for _ in range(max(1, frames))]
        results[source] = _average(batches)

    async with anyio.create_task_group() as tg:
        for source, sensor in sensors:
            tg.start_soon(one, source, sensor)
    return results


def _average(batches: Sequence[Sequence[Detection]]) -> list[Detection]:
    by_name: dict[str, list[Detection]] = {}
    for batch in batches:
        for d in batch:
            by_name.setdefault(d.name, []).append(d)
    merged = []
    for seen in by_name.values():
        n = len(seen)
        last = seen[-1]
        pose = msgspec.structs.replace(
            last.pose,
            x=sum(float(d.pose.x) for d in seen) / n,
            y=sum(float(d.pose.y) for d in seen) / n,
            z=sum(float(d.pose.z) for d in seen) / n,
        )
        confidence = sum(float(d.confidence) for d in seen) / n
        merged.append(msgspec.structs.replace(last, pose=pose, confidence=confidence))
    return merged


def sightings(
    wm: WmClient,
    element: Element,
    detections: dict[str, list[Detection]],
    *,
    footprints: Sequence[str] = (),
) -> list[Sighting]:
    """The detections of ``element`` (matched by label), as centre poses, most confident
    first. ``footprints``: the sources (smart platforms) that report where an object stands
    on their surface rather than its centre."""
    ext = extents(element.properties.get(Prop.size))
    half = ext[2] / 2 if ext is not None else 0.0
    found = []
    for source, seen in detections.items():
        lift = half if source in footprints else 0.0
        for d in seen:
            if d.name == element.label:
                centre = Transform((0.0, 0.0, lift)).compose(to_transform(d.pose))
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
            confidence=float(s.confidence),
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


def still_inside(wm: WmClient, holder: str, point: Transform, *, tolerance: float = 0.03) -> bool:
    """Whether ``point`` lies in the holder's volume (grown by ``tolerance`` m); True when the
    holder has no pose or size (a gripper, a robot): nothing to second-guess then."""
    h = wm.get_element(holder)
    if h.properties.get(Prop.size) is None or world_transform(wm, holder) is None:
        return True
    probe = Element(id="", type=Cls.PhysicalObject, properties={Prop.pose: _pose(point)})
    try:
        return wm.spatial.is_inside(probe, holder, tolerance=tolerance)
    except Exception:  # frames the reasoner cannot chain
        return True


def lies_in(
    wm: WmClient, target: str, centre: Transform, height: float, *, tolerance: float = 0.01
) -> bool:
    """Whether an upright object of ``height`` m centred at ``centre`` rests in (or on) the
    target: its centre over the target's footprint and its bottom between the target's
    bottom and top, each grown by ``tolerance`` m. True when the target's geometry is unknown
    (nothing to check against). A flat container (a tray) holds what stands on it."""
    pose = world_transform(wm, target)
    ext = extents(wm.get_element(target).properties.get(Prop.size))
    if pose is None or ext is None:
        return True
    x, y, z = pose.inverse().apply(centre.translation)
    bottom = z - height / 2
    return (
        abs(x) <= ext[0] / 2 + tolerance
        and abs(y) <= ext[1] / 2 + tolerance
        and -ext[2] / 2 - tolerance <= bottom <= ext[2] / 2 + tolerance
    )


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
