"""The drawer skills in the MuJoCo simulation (meal scenario, fast mode): the wheelchair arm
pulls the kitchen cabinet's drawer out by its handle and pushes it back in. The slide joint
in the physics, the world model's ``drawerOpen`` and the drawer's pose all follow; a handle
that is not where the world model says fails the run instead of being believed."""

from __future__ import annotations

from collections.abc import AsyncIterator
from typing import Any

import msgspec
import pytest

from skill_agent import PreconditionError
from skill_agent.skills import ArmCloseDrawer, ArmOpenDrawer
from tests.integration.test_skills_sim import Sim, run, simulation
from wm_store.ontology import Prop
from wm_store.protocol import Pose, Position

pytestmark = [pytest.mark.sim, pytest.mark.anyio]

PULL = 0.20  # the skills' default, m
PARAMS = {"cabinet": "Cabinet-1", "drawer": "Drawer-1", "location": "friend-home"}


@pytest.fixture
async def meal() -> AsyncIterator[Sim]:
    async with simulation("meal") as sim:
        yield sim


async def slide(sim: Sim) -> float:
    """How far the drawer is out, m (its slide joint, ground truth)."""

    def read(model: Any, data: Any) -> float:
        return float(data.qpos[model.joint("Drawer-1/slide").qposadr[0]])

    return await sim.world.call(read)


def pose_y(sim: Sim) -> float:
    pose = sim.wm.get_element(sim["Drawer-1"]).properties[Prop.pose]
    assert isinstance(pose, Pose)
    return pose.position.y


def params(sim: Sim) -> dict[str, str]:
    return {name: sim[label] for name, label in PARAMS.items()}


async def test_the_arm_opens_and_closes_the_drawer(meal: Sim) -> None:
    sim = meal
    closed_y = pose_y(sim)
    assert await slide(sim) < 0.005
    async with sim.agent("friend", ArmOpenDrawer, ArmCloseDrawer) as friend:
        opened = await run(friend, "open_drawer", **params(sim))
        assert opened.success, opened.message
        out = await slide(sim)
        assert abs(out - PULL) < 0.02, f"the drawer slid {out:.3f} m"
        drawer = sim.wm.get_element(sim["Drawer-1"])
        assert drawer.properties[Prop.drawerOpen] is True
        assert abs(pose_y(sim) - (closed_y + PULL)) < 1e-9  # its front faces world +y
        with pytest.raises(PreconditionError, match="drawerOpen"):
            await run(friend, "open_drawer", **params(sim))  # it is open already
        shut = await run(friend, "close_drawer", **params(sim))
        assert shut.success, shut.message
        assert await slide(sim) < 0.02
        assert sim.wm.get_element(sim["Drawer-1"]).properties[Prop.drawerOpen] is False
        assert abs(pose_y(sim) - closed_y) < 1e-9


async def test_a_handle_that_is_not_there_fails_the_run(meal: Sim) -> None:
    """The world model puts the handle 5 cm above the real one: the fingers close on nothing
    and the drawer stays shut, which the run reports."""
    sim = meal
    drawer = sim.wm.get_element(sim["Drawer-1"])
    grasp = drawer.properties[Prop.graspPose]
    assert isinstance(grasp, Pose)
    p = grasp.position
    wrong = msgspec.structs.replace(grasp, position=Position(p.x, p.y, p.z + 0.05))
    await sim.wm.update_element(sim["Drawer-1"], {Prop.graspPose: wrong})
    async with sim.agent("friend", ArmOpenDrawer) as friend:
        result = await run(friend, "open_drawer", **params(sim))
    assert not result.success and "slipped out" in result.message, result.message
    assert await slide(sim) < 0.02
    assert sim.wm.get_element(sim["Drawer-1"]).properties[Prop.drawerOpen] is False
