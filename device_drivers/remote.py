"""Serving devices over Zenoh: ``devices/<owner>/<device>/cmd`` and ``.../state``.

:func:`serve_devices` exposes any objects implementing the device Protocols (in-process
simulation drivers, or real hardware drivers) so that :mod:`device_drivers.remote_client`
proxies elsewhere can use them with the same interface:

- ``cmd`` (queryable): a :class:`~device_drivers.protocol.Request`, answered once the
  command is done (a motion replies when it has finished) with a ``Reply``, or with an
  :class:`~device_drivers.protocol.ErrorReply` as a Zenoh error reply. Each query runs in
  its own task (meshlink), so a ``Stop`` overtakes a running motion. A malformed request gets
  a ``CommandError`` reply; nothing moves.
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
from collections.abc import Mapping
from functools import partial

import anyio
import anyio.abc

from device_drivers import protocol as p
from device_drivers.control import DeviceKey
from device_drivers.errors import CommandError
from device_drivers.interfaces import Appliance, Arm, Device, Gripper, MobileBase, ObjectSensor
from meshlink import Answer, IncomingQuery, Mesh

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
    task_status: anyio.abc.TaskStatus[None] = anyio.TASK_STATUS_IGNORED,
) -> None:
    """Serve ``devices`` (keyed (owner, device)) until cancelled; reports started once every
    queryable is known to the router."""
    async with anyio.create_task_group() as tg:
        for key, device in devices.items():
            handler = partial(_handle, mesh, key, device, device_kind(device))
            await tg.start(partial(mesh.serve, mesh.keys.device_cmd(*key), handler))
        tg.start_soon(_publish_states, mesh, dict(devices), state_rate)
        task_status.started()


async def _handle(
    mesh: Mesh, key: DeviceKey, device: Device, kind: p.DeviceKind, query: IncomingQuery
) -> list[Answer]:
    cmd_key = mesh.keys.device_cmd(*key)
    try:
        request = p.decode_request(query.payload or b"")
        reply = await _dispatch(mesh, key, device, kind, request)
    except Exception as exc:
        if not isinstance(exc, CommandError):
            _log.info("%s/%s: %s", *key, exc)
        return [Answer(cmd_key, p.encode(p.error_reply(exc)), ok=False, encoding=_ENCODING)]
    return [Answer(cmd_key, p.encode(reply), encoding=_ENCODING)]


async def _dispatch(
    mesh: Mesh, key: DeviceKey, device: Device, kind: p.DeviceKind, request: p.Request
) -> p.Reply:
    cmd = request.command
    if isinstance(cmd, p.Describe):
        return p.DeviceInfo(kind, device.name, key[0], key[1])
    if isinstance(cmd, p.GetState):
        return await _state(device, kind)
    if isinstance(cmd, p.Stop):
        await device.stop()
        return p.Done()
    progress_prefix = mesh.keys.device_state(*key).removesuffix("state") + "progress/"
    if request.progress_key and not request.progress_key.startswith(progress_prefix):
        raise CommandError(f"progress_key must start with {progress_prefix!r}")
    reporter = _Progress(mesh, request.progress_key) if request.progress_key else None
    try:
        report = reporter.report if reporter else None
        if kind == "arm" and isinstance(device, Arm):
            if isinstance(cmd, p.MoveJoints):
                await device.move_joints(cmd.target, duration=cmd.duration, progress=report)
                return p.Done()
            if isinstance(cmd, p.MoveTcp):
                await device.move_tcp(
                    cmd.target,
                    straight=cmd.straight,
                    speed=cmd.speed,
                    whole_body=cmd.whole_body,
                    progress=report,
                )
                return p.Done()
        elif kind == "gripper" and isinstance(device, Gripper):
            if isinstance(cmd, p.OpenGripper):
                await device.open(cmd.width)
                return p.Done()
            if isinstance(cmd, p.CloseGripper):
                return p.Closed(await device.close(cmd.force))
        elif kind == "base" and isinstance(device, MobileBase):
            if isinstance(cmd, p.GoTo):
                await device.go_to(cmd.target, speed=cmd.speed, progress=report)
                return p.Done()
        elif kind == "sensor" and isinstance(device, ObjectSensor):
            if isinstance(cmd, p.Detect):
                return p.Detections(await device.detect())
        elif kind == "appliance" and isinstance(device, Appliance):
            if isinstance(cmd, p.SetDoor):
                await device.set_door(cmd.open, progress=report)
                return p.Done()
            if isinstance(cmd, p.Heat):
                await device.heat(cmd.duration, power=cmd.power, progress=report)
                return p.Done()
            if isinstance(cmd, p.Press):
                await device.press(cmd.button)
                return p.Done()
    finally:
        if reporter is not None:
            reporter.close()
    raise CommandError(f"{device.name} is a {kind}; it does not accept {type(cmd).__name__}")


async def _state(device: Device, kind: p.DeviceKind) -> p.Reply:
    if kind == "arm" and isinstance(device, Arm):
        return p.ArmStateReply(await device.state())
    if kind == "gripper" and isinstance(device, Gripper):
        return p.GripperStateReply(await device.state())
    if kind == "base" and isinstance(device, MobileBase):
        return p.BaseStateReply(await device.state())
    if kind == "appliance" and isinstance(device, Appliance):
        return p.ApplianceStateReply(await device.state())
    return p.Done()  # a sensor has no state


class _Progress:
    """Publishes a command's progress, at most every 50 ms (and always the last value)."""

    def __init__(self, mesh: Mesh, key: str) -> None:
        self._publisher = mesh.publisher(key)
        self._last = 0.0

    def report(self, fraction: float) -> None:
        now = time.monotonic()
        if fraction >= 1.0 or now - self._last >= 0.05:
            self._last = now
            self._publisher.put(p.encode(p.Progress(fraction)), encoding=_ENCODING)

    def close(self) -> None:
        self._publisher.undeclare()


async def _publish_states(mesh: Mesh, devices: dict[DeviceKey, Device], rate: float) -> None:
    kinds = {key: device_kind(d) for key, d in devices.items()}
    keys = [key for key, kind in kinds.items() if kind != "sensor"]
    publishers = {
        key: mesh.publisher(mesh.keys.device_state(*key), latest_only=True) for key in keys
    }
    last: dict[DeviceKey, tuple[bytes, float]] = {}
    try:
        while True:
            now = time.monotonic()
            for key in keys:
                payload = p.encode(await _state(devices[key], kinds[key]))
                previous = last.get(key)
                if previous is None or previous[0] != payload or now - previous[1] >= 1.0:
                    publishers[key].put(payload, encoding=_ENCODING)
                    last[key] = (payload, now)
            await anyio.sleep(1.0 / rate)
    finally:
        for publisher in publishers.values():
            publisher.undeclare()
