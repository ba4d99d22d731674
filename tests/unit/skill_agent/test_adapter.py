"""The external-service adapter: wire structs and keys (pure), and a service skill driving the
reference partner service (docs/examples/partner_service.py) over real Zenoh on loopback."""

from __future__ import annotations

import importlib.util
import logging
import sys
import uuid
from collections.abc import AsyncIterator, Callable, Coroutine, Mapping, Sequence
from contextlib import asynccontextmanager
from pathlib import Path
from typing import Any

import anyio
import msgspec
import pytest

from meshlink import Answer, IncomingQuery, InvalidKeyError, Mesh, MeshConfig, open_mesh
from skill_agent import SkillFailure
from skill_agent.external import (
    CancelAck,
    CancelGoal,
    ExternalServiceSkill,
    Feedback,
    Goal,
    GoalAccepted,
    GoalRejected,
    Outcome,
    ServiceKeys,
    decode_service_event,
    decode_service_reply,
    decode_service_request,
    encode,
    external_skill,
)
from skill_agent.protocol import SkillDescription
from wm_store.protocol import Element, Op, Value

ROOT = Path(__file__).resolve().parents[3]


@pytest.fixture
def mesh_name() -> str:
    return f"adapter-{uuid.uuid4().hex[:10]}"


def load_example() -> Any:
    path = ROOT / "docs" / "examples" / "partner_service.py"
    spec = importlib.util.spec_from_file_location("partner_service_example", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


# --------------------------------------------------------------------------- pure


def test_messages_round_trip_with_tags() -> None:
    goal = Goal(goal_id="g1", skill="open_door", params={"door": "MicrowaveDoor-1", "speed": 0.5})
    assert decode_service_request(encode(goal)) == goal
    assert decode_service_request(encode(CancelGoal(goal_id="g1"))) == CancelGoal(goal_id="g1")
    for reply in (
        GoalAccepted(goal_id="g"),
        GoalRejected(goal_id="g", reason="busy"),
        CancelAck(goal_id="g"),
    ):
        assert decode_service_reply(encode(reply)) == reply
    for event in (
        Feedback(goal_id="g", message="m", fraction=0.5),
        Outcome(goal_id="g", success=True),
    ):
        assert decode_service_event(encode(event)) == event
    raw = msgspec.msgpack.decode(encode(goal))
    assert raw["msg"] == "Goal" and raw["schema_version"] == 1


def test_messages_tolerate_new_fields_and_reject_garbage() -> None:
    newer = msgspec.msgpack.encode({"msg": "Outcome", "goal_id": "g", "success": False, "extra": 1})
    assert decode_service_event(newer) == Outcome(goal_id="g", success=False)
    with pytest.raises(msgspec.ValidationError):
        decode_service_request(msgspec.msgpack.encode({"msg": "Launch", "goal_id": "g"}))
    with pytest.raises(msgspec.DecodeError):
        decode_service_reply(b"\xc1garbage")


def test_service_keys() -> None:
    keys = ServiceKeys("skimesh/m", "partner/door")
    assert keys.goal() == "skimesh/m/services/partner/door/goal"
    assert keys.cancel() == "skimesh/m/services/partner/door/cancel"
    assert keys.feedback("run-1") == "skimesh/m/services/partner/door/feedback/run-1"
    assert keys.alive() == "skimesh/m/services/partner/door/alive"
    with pytest.raises(InvalidKeyError):
        ServiceKeys("skimesh/m", "partner/*")
    with pytest.raises(InvalidKeyError):
        keys.feedback("a/b")


def test_external_skill_builds_a_subclass() -> None:
    desc = SkillDescription(name="open_door", doc="open it")
    cls = external_skill(desc, "partner/door", goal_timeout=2.0)
    assert issubclass(cls, ExternalServiceSkill)
    assert cls.description is desc and cls.service == "partner/door" and cls.goal_timeout == 2.0
    assert cls.__name__ == "OpenDoorService"
    with pytest.raises(InvalidKeyError):
        external_skill(desc, "bad key")


@pytest.mark.anyio
async def test_without_a_mesh_the_skill_fails_clearly() -> None:
    cls = external_skill(SkillDescription(name="open_door"), "partner/door")
    with pytest.raises(SkillFailure, match="needs a mesh session"):
        await cls().execute(FakeContext("r1", cls.description))


# --------------------------------------------------------------------------- over Zenoh


class FakeContext:
    """Just enough of SkillContext for a service skill."""

    def __init__(self, run_id: str, description: SkillDescription) -> None:
        self.run_id = run_id
        self.agent = "a1"
        self.description = description
        self.params: Mapping[str, Value] = {"door": "MicrowaveDoor-1"}
        self.simulated = False
        self.log = logging.getLogger("test")
        self.events: list[tuple[str, float]] = []
        self.first_event = anyio.Event()

    @property
    def wm(self) -> object:
        raise AssertionError("not used")

    def element(self, param: str) -> Element:
        raise AssertionError("not used")

    def device(self, param: str, kind: type[Any]) -> Any:
        raise AssertionError("not used")

    async def progress(self, message: str, *, fraction: float = -1.0, step: str = "") -> None:
        self.events.append((message, fraction))
        self.first_event.set()

    async def checkpoint(self) -> None:
        await anyio.lowlevel.checkpoint()

    async def transact(self, ops: Sequence[Op]) -> int:
        raise AssertionError("not used")


DESC = SkillDescription(name="open_door")


@asynccontextmanager
async def two_sessions(endpoint: str, mesh: str) -> AsyncIterator[tuple[Mesh, Mesh]]:
    config = MeshConfig(connect=(endpoint,), mesh=mesh)
    async with open_mesh(config) as service_side, open_mesh(config) as agent_side:
        yield service_side, agent_side


@asynccontextmanager
async def running(
    fn: Callable[[], Coroutine[Any, Any, None]],
) -> AsyncIterator[anyio.abc.TaskGroup]:
    async with anyio.create_task_group() as tg:
        tg.start_soon(fn)
        try:
            yield tg
        finally:
            tg.cancel_scope.cancel()


def partner(mesh: Mesh, service: str, steps: int) -> Callable[[], Coroutine[Any, Any, None]]:
    example = load_example()

    async def serve() -> None:
        await example.serve_partner(mesh, service, steps)

    return serve


async def wait_alive(mesh: Mesh, service: str) -> None:
    async with mesh.watch_liveliness(ServiceKeys(mesh.keys.prefix, service).alive()) as live:
        async for change in live:
            if change.alive:
                return


@pytest.mark.zenoh
@pytest.mark.anyio
async def test_skill_drives_the_partner_service(router_endpoint: str, mesh_name: str) -> None:
    async with (
        two_sessions(router_endpoint, mesh_name) as (service_side, agent_side),
        running(partner(service_side, "partner/door", 4)),
    ):
        await wait_alive(agent_side, "partner/door")
        skill = external_skill(DESC, "partner/door")(mesh=agent_side)
        ctx = FakeContext("run-ok", DESC)
        with anyio.fail_after(10):
            await skill.execute(ctx)
        assert [m for m, _ in ctx.events] == [f"step {i}/4" for i in range(1, 5)]
        assert [f for _, f in ctx.events] == [0.0, 0.25, 0.5, 0.75]


@pytest.mark.zenoh
@pytest.mark.anyio
async def test_preempt_cancels_the_goal(router_endpoint: str, mesh_name: str) -> None:
    async with (
        two_sessions(router_endpoint, mesh_name) as (service_side, agent_side),
        running(partner(service_side, "partner/door", 1000)),
    ):
        await wait_alive(agent_side, "partner/door")
        skill = external_skill(DESC, "partner/door")(mesh=agent_side)
        ctx = FakeContext("run-stop", DESC)
        acks: list[bytes] = []
        with anyio.fail_after(10):
            async with anyio.create_task_group() as tg:
                tg.start_soon(skill.execute, ctx)
                await ctx.first_event.wait()
                tg.cancel_scope.cancel()  # what a stop does to the run
            await skill.on_preempt(ctx)
            keys = ServiceKeys(agent_side.keys.prefix, "partner/door")
            acks.append(
                await agent_side.request(keys.cancel(), encode(CancelGoal(goal_id="run-stop")))
            )
        assert decode_service_reply(acks[0]) == CancelAck(goal_id="run-stop", known=False), (
            "the first cancel (on_preempt) already ended the goal"
        )


@pytest.mark.zenoh
@pytest.mark.anyio
async def test_rejection_and_lost_service_fail_the_run(
    router_endpoint: str, mesh_name: str
) -> None:
    async with two_sessions(router_endpoint, mesh_name) as (service_side, agent_side):
        keys = ServiceKeys(service_side.keys.prefix, "partner/picky")

        async def reject(query: IncomingQuery) -> list[Answer]:
            goal = decode_service_request(query.payload or b"")
            return [
                Answer(
                    keys.goal(), encode(GoalRejected(goal_id=goal.goal_id, reason="door locked"))
                )
            ]

        async with anyio.create_task_group() as tg:
            await tg.start(service_side.serve, keys.goal(), reject)
            skill = external_skill(DESC, "partner/picky")(mesh=agent_side)
            with (
                anyio.fail_after(10),
                pytest.raises(SkillFailure, match="rejected the goal: door locked"),
            ):
                await skill.execute(FakeContext("run-rej", DESC))
            tg.cancel_scope.cancel()

        # A service that accepts, then disappears (its token goes): the run fails at once.
        async def accept_then_vanish(query: IncomingQuery) -> list[Answer]:
            goal = decode_service_request(query.payload or b"")
            started = Feedback(goal_id=goal.goal_id, message="started")
            service_side.put(keys.feedback(goal.goal_id), encode(started))
            return [Answer(keys.goal(), encode(GoalAccepted(goal_id=goal.goal_id)))]

        async with anyio.create_task_group() as tg:
            await tg.start(service_side.serve, keys.goal(), accept_then_vanish)
            token = service_side.declare_token(keys.alive())
            await wait_alive(agent_side, "partner/picky")
            ctx = FakeContext("run-lost", DESC)

            async def vanish() -> None:
                await ctx.first_event.wait()  # the skill got the acceptance and follows the goal
                token.undeclare()

            tg.start_soon(vanish)
            with (
                anyio.fail_after(10),
                pytest.raises(SkillFailure, match="liveliness token disappeared"),
            ):
                await skill.execute(ctx)
            tg.cancel_scope.cancel()
