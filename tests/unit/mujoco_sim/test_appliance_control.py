"""The microwave: motorised door, heating in simulated time, refusals and safety stops."""

from __future__ import annotations

from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import anyio
import mujoco
import pytest

from device_drivers import Appliance, CommandError, MotionStoppedError
from mujoco_sim import SimAppliance, SimWorld, WorldOptions, running_world, sim_devices
from scenario import load_scenario

pytestmark = [pytest.mark.sim, pytest.mark.anyio]

MEAL = Path(__file__).resolve().parents[3] / "configs" / "scenarios" / "meal" / "scenario.toml"
MEAL_DEPTH = next(a.size[0] for a in load_scenario(MEAL).appliances if a.label == "Microwave-1")


@pytest.fixture
async def world() -> AsyncIterator[SimWorld]:
    async with running_world(load_scenario(MEAL), WorldOptions(fast=True)) as w:
        yield w


def microwave(world: SimWorld) -> SimAppliance:
    device = sim_devices(world, "Microwave-1")[("Microwave-1", "appliance")]
    assert isinstance(device, SimAppliance) and isinstance(device, Appliance)
    assert device.name == "Microwave-1"
    return device


async def test_door_opens_and_closes(world: SimWorld) -> None:
    oven = microwave(world)
    assert not (await oven.state()).door_open
    seen: list[float] = []
    await oven.set_door(True, progress=seen.append)
    state = await oven.state()
    assert state.door_open and state.door_angle == pytest.approx(1.75, abs=0.03)
    assert seen[-1] == 1.0

    # The open door swings out of the cavity, never into it: the door panel's centre lies in
    # front of the housing's front face (the microwave faces +x in its own frame).
    def panel_forward(model: Any, data: Any) -> float:
        housing = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "Microwave-1")
        panel = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "Microwave-1/door")
        offset = data.geom_xpos[panel] - data.xpos[housing]
        forward_axis = data.xmat[housing].reshape(3, 3)[:, 0]
        return float(offset @ forward_axis)

    front_face = MEAL_DEPTH / 2
    assert await world.call(panel_forward) > front_face, "the door panel is outside the cavity"
    await oven.set_door(False)
    assert (await oven.state()).door_angle == pytest.approx(0.0, abs=0.03)


async def test_heating_is_refused_with_the_door_open(world: SimWorld) -> None:
    oven = microwave(world)
    await oven.press("open")
    with pytest.raises(CommandError, match="door is open"):
        await oven.heat(5.0)
    assert not (await oven.state()).heating


async def test_heating_counts_down_in_simulated_time(world: SimWorld) -> None:
    oven = microwave(world)
    ended: list[float] = []

    async def heat() -> None:
        await oven.heat(4.0)
        ended.append(world.snapshot.time)

    async with anyio.create_task_group() as tg:
        tg.start_soon(heat)
        # The world runs as fast as it can beside the test: when the heater starts depends on
        # the machine's load, so the count is checked from the moment it is seen heating
        # (a state and its time come from one snapshot).
        with anyio.fail_after(30):
            while not (first := await oven.state()).heating:
                await world.sleep(0.01)
        t1 = world.snapshot.time
        await world.sleep(1.0)
        state = await oven.state()
        t2 = world.snapshot.time
        assert state.heating
        assert first.remaining - state.remaining == pytest.approx(t2 - t1, abs=0.05)
    began = t1 - (4.0 - first.remaining)
    # at least the 4 s asked for; a loaded machine may read the clock a little later
    assert 4.0 - 0.05 <= ended[0] - began <= 5.0
    assert not (await oven.state()).heating


async def test_opening_the_door_stops_the_heater(world: SimWorld) -> None:
    oven = microwave(world)
    outcome: list[BaseException] = []

    async def heat() -> None:
        try:
            await oven.heat(10.0)
        except MotionStoppedError as exc:
            outcome.append(exc)

    async with anyio.create_task_group() as tg:
        tg.start_soon(heat)
        await world.sleep(0.5)
        await oven.set_door(True)
    assert outcome and "door was opened" in str(outcome[0])
    assert not (await oven.state()).heating


async def test_buttons_start_and_stop(world: SimWorld) -> None:
    oven = microwave(world)
    await oven.press("start")
    await world.sleep(0.2)
    assert (await oven.state()).remaining == pytest.approx(29.8, abs=0.15)
    await oven.press("stop")
    assert not (await oven.state()).heating


async def test_contents_are_what_is_inside(world: SimWorld) -> None:
    oven = microwave(world)
    assert (await oven.state()).contents == []
    inside = world.body_pose("Microwave-1")

    def put_meal_inside(model: Any, data: Any) -> None:
        adr = model.joint("MealBox-1").qposadr[0]
        data.qpos[adr : adr + 3] = [inside.x, inside.y, inside.z + 0.03]

    await world.call(put_meal_inside)
    await world.sleep(0.3)
    assert (await oven.state()).contents == ["MealBox-1"]
