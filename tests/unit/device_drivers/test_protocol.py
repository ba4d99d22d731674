"""The device wire schema: round trips, tolerant decoding, and errors that keep their class."""

from __future__ import annotations

import importlib

import msgspec
import pytest

import device_drivers as errors
from device_drivers import ArmState, BaseState, GripperState, Pose2D, Twist2D, WorldPose
from device_drivers import protocol as p
from meshlink.rpc import BAD_REQUEST, INTERNAL, TOO_LARGE, ErrorReply, WireError, encode


@pytest.mark.parametrize(
    "command",
    [
        p.GetState(),
        p.Stop(),
        p.Pause(),
        p.Resume(),
        p.Describe(),
        p.MoveJoints({"elbow": 1.0}, duration=2.0),
        p.MoveTcp(WorldPose(1, 2, 3), straight=False, speed=0.1, whole_body=True),
        p.OpenGripper(0.05),
        p.CloseGripper(15.0),
        p.GoTo(Pose2D(1.0, 2.0, 0.5), speed=0.3),
        p.SetVelocity(0.2, -0.1, 0.5, duration=2.0),
        p.SetVelocity(wz=0.3),
        p.Detect(),
        p.SetDoor(True),
        p.Heat(30.0, power=0.5),
        p.Press("start"),
    ],
)
def test_requests_round_trip(command: p.Command) -> None:
    request = p.Request(command=command, progress_key="x")
    assert p.decode_request(encode(request)) == request


def test_replies_round_trip() -> None:
    arm = p.ArmStateReply(ArmState(joints={"elbow": 1.0}, tcp=WorldPose(0, 0, 1)))
    closed = p.Closed(GripperState(opening=0.05, holding="Gear-1", pads_in_contact=2))
    for reply in (arm, closed, p.Done(), p.DeviceInfo("arm", "r1-arm", "r1", "arm")):
        assert p.decode_reply(encode(reply)) == reply


def test_the_base_velocity_is_a_field_with_a_default() -> None:
    moving = p.BaseStateReply(BaseState(pose=Pose2D(1.0), velocity=Twist2D(0.2, 0.0, -0.1)))
    assert p.decode_reply(encode(moving)) == moving
    old = {"reply": "base_state", "state": {"pose": {"x": 1.0, "y": 0.0, "yaw": 0.0}}}
    reply = p.decode_reply(msgspec.msgpack.encode(old))  # from a server before the field
    assert isinstance(reply, p.BaseStateReply) and reply.state.velocity == Twist2D()
    with pytest.raises(WireError):  # the duration stays bounded on the wire
        p.decode_request(
            msgspec.msgpack.encode({"command": {"cmd": "set_velocity", "duration": 0.0}})
        )


def test_unknown_fields_are_tolerated_on_the_wire() -> None:
    raw = msgspec.msgpack.encode({"command": {"cmd": "stop", "future": 1}, "extra": True})
    assert p.decode_request(raw).command == p.Stop()


def test_bad_requests_become_command_errors() -> None:
    with pytest.raises(WireError) as info:
        p.decode_request(msgspec.msgpack.encode({"command": {"cmd": "fly"}}))
    reply = p.error_reply(info.value)
    assert reply.code == BAD_REQUEST and "malformed request" in reply.message
    rebuilt = p.error_from_reply(encode(reply))
    assert isinstance(rebuilt, errors.CommandError)
    too_large = p.error_from_reply(encode(p.ErrorReply(code=TOO_LARGE, message="big")))
    assert type(too_large) is errors.CommandError and str(too_large) == "big"


@pytest.mark.parametrize(
    "exc",
    [
        errors.MotionTimeoutError("r1-arm: elbow is 0.1 rad away"),
        errors.GraspLostError("r1-gripper lost Gear-1"),
        errors.CollisionError("blocked by Shelf-1"),
        errors.DeviceBusyError("busy"),
        errors.MotionStoppedError("stopped"),
    ],
)
def test_device_errors_keep_their_class(exc: errors.DeviceError) -> None:
    rebuilt = p.error_from_reply(encode(p.error_reply(exc)))
    assert type(rebuilt) is type(exc)
    assert str(rebuilt) == str(exc)


def test_unreachable_error_keeps_its_attributes() -> None:
    exc = errors.UnreachableError(
        position_error=0.2,
        orientation_error=0.1,
        iterations=30,
        solver="placo",
        joints={"r1/elbow": 1.0},
        whole_body=False,
    )
    rebuilt = p.error_from_reply(encode(p.error_reply(exc)))
    assert isinstance(rebuilt, errors.UnreachableError)
    assert rebuilt.position_error == 0.2 and rebuilt.joints == {"r1/elbow": 1.0}
    assert str(rebuilt) == str(exc)


def test_foreign_errors_and_plain_text() -> None:
    reply = p.error_reply(RuntimeError("boom"))
    assert reply.code == INTERNAL and "RuntimeError: boom" in reply.message
    rebuilt = p.error_from_reply(encode(reply))
    assert type(rebuilt) is errors.DeviceError and "RuntimeError: boom" in str(rebuilt)
    text = p.error_from_reply(b"Cancelled: the server stopped before answering")
    assert isinstance(text, errors.DeviceUnavailableError)
    assert str(text) == "the device server failed: Cancelled: the server stopped before answering"
    unknown = p.error_from_reply(encode(p.ErrorReply(code="NoSuchError", message="?")))
    assert type(unknown) is errors.DeviceError


def test_the_error_reply_is_meshlinks_tagged_with_details() -> None:
    """The one wire change: the device ErrorReply carries the tag of every service's error,
    so any client reads it; an untagged error of an older server still decodes."""
    exc = errors.GraspLostError("r1-gripper lost Gear-1")
    raw = msgspec.msgpack.decode(encode(p.error_reply(exc)))
    assert raw["reply"] == "ErrorReply" and raw["code"] == "GraspLostError"
    generic = msgspec.msgpack.decode(encode(p.error_reply(exc)), type=ErrorReply)
    assert generic.code == "GraspLostError" and generic.message == str(exc)
    old = {"code": "MotionTimeoutError", "message": "late", "details": {}, "schema_version": 1}
    rebuilt = p.error_from_reply(msgspec.msgpack.encode(old))
    assert type(rebuilt) is errors.MotionTimeoutError and str(rebuilt) == "late"


NEW_MODULES = [
    "device_drivers.protocol",
    "device_drivers.remote",
]


@pytest.mark.parametrize("name", NEW_MODULES)
def test_public_names_exist(name: str) -> None:
    module = importlib.import_module(name)
    assert [n for n in module.__all__ if not hasattr(module, n)] == []
