"""An arm swings a door that has no motor, in the MuJoCo meal scenario with its microwave
built without a door motor (``door_motor = false``: a bar handle on the door instead): the
wheelchair arm grips the handle and pulls the door open along its arc, then pushes it shut.
The hinge of the physics and the world model's ``doorOpen`` follow; the appliance itself
refuses to move its door."""

from __future__ import annotations

from collections.abc import AsyncIterator
from typing import Any

import msgspec
import pytest

from device_drivers import Appliance, CommandError
from mujoco_sim import sim_devices
from scenario import Scenario
from skill_agent.skills import ArmCloseDoor, ArmOpenDoor
from tests.integration.test_skills_sim import Sim, run, simulation
from wm_store.ontology import Prop

pytestmark = [pytest.mark.sim, pytest.mark.anyio]

OPEN_ANGLE = 0.4  # rad: how far the wheelchair arm follows the handle from home (0.6: no)


def motorless(scenario: Scenario) -> Scenario:
    ovens = [msgspec.structs.replace(a, door_motor=False) for a in scenario.appliances]
    return msgspec.structs.replace(scenario, appliances=ovens)


@pytest.fixture
async def meal() -> AsyncIterator[Sim]:
    async with simulation("meal", edit=motorless) as sim:
        yield sim


async def hinge(sim: Sim) -> float:
    def read(model: Any, data: Any) -> float:
        return float(data.qpos[model.joint("Microwave-1/door").qposadr[0]])

    return await sim.world.call(read)


async def test_the_arm_opens_and_closes_a_door_without_a_motor(meal: Sim) -> None:
    sim = meal
    oven = sim_devices(sim.world, "Microwave-1")[("Microwave-1", "appliance")]
    assert isinstance(oven, Appliance)
    with pytest.raises(CommandError, match="no motor"):
        await oven.set_door(True)
    params = {
        "appliance": sim["Microwave-1"],
        "door": sim["Microwave-1-door"],
        "location": sim["friend-home"],
        "open_angle": OPEN_ANGLE,
    }
    async with sim.agent("friend", ArmOpenDoor, ArmCloseDoor) as friend:
        opened = await run(friend, "open_door", **params)
        assert opened.success, opened.message
        angle = await hinge(sim)
        assert abs(angle - OPEN_ANGLE) < 0.1, f"the door is at {angle:.2f} rad"
        assert sim.wm.get_element(sim["Microwave-1"]).properties[Prop.doorOpen] is True
        closed = await run(friend, "close_door", **params)
        assert closed.success, closed.message
    assert await hinge(sim) < 0.05
    assert sim.wm.get_element(sim["Microwave-1"]).properties[Prop.doorOpen] is False
