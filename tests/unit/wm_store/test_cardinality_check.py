"""Minimum cardinalities are reported by the store (``CheckCardinality`` on the read-only
endpoint, ``WmClient.check_cardinality``); maximums stay enforced on every write."""

from __future__ import annotations

from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

import anyio
import pytest

from meshlink.rpc import ErrorReply, encode
from wm_store import CardinalityError, ElementNotFoundError, InMemoryTransport, WmClient
from wm_store.ontology import Ontology
from wm_store.protocol import (
    AddElement,
    CardinalityReply,
    CardinalityViolation,
    CheckCardinality,
    Op,
    Relation,
    Transact,
    decode_reply,
)
from wm_store.server import WmService, WmStore

pytestmark = pytest.mark.anyio


@asynccontextmanager
async def connected(ontology: Ontology) -> AsyncIterator[tuple[WmService, WmClient]]:
    store = await WmStore.open(ontology)
    async with anyio.create_task_group() as tg:
        await tg.start(store.run)
        service = WmService(store)
        async with WmClient.connect(InMemoryTransport(service), ontology) as wm:
            yield service, wm
        tg.cancel_scope.cancel()


def shortfalls(reply: CardinalityReply) -> list[tuple[str, str, str, int, int]]:
    return [(v.element, v.relation, v.on_class, v.required, v.present) for v in reply.violations]


async def test_a_robot_without_its_devices_is_reported_until_it_has_them(
    ontology: Ontology,
) -> None:
    async with connected(ontology) as (_service, wm):
        clean = await wm.check_cardinality()
        assert (clean.revision, clean.checked, clean.violations) == (0, 0, [])

        robot = await wm.add_element("MobileManipulator", "r1")
        await wm.add_element("Box", "unrelated")  # no restriction on Box: never reported
        report = await wm.check_cardinality()
        assert report.revision == wm.revision and report.checked == 2
        assert shortfalls(report) == [
            (robot, "hasA", "Arm", 1, 0),
            (robot, "hasA", "MobileBase", 1, 0),
        ]
        first = report.violations[0]
        assert first.type == "MobileManipulator" and first.declared_on == "MobileManipulator"
        assert first.message.startswith(f"{robot}: a MobileManipulator should have at least 1")

        # A gripper is a device but not an arm: the qualified minimum still counts 0 arms.
        await wm.add_branch(robot, "hasA", "Gripper", "g")
        assert shortfalls(await wm.check_cardinality())[0] == (robot, "hasA", "Arm", 1, 0)

        await wm.add_branch(robot, "hasA", "MobileBase", "base")
        assert shortfalls(await wm.check_cardinality()) == [(robot, "hasA", "Arm", 1, 0)]
        # A class taught at run time counts as its parent: a UR5e arm is an Arm.
        await wm.define_class("UR5e", "Arm")
        await wm.add_branch(robot, "hasA", "UR5e", "arm")
        done = await wm.check_cardinality()
        assert done.violations == [] and done.checked == 5

        # The maximum ("exactly 1 MobileBase") is still refused on write, not reported.
        with pytest.raises(CardinalityError, match="MobileBase"):
            await wm.add_branch(robot, "hasA", "MobileBase", "second base")
        assert (await wm.check_cardinality()).violations == []


async def test_run_time_subclasses_inherit_the_minimum_and_ids_narrow_the_check(
    ontology: Ontology,
) -> None:
    async with connected(ontology) as (_service, wm):
        await wm.define_class("KitchenMicrowave", "Microwave")
        oven = await wm.add_element("KitchenMicrowave", "oven")
        other = await wm.add_element("Microwave", "other")
        await wm.add_branch(other, "hasA", "MicrowaveDoor", "door")
        report = await wm.check_cardinality()
        assert report.violations == [
            CardinalityViolation(
                element=oven,
                type="KitchenMicrowave",
                relation="hasA",
                required=1,
                present=0,
                on_class="MicrowaveDoor",
                declared_on="Microwave",
                message=f"{oven}: a KitchenMicrowave should have exactly 1 'hasA' to a "
                "MicrowaveDoor (declared on Microwave); it has 0",
            )
        ]
        narrowed = await wm.check_cardinality([other])
        assert (narrowed.checked, narrowed.violations) == (1, [])
        assert shortfalls(await wm.check_cardinality([other, oven, oven]))[0][0] == oven
        with pytest.raises(ElementNotFoundError, match="Microwave-99"):
            await wm.check_cardinality([oven, "Microwave-99"])


async def test_the_check_is_a_read_only_request_that_changes_nothing(ontology: Ontology) -> None:
    async with connected(ontology) as (service, _wm):
        ops: list[Op] = [
            AddElement(type="RobotAgent", label="agent", ref="$a"),
            AddElement(type="Microwave", relations=[Relation("$a", "controls", "$")]),
        ]
        await service.store.transact(Transact(ops=ops))
        before = service.store.snapshot()
        data, ok = await service.handle_bytes(encode(CheckCardinality()), read_only=True)
        reply = decode_reply(data)
        assert ok and isinstance(reply, CardinalityReply)
        # controls(agent, Microwave): "exactly 1 controls Robot" counts robots only.
        assert shortfalls(reply) == [
            ("Microwave-1", "hasA", "MicrowaveDoor", 1, 0),
            ("RobotAgent-1", "controls", "Robot", 1, 0),
        ]
        data, ok = await service.handle_bytes(
            encode(CheckCardinality(ids=["Nope-1"])), read_only=True
        )
        error = decode_reply(data)
        assert not ok and isinstance(error, ErrorReply) and "Nope-1" in error.message
        assert service.store.snapshot() == before
