"""The person as the last sensor (FRIEND II): when no sensor sees an object, ``locate`` uses a
recent report of where a person saw it (a pose observation whose source is an ``Operator``
element, as ``skimesh operator --seen`` writes through :func:`task_agent.operator.
sighting_ops`); an old report, or one by anything but an operator, does not count."""

from __future__ import annotations

from collections.abc import AsyncIterator

import pytest

from device_drivers import Pose2D
from skill_agent import SkillFailure
from skill_agent.protocol import Progress
from skill_agent.runtime import AgentCore
from skill_agent.skills import Locate
from skill_agent.skills._locate import OPERATOR_SIGHTING_AGE
from task_agent.operator import sighting_ops
from task_agent.protocol import SeenAt
from tests.unit.skill_agent.test_skills_fakes import Rig, rig, run
from wm_store.ontology import Cls, Prop
from wm_store.protocol import AddElement, Observe, Pose

pytestmark = pytest.mark.anyio


@pytest.fixture
async def kit() -> AsyncIterator[Rig]:
    async with rig("kitting") as r:
        r.robot_devices("r1", base_pose=Pose2D(-0.6, -1.0), camera="r1-camera")
        r.world.hidden.add("Gear-2")  # no sensor sees it
        reply = await r.wm.transact([AddElement(type=Cls.Operator, label="operator", ref="$op")])
        r.ids["operator"] = reply.ids["$op"]
        yield r


@pytest.fixture
async def r1(kit: Rig) -> AsyncIterator[AgentCore]:
    async with kit.agent("r1", Locate) as core:
        yield core


async def test_a_persons_recent_sighting_stands_in_for_the_sensors(kit: Rig, r1: AgentCore) -> None:
    seen = SeenAt(element="Gear-2", position=(1.05, -1.20, 0.73), confidence=0.8)
    await kit.wm.transact(sighting_ops(kit.wm, "operator", [seen]))
    gear = kit.wm.get_element(kit["Gear-2"])
    [obs] = gear.observations[Prop.pose]
    assert obs.source == kit["operator"] and obs.confidence == pytest.approx(0.8)
    pose = gear.properties[Prop.pose]
    assert isinstance(pose, Pose) and pose.position.x == pytest.approx(1.05)
    said: list[str] = []
    r1.subscribe(lambda e: said.append(e.message) if isinstance(e, Progress) else None)
    result = await run(r1, "locate", object=kit["Gear-2"])
    assert result.success, result.message
    assert any("not seen by" in m and "where the operator" in m for m in said), said


async def test_an_old_or_non_operator_sighting_does_not_count(kit: Rig, r1: AgentCore) -> None:
    old = SeenAt(element="Gear-2", position=(1.05, -1.20, 0.73))
    ops = sighting_ops(kit.wm, "operator", [old])
    stale = [
        Observe(
            id=op.id,
            property=op.property,
            value=op.value,
            source=op.source,
            confidence=op.confidence,
            stamp=(op.stamp or 0.0) - OPERATOR_SIGHTING_AGE - 1,
        )
        if isinstance(op, Observe)
        else op
        for op in ops
    ]
    await kit.wm.transact(stale)
    assert not (await run(r1, "locate", object=kit["Gear-2"])).success
    camera = Observe(
        id=kit["Gear-2"],
        property=Prop.pose,
        value=kit.wm.get_element(kit["Gear-2"]).properties[Prop.pose],
        source=kit["r1-camera"],  # a device, not a person
    )
    await kit.wm.transact([camera])
    result = await run(r1, "locate", object=kit["Gear-2"])
    assert not result.success and "not seen" in result.message


async def test_a_sighting_of_an_unknown_element_is_refused(kit: Rig) -> None:
    with pytest.raises(SkillFailure, match="Gear-99"):
        sighting_ops(kit.wm, "operator", [SeenAt(element="Gear-99", position=(0, 0, 0))])
