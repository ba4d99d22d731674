"""Typed device interfaces: what skills and primitives call, whatever the transport.

FRIEND II's hardware servers were reachable either in-process or remotely with the same
interface; so are these. Each interface below is implemented twice:

- in-process drivers over the MuJoCo world (direct calls, for speed and for the demo), and
- remote proxies over Zenoh (``devices/<robot>/<device>/{state,cmd}``), for a simulator or a
  real robot in another process or on another host.

Skill code depends only on these Protocols, so it does not change with the transport.

Conventions: SI units (metres, radians, seconds, newtons); poses in the world frame unless a
field says otherwise; every method that may take time is ``async`` and cancellable: cancelling
a motion stops the device safely (it holds its current position) before the cancellation
propagates. Failures raise :class:`~device_drivers.MotionError` subclasses.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Literal, Protocol, runtime_checkable

from msgspec import Struct

__all__ = [
    "Appliance",
    "ApplianceState",
    "Arm",
    "ArmState",
    "BaseState",
    "Detection",
    "Device",
    "DeviceKey",
    "Gripper",
    "GripperState",
    "MobileBase",
    "ObjectSensor",
    "Pausable",
    "Pose2D",
    "ProgressCallback",
    "Twist2D",
    "WorldPose",
]

DeviceKey = tuple[str, str]
"""(owner, device): the robot name (or appliance / fixed sensor label) and the device name."""


class Pose2D(Struct, frozen=True, forbid_unknown_fields=True):
    """A planar pose in the world frame: ``x``, ``y`` in metres, ``yaw`` in radians about +z."""

    x: float = 0.0
    y: float = 0.0
    yaw: float = 0.0


ProgressCallback = Callable[[float], None]
"""Called with the fraction of a motion done, 0..1 (cheap; runs on the event loop)."""


class WorldPose(Struct, frozen=True, array_like=True):
    """Position (m) and unit quaternion (x, y, z, w) in the world frame."""

    x: float
    y: float
    z: float
    qx: float = 0.0
    qy: float = 0.0
    qz: float = 0.0
    qw: float = 1.0


class ArmState(Struct, frozen=True, kw_only=True):
    joints: dict[str, float]
    tcp: WorldPose
    moving: bool = False


class GripperState(Struct, frozen=True, kw_only=True):
    opening: float
    """Distance between the finger pads (m)."""
    holding: str = ""
    """Name of the object held (attached), "" if none."""
    pads_in_contact: int = 0
    moving: bool = False


class Twist2D(Struct, frozen=True):
    """A planar velocity in the **base frame**: ``vx`` forward, ``vy`` to the left (m/s),
    ``wz`` yaw rate about +z (rad/s, counter-clockwise)."""

    vx: float = 0.0
    vy: float = 0.0
    wz: float = 0.0


class BaseState(Struct, frozen=True, kw_only=True):
    pose: Pose2D
    moving: bool = False
    velocity: Twist2D = Twist2D()
    """The base's measured velocity, in its own frame (see :class:`Twist2D`), rounded to
    1 mm/s and 1 mrad/s."""


class Detection(Struct, frozen=True, kw_only=True):
    """An object seen by a sensor: its simulation/world name, class, pose and confidence."""

    name: str
    type: str
    pose: WorldPose
    confidence: float = 1.0
    source: str = ""


class ApplianceState(Struct, frozen=True, kw_only=True):
    door_angle: float = 0.0
    door_open: bool = False
    heating: bool = False
    remaining: float = 0.0
    """Seconds of heating left."""
    contents: list[str] = []


@runtime_checkable
class Device(Protocol):
    """Common to every device: a name (its world-model label) and a safe stop."""

    @property
    def name(self) -> str: ...

    async def stop(self) -> None:
        """Halt now and hold the current position. Idempotent; never raises MotionError."""
        ...


@runtime_checkable
class Pausable(Protocol):
    """A device whose motion can be held and continued (see the module doc).

    ``pause()`` slows the running motion along its path to a stop and holds it there; the
    motion's own clock stops with it, so its time limits do not run out while held, and a
    command given while held waits (its motion starts at ``resume()``). It returns once the
    device is at rest (at most the driver's stated bound; the MuJoCo controllers: 0.5 s of
    slowing down, then the servos settle, within 2 s in all). ``resume()`` speeds the motion
    up again and it goes on to its target; the call that started it returns as if it had
    never been held. Both are idempotent and never raise ``MotionError``. ``stop()`` ends a
    hold as well: the held motion fails with ``MotionStoppedError`` and the device is free."""

    async def pause(self) -> None: ...

    async def resume(self) -> None: ...


@runtime_checkable
class Arm(Device, Protocol):
    async def state(self) -> ArmState: ...

    async def move_joints(
        self,
        target: Mapping[str, float],
        *,
        duration: float | None = None,
        progress: ProgressCallback | None = None,
    ) -> None:
        """Move to joint positions (rad) along a smooth trajectory; ``duration`` defaults to one
        from the joint speed limits."""
        ...

    async def move_tcp(
        self,
        target: WorldPose,
        *,
        straight: bool = True,
        speed: float = 0.2,
        whole_body: bool = False,
        progress: ProgressCallback | None = None,
    ) -> None:
        """Move the tool centre point to ``target``; ``straight``: a Cartesian line with IK at
        every control tick; ``whole_body``: the base may move too. Raises UnreachableError."""
        ...


@runtime_checkable
class Gripper(Device, Protocol):
    async def state(self) -> GripperState: ...

    async def open(self, width: float | None = None) -> None:
        """Open to ``width`` (m; default fully) and release whatever is held."""
        ...

    async def close(self, force: float = 20.0) -> GripperState:
        """Close with ``force`` (N) until the fingers stop; the object is attached only if both
        pads touch it. Returns the resulting state (``holding`` "" if nothing was grasped)."""
        ...


@runtime_checkable
class MobileBase(Device, Protocol):
    async def state(self) -> BaseState: ...

    async def go_to(
        self, target: Pose2D, *, speed: float = 0.5, progress: ProgressCallback | None = None
    ) -> None:
        """Drive to ``target`` along an obstacle-free path; raises CollisionError if the path is
        blocked."""
        ...

    async def set_velocity(
        self, vx: float, vy: float, wz: float, *, duration: float | None = None
    ) -> None:
        """Drive at the twist ``vx``, ``vy`` (m/s), ``wz`` (rad/s) in the **base frame**,
        clamped to the base's speed, yaw-rate and acceleration limits.

        Returns once the base has come to rest ``duration`` seconds (simulated) after the
        start; with ``duration=None`` it drives until :meth:`stop`, which ends it normally.
        Another ``set_velocity`` replaces the twist (the earlier call returns then).
        Cancelling the call stops the base. Raises DeviceBusyError while a ``go_to`` (or a
        whole-body arm motion) drives the base, CollisionError (the base halted first) when
        its footprint would hit an obstacle, MotionStoppedError when ``stop()`` cuts a
        ``duration`` short, CommandError for a value that is not finite."""
        ...


@runtime_checkable
class ObjectSensor(Device, Protocol):
    """A camera or a smart platform: reports objects in its field of view, with noise."""

    async def detect(self) -> list[Detection]: ...


@runtime_checkable
class Appliance(Device, Protocol):
    """A smart appliance (FRIEND II's microwave): motorised door, heating."""

    async def state(self) -> ApplianceState: ...

    async def set_door(self, open: bool, *, progress: ProgressCallback | None = None) -> None: ...

    async def heat(
        self, duration: float, *, power: float = 1.0, progress: ProgressCallback | None = None
    ) -> None:
        """Heat for ``duration`` seconds (simulated time); refuses with the door open."""
        ...

    async def press(self, button: Literal["start", "stop", "open"]) -> None: ...
