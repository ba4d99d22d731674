"""Wire schema of the device endpoints ``devices/<owner>/<device>/{cmd,state}`` (msgspec
MessagePack; no I/O).

Direction by direction::

    querier -> cmd    Request{schema_version, command: Command, progress_key}
    cmd -> querier    Reply (ok) | ErrorReply (as a Zenoh *error* reply)
    state             StateMessage, published at a modest rate (latest wins)
    progress_key      Progress{fraction}, while a command with progress runs

``Command`` is a union tagged by ``cmd``; ``Reply`` and ``StateMessage`` by ``reply``; every
message is encoded with :func:`meshlink.rpc.encode`. The in-process simulation queues the very
same command Structs, so both transports mean the same. Messages only gain fields with defaults
(an older client keeps working).

Errors follow :mod:`meshlink.rpc`, like every skimesh service. A device-layer error travels with
its exception class name as ``code`` (``MotionTimeoutError``) and its attributes in ``details``;
a request the server cannot read answers the standard :data:`~meshlink.rpc.BAD_REQUEST` or
:data:`~meshlink.rpc.TOO_LARGE`, an unexpected exception :data:`~meshlink.rpc.INTERNAL`.
:func:`error_from_reply` rebuilds the exception (standard codes as :class:`CommandError` and
:class:`DeviceError`), so ``except GraspLostError`` works remotely.

:class:`ErrorReply` is :class:`meshlink.rpc.ErrorReply` with ``details``, and this is the one
change on the wire: it is now tagged (``"reply": "ErrorReply"``), so that an error is an
``ErrorReply`` to any skimesh client, as it is for the other services. Older clients ignore the
extra field; an untagged error from an older server still decodes (a lone Struct's tag is
optional), and its codes (``CommandError``, ``DeviceError``) are class names as before.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal, TypeAlias, cast

from msgspec import Meta, Struct, field

from device_drivers import _errors as errors
from device_drivers._interfaces import (
    ApplianceState,
    ArmState,
    BaseState,
    Detection,
    GripperState,
    Pose2D,
    WorldPose,
)
from meshlink import rpc
from meshlink.rpc import BAD_REQUEST, INTERNAL, TOO_LARGE, UNAVAILABLE, Decoder, WireError

__all__ = [
    "SCHEMA_VERSION",
    "ApplianceStateReply",
    "ArmStateReply",
    "BaseStateReply",
    "CloseGripper",
    "Closed",
    "Command",
    "Describe",
    "Detect",
    "Detections",
    "DeviceInfo",
    "DeviceKind",
    "Done",
    "ErrorReply",
    "GetState",
    "GoTo",
    "GripperStateReply",
    "Heat",
    "MoveJoints",
    "MoveTcp",
    "OpenGripper",
    "Pause",
    "Press",
    "Progress",
    "Reply",
    "Request",
    "Resume",
    "SetDoor",
    "SetVelocity",
    "StateMessage",
    "Stop",
    "decode_reply",
    "decode_request",
    "error_from_reply",
    "error_reply",
]

SCHEMA_VERSION = 1
DeviceKind = Literal["arm", "gripper", "base", "sensor", "appliance"]
Seconds = Annotated[float, Meta(gt=0, le=3600)]


class _Cmd(Struct, frozen=True, tag_field="cmd"):
    pass


class GetState(_Cmd, tag="state", frozen=True):
    """Any device: its state (a sensor has none: ``Done``)."""


class Stop(_Cmd, tag="stop", frozen=True):
    """Any device: halt and hold (the reply comes once it is halted)."""


class Pause(_Cmd, tag="pause", frozen=True):
    """A pausable device: bring the running motion to rest on its path and hold it (the reply
    comes once it is at rest; see :class:`device_drivers.Pausable`)."""


class Resume(_Cmd, tag="resume", frozen=True):
    """A pausable device: go on with the held motion (the reply comes at once)."""


class Describe(_Cmd, tag="describe", frozen=True):
    """Any device: what it is (``DeviceInfo``)."""


class MoveJoints(_Cmd, tag="move_joints", frozen=True):
    target: dict[str, float]
    """Joint name (``elbow`` or ``r1/elbow``) -> rad; joints left out keep their set-point."""
    duration: Seconds | None = None


class MoveTcp(_Cmd, tag="move_tcp", frozen=True):
    target: WorldPose
    straight: bool = True
    speed: Annotated[float, Meta(gt=0, le=2)] = 0.2
    whole_body: bool = False
    final: dict[str, float] = {}
    """Filled by the arm driver: the IK solution of ``target`` it checked first."""


class OpenGripper(_Cmd, tag="open", frozen=True):
    width: Annotated[float, Meta(ge=0, le=1)] | None = None


class CloseGripper(_Cmd, tag="close", frozen=True):
    force: Annotated[float, Meta(gt=0, le=1000)] = 20.0


class GoTo(_Cmd, tag="go_to", frozen=True):
    target: Pose2D
    speed: Annotated[float, Meta(gt=0, le=3)] = 0.5


class SetVelocity(_Cmd, tag="set_velocity", frozen=True):
    """A base: drive at this twist (base frame, m/s and rad/s) for ``duration`` s, or until
    stopped when None. Any finite value is accepted: the base clamps it to its own limits."""

    vx: float = 0.0
    vy: float = 0.0
    wz: float = 0.0
    duration: Seconds | None = None


class Detect(_Cmd, tag="detect", frozen=True):
    pass


class SetDoor(_Cmd, tag="set_door", frozen=True):
    open: bool


class Heat(_Cmd, tag="heat", frozen=True):
    duration: Seconds
    power: Annotated[float, Meta(gt=0, le=1)] = 1.0


class Press(_Cmd, tag="press", frozen=True):
    button: Literal["start", "stop", "open"]


Command: TypeAlias = (
    GetState
    | Stop
    | Pause
    | Resume
    | Describe
    | MoveJoints
    | MoveTcp
    | OpenGripper
    | CloseGripper
    | GoTo
    | SetVelocity
    | Detect
    | SetDoor
    | Heat
    | Press
)


class Request(Struct, frozen=True, kw_only=True):
    command: Command
    schema_version: int = SCHEMA_VERSION
    progress_key: str = ""
    """If set, the server publishes :class:`Progress` on this key while the command runs."""


class _Reply(Struct, frozen=True, tag_field="reply"):
    pass


class Done(_Reply, tag="done", frozen=True):
    pass


class ArmStateReply(_Reply, tag="arm_state", frozen=True):
    state: ArmState


class GripperStateReply(_Reply, tag="gripper_state", frozen=True):
    state: GripperState


class BaseStateReply(_Reply, tag="base_state", frozen=True):
    state: BaseState


class ApplianceStateReply(_Reply, tag="appliance_state", frozen=True):
    state: ApplianceState


class Closed(_Reply, tag="closed", frozen=True):
    state: GripperState


class Detections(_Reply, tag="detections", frozen=True):
    items: list[Detection]


class DeviceInfo(_Reply, tag="info", frozen=True):
    kind: DeviceKind
    label: str
    owner: str
    device: str


StateMessage: TypeAlias = ArmStateReply | GripperStateReply | BaseStateReply | ApplianceStateReply
Reply: TypeAlias = Done | StateMessage | Closed | Detections | DeviceInfo


class Progress(Struct, frozen=True):
    fraction: float


class ErrorReply(rpc.ErrorReply, tag="ErrorReply", frozen=True, kw_only=True):
    """An error reply: ``code`` is the exception class name (``MotionTimeoutError``) or a
    standard code of :mod:`meshlink.rpc`; ``details`` the exception's attributes."""

    details: dict[str, Any] = field(default_factory=dict)


_request: Decoder[Request] = Decoder(Request, what="request")
_reply: Decoder[Reply] = Decoder(Reply, what="reply")
_error: Decoder[ErrorReply] = Decoder(ErrorReply, what="error reply")
_DETAILS = {
    "UnreachableError": ("position_error", "orientation_error", "iterations", "solver", "joints"),
    "SimulationDivergedError": ("time", "culprit", "field"),
}


def decode_request(payload: bytes) -> Request:
    """Raises :class:`meshlink.rpc.WireError` naming the bad field (or the size)."""
    return _request.decode(payload)


def decode_reply(payload: bytes) -> Reply:
    """Raises :class:`meshlink.rpc.WireError` for a payload that is no ``Reply``."""
    return _reply.decode(payload)


def error_reply(exc: BaseException) -> ErrorReply:
    """The reply the ``cmd`` queryable answers for ``exc``: a device-layer error keeps its class
    name and attributes; a :class:`~meshlink.rpc.WireError` (a request that cannot be read) its
    standard code; anything else is :data:`~meshlink.rpc.INTERNAL` with its type in the
    message."""
    if isinstance(exc, errors.DeviceError):
        names = _DETAILS.get(type(exc).__name__, ())
        details = {n: getattr(exc, n) for n in names if hasattr(exc, n)}
        return ErrorReply(code=type(exc).__name__, message=str(exc), details=details)
    if isinstance(exc, WireError):
        return ErrorReply(code=exc.code, message=str(exc))
    return ErrorReply(code=INTERNAL, message=f"{type(exc).__name__}: {exc}")


def _device_error(reply: rpc.ErrorReply) -> errors.DeviceError:
    """The device-layer exception named by ``reply.code`` (``DeviceError`` for a name it does
    not know), with the attributes in ``details``."""
    cls = getattr(errors, reply.code, None)
    if not (isinstance(cls, type) and issubclass(cls, errors.DeviceError)):
        cls = errors.DeviceError
    exc = cls.__new__(cls)
    Exception.__init__(exc, reply.message)
    for name, value in getattr(reply, "details", {}).items():
        setattr(exc, name, value)
    return exc


_CODES: dict[str, rpc.ErrorFactory] = {
    BAD_REQUEST: rpc.from_message(errors.CommandError),
    TOO_LARGE: rpc.from_message(errors.CommandError),
    INTERNAL: rpc.from_message(errors.DeviceError),
    UNAVAILABLE: lambda r: errors.DeviceUnavailableError(f"the device server failed: {r.message}"),
}
"""The standard codes of :mod:`meshlink.rpc` as device-layer exceptions; any other code is an
exception class name (:func:`_device_error`)."""


def error_from_reply(payload: bytes) -> errors.DeviceError:
    """The exception an error reply stands for (``DeviceUnavailableError`` for a payload that
    is not an :class:`ErrorReply`, e.g. a server that stopped before answering)."""
    reply = rpc.decode_error(payload, _error)
    return cast(errors.DeviceError, rpc.error_for(reply, _CODES, fallback=_device_error))
