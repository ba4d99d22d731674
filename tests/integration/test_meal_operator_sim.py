"""FRIEND II's fallback for sensing, in the MuJoCo meal scenario: neither the camera over the
worktop nor the worktop's tactile surface finds the meal box (both blinded here), so
``locate`` fails; a person then says where they see it (the operator's answer with ``seen``,
written as their observation), ``locate`` takes that, and the arm picks the real meal box
with both pads where the person said it is."""

from __future__ import annotations

from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

import anyio
import pytest

from device_drivers import Detection
from mujoco_sim import sim_devices
from skill_agent.runtime import AgentCore, SkillEntry
from skill_agent.skills import Locate, Pick
from task_agent.operator import sighting_ops
from task_agent.protocol import SeenAt
from tests.integration.test_skills_sim import Sim, run, simulation
from wm_store.ontology import Cls, Prop, Rel
from wm_store.protocol import AddElement, SizeCuboid

pytestmark = [pytest.mark.sim, pytest.mark.anyio]


class Blind:
    """An object sensor that sees nothing (a covered camera, a switched-off worktop)."""

    def __init__(self, name: str) -> None:
        self.name = name

    async def detect(self) -> list[Detection]:
        return []

    async def stop(self) -> None:
        return None


@asynccontextmanager
async def blind_friend(sim: Sim) -> AsyncIterator[AgentCore]:
    """The wheelchair's agent with its arm, gripper and base, and both room sensors blind."""
    devices: dict[str, object] = {
        sim[d.name]: d for key, d in sim_devices(sim.world).items() if key[0] == "friend"
    }
    devices.update({sim[label]: Blind(label) for label in ("Camera-1", "Worktop-1")})
    skills = {
        s.description.name: SkillEntry(s.description, s, s.__module__) for s in (Locate, Pick)
    }
    core = AgentCore(
        name="friend",
        wm=sim.wm,
        skills=skills,
        devices=devices,
        robot=sim["friend"],
        hardware={"sensor": sim["Camera-1"], "platform": sim["Worktop-1"]},
        preempt_timeout=3.0,
    )
    async with anyio.create_task_group() as tg:
        await tg.start(core.run)
        yield core
        tg.cancel_scope.cancel()


@pytest.fixture
async def meal() -> AsyncIterator[Sim]:
    async with simulation("meal") as sim:
        yield sim


async def test_a_person_says_where_the_meal_box_is_and_the_arm_picks_it(meal: Sim) -> None:
    sim = meal
    box = sim["MealBox-1"]
    await sim.wm.transact([AddElement(type=Cls.Operator, label="operator")])
    async with blind_friend(sim) as friend:
        lost = await run(friend, "locate", object=box)
        assert not lost.success and "not seen" in lost.message
        truth = sim.world.body_pose("MealBox-1")  # its bottom centre
        size = sim.wm.get_element(box).properties[Prop.size]
        assert isinstance(size, SizeCuboid)
        # what the person says: where its centre is, to within a few millimetres
        centre = (truth.x + 0.004, truth.y - 0.003, truth.z + size.z / 2)
        seen = SeenAt(element="MealBox-1", position=centre)
        await sim.wm.transact(sighting_ops(sim.wm, "operator", [seen]))
        found = await run(friend, "locate", object=box)
        assert found.success, found.message
        picked = await run(friend, "pick", object=box)
        assert picked.success, picked.message
    assert sim.wm.query_relation(sim["friend-gripper"], Rel.contain, box)
    assert "MealBox-1" in sim.world.snapshot.attached, "held by both pads in the physics"
