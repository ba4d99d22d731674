"""Remote device proxies: the device Protocols over Zenoh (see :mod:`device_drivers.remote`).

``RemoteArm``, ``RemoteGripper``, ``RemoteBase``, ``RemoteSensor`` and ``RemoteAppliance``
implement :class:`~device_drivers.Arm` ... exactly, so skill code runs unchanged
against them. A command returns when the device has finished it (motions use
``motion_timeout``, default 10 minutes; quick calls ``timeout``). Errors come back as the
same exception classes (``MotionTimeoutError``, ``GraspLostError``, ...); no reply at all is
:class:`DeviceUnavailableError`. Cancelling a call cancels the query and then sends ``Stop``
(shielded, at most ``timeout`` s), so the device halts as it would in-process (not for
``pause`` and ``resume``, which leave the motion to the device). With a
``progress`` callback the proxy subscribes to a per-call progress key for the call's length.
:func:`connect_devices` finds the devices of an owner (or of all owners) and builds proxies.
"""

from __future__ import annotations

import contextlib
import uuid
from collections.abc import Mapping
from typing import Literal

import anyio
import msgspec

from device_drivers import protocol as p
from device_drivers._errors import DeviceError, DeviceUnavailableError
from device_drivers._interfaces import (
    ApplianceState,
    ArmState,
    BaseState,
    Detection,
    Device,
    DeviceKey,
    GripperState,
    Pose2D,
    ProgressCallback,
    WorldPose,
)
from meshlink import Mesh, NoReplyError, RemoteError, check_name
from meshlink.rpc import WireError, encode

__all__ = [
    "RemoteAppliance",
    "RemoteArm",
    "RemoteBase",
    "RemoteDevice",
    "RemoteGripper",
    "RemoteSensor",
    "connect_devices",
]


class RemoteDevice:
    """Base of the proxies: one device ``owner``/``device`` served on ``mesh``."""

    def __init__(
        self,
        mesh: Mesh,
        owner: str,
        device: str,
        *,
        label: str = "",
        timeout: float = 5.0,
        motion_timeout: float = 600.0,
    ) -> None:
        self._mesh = mesh
        self.key: DeviceKey = (owner, device)
        self._cmd = mesh.keys.device_cmd(owner, device)
        self._label = label or f"{owner}-{device}"
        self.timeout = timeout
        self.motion_timeout = motion_timeout

    @property
    def name(self) -> str:
        return self._label

    async def stop(self) -> None:
        await self._call(p.Stop(), motion=False)

    async def pause(self) -> None:
        """Hold the running motion (:class:`~device_drivers.Pausable`); returns once the
        device is at rest."""
        await self._call(p.Pause(), motion=False)

    async def resume(self) -> None:
        """Go on with the held motion (:class:`~device_drivers.Pausable`)."""
        await self._call(p.Resume(), motion=False)

    async def _call(
        self, command: p.Command, *, motion: bool = True, progress: ProgressCallback | None = None
    ) -> p.Reply:
        timeout = self.motion_timeout if motion else self.timeout
        if progress is None:
            return await self._send(p.Request(command=command), timeout)
        prefix = self._mesh.keys.device_state(*self.key).removesuffix("state") + "progress/"
        key = prefix + uuid.uuid4().hex[:16]
        last = -1.0

        def report(payload: bytes) -> None:
            nonlocal last
            last = msgspec.msgpack.decode(payload, type=p.Progress).fraction
            progress(last)

        # through one subscriber on progress/* per device: a fresh key per command would
        # leave state behind in the router for good (meshlink._shared)
        subscription = self._mesh.subscribe(key, via=prefix + "*")
        async with subscription as updates, anyio.create_task_group() as tg:

            async def forward() -> None:
                async for sample in updates:
                    report(sample.payload)

            tg.start_soon(forward)
            try:
                reply = await self._send(p.Request(command=command, progress_key=key), timeout)
            finally:
                tg.cancel_scope.cancel()
            with contextlib.suppress(anyio.WouldBlock, anyio.EndOfStream):
                while True:  # what arrived with the reply
                    report(updates.receive_nowait().payload)
        if last < 1.0:  # the reply can overtake the last progress sample (other Zenoh path)
            progress(1.0)
        return reply

    async def _send(self, request: p.Request, timeout: float) -> p.Reply:
        try:
            payload = await self._mesh.request(self._cmd, encode(request), timeout=timeout)
        except RemoteError as exc:
            raise p.error_from_reply(exc.payload) from None
        except NoReplyError as exc:
            raise DeviceUnavailableError(f"{self._label}: {exc}") from None
        except anyio.get_cancelled_exc_class():
            if not isinstance(request.command, p.Stop | p.Pause | p.Resume):
                # the caller is being cancelled anyway; a device that is gone cannot move
                with (
                    anyio.CancelScope(shield=True),
                    anyio.move_on_after(self.timeout),
                    contextlib.suppress(DeviceError),
                ):
                    await self._send(p.Request(command=p.Stop()), self.timeout)
            raise
        try:
            return p.decode_reply(payload)
        except WireError as exc:
            raise DeviceError(f"{self._label}: unreadable reply ({exc})") from None

    async def _state(self, kind: type[msgspec.Struct]) -> object:
        reply = await self._call(p.GetState(), motion=False)
        state = getattr(reply, "state", None)
        if not isinstance(state, kind):
            raise DeviceError(f"{self._label}: expected a {kind.__name__}, got {reply!r}")
        return state

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self._label} at {self._cmd}>"


class RemoteArm(RemoteDevice):
    async def state(self) -> ArmState:
        state = await self._state(ArmState)
        assert isinstance(state, ArmState)
        return state

    async def move_joints(
        self,
        target: Mapping[str, float],
        *,
        duration: float | None = None,
        progress: ProgressCallback | None = None,
    ) -> None:
        await self._call(p.MoveJoints(dict(target), duration), progress=progress)

    async def move_tcp(
        self,
        target: WorldPose,
        *,
        straight: bool = True,
        speed: float = 0.2,
        whole_body: bool = False,
        progress: ProgressCallback | None = None,
    ) -> None:
        await self._call(p.MoveTcp(target, straight, speed, whole_body), progress=progress)


class RemoteGripper(RemoteDevice):
    async def state(self) -> GripperState:
        state = await self._state(GripperState)
        assert isinstance(state, GripperState)
        return state

    async def open(self, width: float | None = None) -> None:
        await self._call(p.OpenGripper(width))

    async def close(self, force: float = 20.0) -> GripperState:
        reply = await self._call(p.CloseGripper(force))
        if not isinstance(reply, p.Closed):
            raise DeviceError(f"{self._label}: expected the closed state, got {reply!r}")
        return reply.state


class RemoteBase(RemoteDevice):
    async def state(self) -> BaseState:
        state = await self._state(BaseState)
        assert isinstance(state, BaseState)
        return state

    async def go_to(
        self, target: Pose2D, *, speed: float = 0.5, progress: ProgressCallback | None = None
    ) -> None:
        await self._call(p.GoTo(target, speed), progress=progress)

    async def set_velocity(
        self, vx: float, vy: float, wz: float, *, duration: float | None = None
    ) -> None:
        """As in-process; an open-ended call gives up after ``motion_timeout`` s, stopping
        the base first (a base nobody waits for must not drive on)."""
        try:
            await self._call(p.SetVelocity(vx, vy, wz, duration))
        except DeviceUnavailableError:
            with anyio.move_on_after(self.timeout), contextlib.suppress(DeviceError):
                await self._send(p.Request(command=p.Stop()), self.timeout)
            raise


class RemoteSensor(RemoteDevice):
    async def detect(self) -> list[Detection]:
        reply = await self._call(p.Detect(), motion=False)
        if not isinstance(reply, p.Detections):
            raise DeviceError(f"{self._label}: expected detections, got {reply!r}")
        return reply.items


class RemoteAppliance(RemoteDevice):
    async def state(self) -> ApplianceState:
        state = await self._state(ApplianceState)
        assert isinstance(state, ApplianceState)
        return state

    async def set_door(self, open: bool, *, progress: ProgressCallback | None = None) -> None:
        await self._call(p.SetDoor(open), progress=progress)

    async def heat(
        self, duration: float, *, power: float = 1.0, progress: ProgressCallback | None = None
    ) -> None:
        await self._call(p.Heat(duration, power), progress=progress)

    async def press(self, button: Literal["start", "stop", "open"]) -> None:
        await self._call(p.Press(button))


_PROXIES: dict[str, type[RemoteDevice]] = {
    "arm": RemoteArm,
    "gripper": RemoteGripper,
    "base": RemoteBase,
    "sensor": RemoteSensor,
    "appliance": RemoteAppliance,
}


async def connect_devices(
    mesh: Mesh, owner: str = "*", *, timeout: float = 2.0
) -> dict[DeviceKey, Device]:
    """Proxies for the devices served for ``owner`` (``"*"``: every owner), keyed (owner,
    device), from one ``Describe`` query. Devices whose server does not answer within
    ``timeout`` are missing from the result."""
    if owner != "*":
        check_name(owner, "device owner")
    selector = f"{mesh.keys.prefix}/devices/{owner}/*/cmd"
    replies = await mesh.get(selector, encode(p.Request(command=p.Describe())), timeout=timeout)
    found: dict[DeviceKey, Device] = {}
    for reply in replies:
        if not reply.ok:
            continue
        info = p.decode_reply(reply.payload)
        if isinstance(info, p.DeviceInfo):
            proxy: Device = _PROXIES[info.kind](mesh, info.owner, info.device, label=info.label)
            found[(info.owner, info.device)] = proxy
    return dict(sorted(found.items()))
