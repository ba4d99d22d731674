"""The device ``cmd`` queryable over real Zenoh on loopback (an in-process router), served for a
fake gripper: hostile payloads (invalid UTF-8, deep nesting, unknown tags, empty, huge) and
random ones all answer a decodable ErrorReply or a valid reply, with the standard codes; the
proxies turn those codes into the device-layer exceptions callers catch today."""

from __future__ import annotations

import uuid
from collections.abc import AsyncIterator, Iterator
from contextlib import asynccontextmanager
from functools import partial

import anyio
import msgspec
import pytest
from anyio.from_thread import BlockingPortal, start_blocking_portal
from hypothesis import HealthCheck, given, settings

from device_drivers import (
    CommandError,
    DeviceError,
    GraspLostError,
    GripperState,
)
from device_drivers import protocol as p
from device_drivers.remote import RemoteGripper, serve_devices
from meshlink import Mesh, MeshConfig, open_mesh
from meshlink.rpc import BAD_REQUEST, INTERNAL, TOO_LARGE, Decoder, ErrorReply, encode
from meshlink.testing import check_reply, fuzz_queryable, hostile_payloads, payloads

pytestmark = pytest.mark.zenoh

LIMIT = 4096
REPLIES: Decoder[p.Reply | p.ErrorReply] = Decoder(p.Reply | p.ErrorReply, what="reply")
SAMPLES = [
    encode(p.Request(command=p.GetState())),
    encode(p.Request(command=p.Describe())),
    encode(p.Request(command=p.OpenGripper(0.05), progress_key="x")),
]


class FakeGripper:
    """A gripper in memory; ``close`` fails on purpose with the forces 13 and 14."""

    def __init__(self) -> None:
        self.opening = 0.0

    @property
    def name(self) -> str:
        return "fake-gripper"

    async def stop(self) -> None:
        pass

    async def state(self) -> GripperState:
        return GripperState(opening=self.opening)

    async def open(self, width: float | None = None) -> None:
        self.opening = 0.085 if width is None else width

    async def close(self, force: float = 20.0) -> GripperState:
        if force == 13.0:
            raise RuntimeError("wires crossed")
        if force == 14.0:
            raise GraspLostError("fake-gripper lost Gear-1")
        self.opening = 0.0
        return await self.state()


class Served:
    def __init__(self, portal: BlockingPortal, mesh: Mesh, gripper: FakeGripper) -> None:
        self.portal, self.mesh, self.gripper = portal, mesh, gripper
        self.key = mesh.keys.device_cmd("r1", "gripper")


@asynccontextmanager
async def serving(config: MeshConfig, gripper: FakeGripper) -> AsyncIterator[Mesh]:
    async with open_mesh(config) as mesh, anyio.create_task_group() as tg:
        devices = {("r1", "gripper"): gripper}
        await tg.start(partial(serve_devices, mesh, devices, max_request_bytes=LIMIT))
        yield mesh
        tg.cancel_scope.cancel()


@pytest.fixture(scope="module")
def served(module_router: str) -> Iterator[Served]:
    """One gripper served on one mesh for the module, driven from the test's thread."""
    config = MeshConfig(mode="client", connect=(module_router,), mesh=f"test-{uuid.uuid4().hex}")
    gripper = FakeGripper()
    with (
        start_blocking_portal("asyncio") as portal,
        portal.wrap_async_context_manager(serving(config, gripper)) as mesh,
    ):
        yield Served(portal, mesh, gripper)


def ask(served: Served, payload: bytes) -> object:
    """The one reply to ``payload``, checked (an ErrorReply when not ok) and decoded."""
    answers = served.portal.call(lambda: served.mesh.get(served.key, payload, timeout=10.0))
    assert len(answers) == 1
    return check_reply(answers[0].payload, answers[0].ok, REPLIES)


def code_of(served: Served, payload: bytes) -> str:
    reply = ask(served, payload)
    assert isinstance(reply, ErrorReply), reply
    return reply.code


def test_hostile_payloads_answer_standard_codes(served: Served) -> None:
    count = served.portal.call(
        lambda: fuzz_queryable(
            served.mesh, served.key, REPLIES, hostile_payloads(SAMPLES, huge=LIMIT + 1)
        )
    )
    assert count >= len(hostile_payloads(huge=0))
    bad_utf8 = msgspec.msgpack.encode({"command": {"cmd": "open"}, "progress_key": "\x00"})
    bad_utf8 = bad_utf8.replace(b"\xa1\x00", b"\xa2\xff\xfe")
    deep = b"\x81\xa7command" + b"\x91" * 1000 + b"\xc0"
    cases = {
        b"": BAD_REQUEST,
        bad_utf8: BAD_REQUEST,
        deep: BAD_REQUEST,
        msgspec.msgpack.encode({"command": {"cmd": "fly"}}): BAD_REQUEST,
        b"\x00" * (LIMIT + 1): TOO_LARGE,
    }
    assert {code_of(served, payload) for payload in cases} == set(cases.values())
    for payload, code in cases.items():
        assert code_of(served, payload) == code


def test_valid_requests_still_answer(served: Served) -> None:
    assert ask(served, SAMPLES[0]) == p.GripperStateReply(
        GripperState(opening=served.gripper.opening)
    )
    info = ask(served, SAMPLES[1])
    assert info == p.DeviceInfo("gripper", "fake-gripper", "r1", "gripper")


@settings(
    max_examples=200,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(data=payloads(SAMPLES))
def test_fuzz_every_reply_is_an_error_reply_or_a_valid_reply(served: Served, data: bytes) -> None:
    ask(served, data)


def test_the_proxy_raises_what_callers_catch(served: Served) -> None:
    """Standard codes become CommandError / DeviceError; a device error keeps its class."""
    proxy = RemoteGripper(served.mesh, "r1", "gripper")
    internal = encode(p.Request(command=p.CloseGripper(13.0)))
    assert code_of(served, internal) == INTERNAL

    async def call(force: float) -> None:
        await proxy.close(force)

    with pytest.raises(DeviceError, match="RuntimeError: wires crossed") as info:
        served.portal.call(call, 13.0)
    assert type(info.value) is DeviceError
    with pytest.raises(GraspLostError, match="lost Gear-1"):
        served.portal.call(call, 14.0)
    with pytest.raises(CommandError, match="malformed request"):  # width > 1: bad_request
        served.portal.call(proxy.open, 5.0)
    bad = served.portal.call(lambda: served.mesh.get(served.key, b"\xc1", timeout=10.0))
    assert isinstance(p.error_from_reply(bad[0].payload), CommandError)


def test_a_device_that_is_not_pausable_refuses_pause_and_resume(served: Served) -> None:
    proxy = RemoteGripper(served.mesh, "r1", "gripper")
    for call in (proxy.pause, proxy.resume):
        with pytest.raises(CommandError, match="fake-gripper cannot be paused"):
            served.portal.call(call)
