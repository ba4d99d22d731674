"""SimTruth: a running :class:`~mujoco_sim.SimWorld` as a :class:`device_drivers.truth.GroundTruth`.

Answers every :data:`~device_drivers.truth.TruthRequest` from the world's latest snapshot, on
the event loop (snapshots are immutable; nothing here touches MuJoCo's data). Settling sleeps
in simulated time (:meth:`SimWorld.sleep`: a fast world steps, a real-time one is waited for)
and is bounded twice: by the request's simulated seconds, and by ``wall_bound`` wall seconds
beyond them (a world that has stopped answers at once). An unknown label raises
:class:`~device_drivers.UnknownElementError`, which the queryable answers by name.
"""

from __future__ import annotations

import anyio

from device_drivers import ApplianceState, DeviceKey, UnknownElementError
from device_drivers import truth as t

from ._world import SimWorld

__all__ = ["REST_SPEED", "SimTruth"]

REST_SPEED = 0.01
"""m/s: an object slower than this is at rest (as :meth:`SimWorld.object_in` judges)."""


class SimTruth:
    """The ground truth of ``world`` (see the module doc)."""

    def __init__(self, world: SimWorld, *, wall_bound: float = 10.0) -> None:
        self.world = world
        self.wall_bound = wall_bound

    async def answer(self, request: t.TruthRequest) -> t.TruthReply:
        world = self.world
        match request:
            case t.SimClock():
                failure = world.failure
                return t.ClockReply(
                    time=world.snapshot.time,
                    fast=world.options.fast,
                    failure=str(failure) if failure is not None else "",
                )
            case t.Scene():
                return t.SceneReply(
                    time=world.snapshot.time,
                    objects=sorted(world.facts.objects),
                    appliances=sorted(self._appliances()),
                )
            case t.Settle(objects=objects, settle=settle, rest_within=rest_within):
                moving = await self._settle(objects, settle, rest_within)
                return t.SettleReply(time=world.snapshot.time, moving=moving)
            case t.ObjectIn(thing=thing, holder=holder):
                self._object(holder)
                await self._settle([thing], request.settle, request.rest_within)
                snap = world.snapshot
                held = thing in snap.attached
                speed = snap.speeds.get(thing, 0.0)
                return t.ObjectInReply(
                    time=snap.time,
                    thing=thing,
                    holder=holder,
                    inside=world.object_in(thing, holder),
                    pose=world.body_pose(thing),
                    held=held,
                    speed=speed,
                    at_rest=not held and speed <= REST_SPEED,
                )
            case t.ApplianceTruth(label=label):
                return t.ApplianceReply(
                    time=world.snapshot.time, label=label, state=self._appliance(label)
                )
            case t.Poses(labels=labels):
                poses = {label: world.body_pose(label) for label in labels}
                return t.PosesReply(time=world.snapshot.time, poses=poses)
        raise UnknownElementError("request", type(request).__name__, ())  # pragma: no cover

    def _object(self, label: str) -> None:
        if label not in self.world.facts.objects:
            raise UnknownElementError("object", label, self.world.facts.objects)

    def _appliances(self) -> dict[str, DeviceKey]:
        world = self.world
        return {world.label(k): k for k, kind in world.devices.items() if kind == "appliance"}

    def _appliance(self, label: str) -> ApplianceState:
        known = self._appliances()
        if label not in known:
            raise UnknownElementError("appliance", label, known)
        state = self.world.state(known[label])
        if not isinstance(state, ApplianceState):
            raise UnknownElementError("appliance", label, known)
        return state

    def _at_rest(self, label: str) -> bool:
        snap = self.world.snapshot
        return label not in snap.attached and snap.speeds.get(label, 0.0) <= REST_SPEED

    async def _settle(self, objects: list[str], settle: float, rest_within: float) -> list[str]:
        """Sleep ``settle`` simulated s, then until every one of ``objects`` is at rest (at
        most ``rest_within`` simulated s more); the objects still moving or held."""
        world = self.world
        for label in objects:
            self._object(label)
        with anyio.move_on_after(settle + rest_within + self.wall_bound):
            if settle > 0:
                await world.sleep(settle)  # returns at once if the world has stopped
            deadline = world.snapshot.time + rest_within
            while world.snapshot.time < deadline and world.failure is None:
                if all(self._at_rest(o) for o in objects):
                    break
                await world.sleep(min(0.1, deadline - world.snapshot.time))
        return [o for o in objects if not self._at_rest(o)]
