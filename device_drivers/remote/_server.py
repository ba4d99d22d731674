"""Serving devices over Zenoh: ``devices/<owner>/<device>/cmd`` and ``.../state``.

:func:`serve_devices` exposes any objects implementing the device Protocols (in-process
simulation drivers, or real hardware drivers) so that :mod:`device_drivers.remote`
proxies elsewhere can use them with the same interface:

- ``cmd`` (queryable): a :class:`~device_drivers.protocol.Request`, answered once the
  command is done (a motion replies when it has finished) with a ``Reply``, or with an
  :class:`~device_drivers.protocol.ErrorReply` as a Zenoh error reply. Each query runs in
  its own task (meshlink), so a ``Stop`` (or a ``Pause``) overtakes a running motion;
  ``Pause`` / ``Resume`` need a :class:`~device_drivers.Pausable` device (``CommandError``
  otherwise). The queryable is a :class:`meshlink.rpc.RequestHandler`: a request that
  cannot be read (malformed, or longer than ``max_request_bytes``) answers ``bad_request`` /
  ``too_large`` (a ``CommandError`` to the proxies) and nothing moves; an unexpected
  exception answers ``internal`` (a ``DeviceError``) and is logged.
- ``state`` (publication): the device's state, when it changed and at least once a second,
  checked at ``state_rate`` Hz. Congestion control DROP: a late state is worthless, the next
  one replaces it (commands and their replies are the reliable path).
- progress: a request may name a key under ``devices/<owner>/<device>/progress/``; while the
  command runs, :class:`~device_drivers.protocol.Progress` messages go there (~20 Hz).

Runs on the event loop; every Zenoh crossing is inside meshlink.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Awaitable, Callable, Mapping
from functools import partial
from typing import Any, cast

import anyio
import anyio.abc

from device_drivers import protocol as p
from device_drivers._errors import CommandError, DeviceError
from device_drivers._interfaces import (
    Appliance,
    Arm,
    Device,
    DeviceKey,
    Gripper,
    MobileBase,
    ObjectSensor,
    Pausable,
    ProgressCallback,
)
from meshlink import Mesh
from meshlink.rpc import DEFAULT_MAX_REQUEST_BYTES, RequestHandler, encode

__all__ = ["device_kind", "serve_devices"]

_log = logging.getLogger(__name__)
_KINDS: tuple[tuple[type, p.DeviceKind], ...] = (
    (Arm, "arm"),
    (Gripper, "gripper"),
    (MobileBase, "base"),
    (Appliance, "appliance"),
    (ObjectSensor, "sensor"),
)
_ENCODING = "application/msgpack"


def device_kind(device: Device) -> p.DeviceKind:
    """Which interface ``device`` implements (checked in the order arm, gripper, base,
    appliance, sensor)."""
    for protocol_, kind in _KINDS:
        if isinstance(device, protocol_):
            return kind
    raise TypeError(f"{device!r} implements none of the device interfaces")


async def serve_devices(
    mesh: Mesh,
    devices: Mapping[DeviceKey, Device],
    *,
    state_rate: float = 25.0,
    max_request_bytes: int = DEFAULT_MAX_REQUEST_BYTES,
    task_status: anyio.abc.TaskStatus[None] = anyio.TASK_STATUS_IGNORED,
) -> None:
    """Serve ``devices`` (keyed (owner, device)) until cancelled; reports started once every
    queryable is known to the router. A longer command request than ``max_request_bytes``
    answers ``too_large``."""
    served = [_Served(mesh, key, device, max_request_bytes) for key, device in devices.items()]
    async with anyio.create_task_group() as tg:
        for device in served:
            handler = device.rpc.serve_on(device.cmd_key)
            await tg.start(partial(mesh.serve, device.cmd_key, handler))
        tg.start_soon(_publish_states, mesh, [d for d in served if d.kind != "sensor"], state_rate)
        task_status.started()


class _Served:
    """One device as served: its kind (resolved once: a runtime Protocol check is slow), its
    keys, built once, and its ``cmd`` queryable (:attr:`rpc`)."""

    def __init__(
        self,
        mesh: Mesh,
        key: DeviceKey,
        device: Device,
        max_request_bytes: int = DEFAULT_MAX_REQUEST_BYTES,
    ) -> None:
        self.mesh, self.key, self.device = mesh, key, device
        self.kind = device_kind(device)
        self.cmd_key = mesh.keys.device_cmd(*key)
        self.state_key = mesh.keys.device_state(*key)
        self.progress_prefix = self.state_key.removesuffix("state") + "progress/"
        self.rpc: RequestHandler[p.Request, p.Reply] = RequestHandler(
            p.Request,
            self.dispatch,
            errors=self._to_reply,
            max_request_bytes=max_request_bytes,
            error_type=p.ErrorReply,
            name=self.cmd_key,
        )

    def _to_reply(self, exc: Exception) -> p.ErrorReply | None:
        """A device-layer error as its reply (logged unless the command was refused); ``None``
        for any other exception, which the handler answers ``internal`` and logs."""
        if not isinstance(exc, DeviceError):
            return None
        if not isinstance(exc, CommandError):
            _log.info("%s/%s: %s", *self.key, exc)
        return p.error_reply(exc)

    async def dispatch(self, request: p.Request) -> p.Reply:
        cmd, device = request.command, self.device
        if isinstance(cmd, p.Describe):
            return p.DeviceInfo(self.kind, device.name, *self.key)
        if isinstance(cmd, p.GetState):
            return await self.state()
        if isinstance(cmd, p.Stop):
            await device.stop()
            return p.Done()
        if isinstance(cmd, p.Pause | p.Resume):
            if not isinstance(device, Pausable):
                raise CommandError(f"{device.name} cannot be paused")
            await (device.pause() if isinstance(cmd, p.Pause) else device.resume())
            return p.Done()
        key = request.progress_key
        if key and not key.startswith(self.progress_prefix):
            raise CommandError(f"progress_key must start with {self.progress_prefix!r}")
        reporter = _Progress(self.mesh, key) if key else None
        try:
            report = reporter.report if reporter else None
            reply = await _KINDS_RUN[self.kind](device, cmd, report)
        finally:
            if reporter is not None:
                reporter.close()
        if reply is None:
            kind, what = self.kind, type(cmd).__name__
            raise CommandError(f"{device.name} is a {kind}; it does not accept {what}")
        return reply

    async def state(self) -> p.Reply:
        device, kind = self.device, self.kind
        if kind == "arm":
            return p.ArmStateReply(await cast(Arm, device).state())
        if kind == "gripper":
            return p.GripperStateReply(await cast(Gripper, device).state())
        if kind == "base":
            return p.BaseStateReply(await cast(MobileBase, device).state())
        if kind == "appliance":
            return p.ApplianceStateReply(await cast(Appliance, device).state())
        return p.Done()  # a sensor has no state


# Running a command on a device of each kind (the kind is known: the casts are safe); None:
# not a command of that kind.
Run = Callable[[Any, p.Command, ProgressCallback | None], Awaitable[p.Reply | None]]


async def _arm(arm: Arm, cmd: p.Command, report: ProgressCallback | None) -> p.Reply | None:
    if isinstance(cmd, p.MoveJoints):
        await arm.move_joints(cmd.target, duration=cmd.duration, progress=report)
        return p.Done()
    if isinstance(cmd, p.MoveTcp):
        await arm.move_tcp(
            cmd.target,
            straight=cmd.straight,
            speed=cmd.speed,
            whole_body=cmd.whole_body,
            progress=report,
        )
        return p.Done()
    return None


async def _gripper(
    gripper: Gripper, cmd: p.Command, report: ProgressCallback | None
) -> p.Reply | None:
    if isinstance(cmd, p.OpenGripper):
        await gripper.open(cmd.width)
        return p.Done()
    if isinstance(cmd, p.CloseGripper):
        return p.Closed(await gripper.close(cmd.force))
    return None


async def _base(
    base: MobileBase, cmd: p.Command, report: ProgressCallback | None
) -> p.Reply | None:
    if isinstance(cmd, p.GoTo):
        await base.go_to(cmd.target, speed=cmd.speed, progress=report)
        return p.Done()
    if isinstance(cmd, p.SetVelocity):
        await base.set_velocity(cmd.vx, cmd.vy, cmd.wz, duration=cmd.duration)
        return p.Done()
    return None


async def _sensor(
    sensor: ObjectSensor, cmd: p.Command, report: ProgressCallback | None
) -> p.Reply | None:
    if isinstance(cmd, p.Detect):
        return p.Detections(await sensor.detect())
    return None


async def _appliance(
    appliance: Appliance, cmd: p.Command, report: ProgressCallback | None
) -> p.Reply | None:
    if isinstance(cmd, p.SetDoor):
        await appliance.set_door(cmd.open, progress=report)
        return p.Done()
    if isinstance(cmd, p.Heat):
        await appliance.heat(cmd.duration, power=cmd.power, progress=report)
        return p.Done()
    if isinstance(cmd, p.Press):
        await appliance.press(cmd.button)
        return p.Done()
    return None


_KINDS_RUN: dict[p.DeviceKind, Run] = {
    "arm": _arm,
    "gripper": _gripper,
    "base": _base,
    "sensor": _sensor,
    "appliance": _appliance,
}


class _Progress:
    """Publishes a command's progress, at most every 50 ms (and always the last value)."""

    def __init__(self, mesh: Mesh, key: str) -> None:
        self._publisher = mesh.publisher(key)
        self._last = 0.0

    def report(self, fraction: float) -> None:
        now = time.monotonic()
        if fraction >= 1.0 or now - self._last >= 0.05:
            self._last = now
            self._publisher.put(encode(p.Progress(fraction)), encoding=_ENCODING)

    def close(self) -> None:
        self._publisher.undeclare()


async def _publish_states(mesh: Mesh, devices: list[_Served], rate: float) -> None:
    publishers = [mesh.publisher(d.state_key, latest_only=True) for d in devices]
    last: dict[DeviceKey, tuple[bytes, float]] = {}
    try:
        while True:
            now = time.monotonic()
            for device, publisher in zip(devices, publishers, strict=True):
                payload = encode(await device.state())
                previous = last.get(device.key)
                if previous is None or previous[0] != payload or now - previous[1] >= 1.0:
                    publisher.put(payload, encoding=_ENCODING)
                    last[device.key] = (payload, now)
            await anyio.sleep(1.0 / rate)
    finally:
        for publisher in publishers:
            publisher.undeclare()
