"""In-process drivers: the device Protocols of :mod:`device_drivers` over a
:class:`~mujoco_sim.SimWorld`.

Each method queues one command (the Structs of :mod:`device_drivers.protocol`) and waits for
its outcome; state comes from the latest snapshot, so ``state()`` never waits for the
simulation thread. Cancelling a call halts the device before the cancellation propagates.
Every driver is :class:`~device_drivers.Pausable` (see :mod:`mujoco_sim.control`).
Use :func:`sim_devices` to get every device of a world, keyed ``(owner, device)``.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Literal

from device_drivers import (
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
from device_drivers.protocol import (
    CloseGripper,
    Detect,
    GoTo,
    Heat,
    MoveJoints,
    MoveTcp,
    OpenGripper,
    Pause,
    Press,
    Resume,
    SetDoor,
    SetVelocity,
)
from mujoco_sim._world import SimWorld

__all__ = ["SimAppliance", "SimArm", "SimBase", "SimGripper", "SimSensor", "sim_devices"]


class _SimDevice:
    def __init__(self, world: SimWorld, key: DeviceKey) -> None:
        self._world = world
        self._key = key
        self._label = world.label(key)

    @property
    def name(self) -> str:
        """The device's world-model label (``r1-arm``, ``Microwave-1``, ...)."""
        return self._label

    @property
    def key(self) -> DeviceKey:
        """(owner, device): the segments of its Zenoh keys."""
        return self._key

    async def stop(self) -> None:
        """Halt and hold; returns once the device is still (quietly if the world stopped)."""
        await self._world.halt(self._key)

    async def pause(self) -> None:
        """Hold the running motion on its path (:class:`~device_drivers.Pausable`); returns
        once the device is at rest: 0.5 s of slowing down, then the servos settle (within
        2 s of the call in all, simulated)."""
        await self._world.execute(self._key, Pause())

    async def resume(self) -> None:
        """Go on with the held motion (:class:`~device_drivers.Pausable`)."""
        await self._world.execute(self._key, Resume())

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self._label} ({self._key[0]}/{self._key[1]})>"


class SimArm(_SimDevice):
    async def state(self) -> ArmState:
        state: ArmState = self._world.state(self._key)
        return state

    async def move_joints(
        self,
        target: Mapping[str, float],
        *,
        duration: float | None = None,
        progress: ProgressCallback | None = None,
    ) -> None:
        await self._world.execute(self._key, MoveJoints(dict(target), duration), progress)

    async def move_tcp(
        self,
        target: WorldPose,
        *,
        straight: bool = True,
        speed: float = 0.2,
        whole_body: bool = False,
        progress: ProgressCallback | None = None,
    ) -> None:
        """Checks the target with full IK first (UnreachableError before anything moves)."""
        solution = await self._world.solve_ik(self._key[0], target, whole_body=whole_body)
        command = MoveTcp(target, straight, speed, whole_body, final=solution.joints)
        await self._world.execute(self._key, command, progress)


class SimGripper(_SimDevice):
    async def state(self) -> GripperState:
        state: GripperState = self._world.state(self._key)
        return state

    async def open(self, width: float | None = None) -> None:
        await self._world.execute(self._key, OpenGripper(width))

    async def close(self, force: float = 20.0) -> GripperState:
        state: GripperState = await self._world.execute(self._key, CloseGripper(force))
        return state


class SimBase(_SimDevice):
    async def state(self) -> BaseState:
        state: BaseState = self._world.state(self._key)
        return state

    async def go_to(
        self, target: Pose2D, *, speed: float = 0.5, progress: ProgressCallback | None = None
    ) -> None:
        await self._world.execute(self._key, GoTo(target, speed), progress)

    async def set_velocity(
        self, vx: float, vy: float, wz: float, *, duration: float | None = None
    ) -> None:
        """See :meth:`device_drivers.MobileBase.set_velocity`."""
        await self._world.execute(self._key, SetVelocity(vx, vy, wz, duration))


class SimSensor(_SimDevice):
    async def detect(self) -> list[Detection]:
        found: list[Detection] = await self._world.execute(self._key, Detect())
        return found


class SimAppliance(_SimDevice):
    async def state(self) -> ApplianceState:
        state: ApplianceState = self._world.state(self._key)
        return state

    async def set_door(self, open: bool, *, progress: ProgressCallback | None = None) -> None:
        await self._world.execute(self._key, SetDoor(open), progress)

    async def heat(
        self, duration: float, *, power: float = 1.0, progress: ProgressCallback | None = None
    ) -> None:
        await self._world.execute(self._key, Heat(duration, power), progress)

    async def press(self, button: Literal["start", "stop", "open"]) -> None:
        await self._world.execute(self._key, Press(button))


_CLASSES: dict[str, type[_SimDevice]] = {
    "arm": SimArm,
    "gripper": SimGripper,
    "base": SimBase,
    "sensor": SimSensor,
    "appliance": SimAppliance,
}


def sim_devices(world: SimWorld, owner: str | None = None) -> dict[DeviceKey, Device]:
    """Drivers for every device of ``world`` (or of one ``owner``), keyed (owner, device)."""
    found: dict[DeviceKey, Device] = {}
    for key, kind in world.devices.items():
        if owner is None or key[0] == owner:
            driver: Device = _CLASSES[kind](world, key)
            found[key] = driver
    return found
