"""The meal skills with fake devices: the microwave agent's door and heat skills (with their
honest checks of the appliance's report), and the arm robot's pick / put_in / take_out /
serve / door skills on the meal scenario's world model."""

from __future__ import annotations

from collections.abc import AsyncIterator

import anyio
import pytest

from device_drivers import Pose2D
from skill_agent import PreconditionError
from skill_agent.protocol import StartRun
from skill_agent.runtime import SimulatedOutcomes
from skill_agent.skills import (
    HEATED,
    ApplianceCloseDoor,
    ApplianceOpenDoor,
    ArmCloseDoor,
    ArmOpenDoor,
    Heat,
    Pick,
    PutIn,
    Serve,
    TakeOut,
)
from skill_agent.skills._doors import handle_pose
from tests.unit.skill_agent.test_skills_fakes import FakeAppliance, FakeArm, Rig, rig, run
from wm_store.ontology import Prop, Rel
from wm_store.protocol import SetRelation, UnsetRelation, Value
from wm_store.reasoners import Transform

pytestmark = pytest.mark.anyio


@pytest.fixture
async def meal() -> AsyncIterator[Rig]:
    async with rig("meal") as r:
        yield r


def microwave(meal: Rig) -> FakeAppliance:
    device = FakeAppliance("Microwave-1", meal.world)
    meal.devices = {"Microwave-1": device}
    return device


async def door_open(meal: Rig) -> bool:
    value = meal.wm.get_element(meal["Microwave-1"]).properties[Prop.doorOpen]
    assert isinstance(value, bool)
    return value


async def test_the_microwave_opens_and_closes_its_door(meal: Rig) -> None:
    oven = microwave(meal)
    async with meal.agent("Microwave-1", ApplianceOpenDoor, ApplianceCloseDoor) as core:
        opened = await run(core, "open_door")
        assert opened.success, opened.message
        assert opened.params == {"appliance": meal["Microwave-1"], "door": meal["Microwave-1-door"]}
        assert await door_open(meal) and oven.door_open
        closed = await run(core, "close_door")
        assert closed.success and not await door_open(meal)


async def test_a_door_that_does_not_move_fails_the_skill(meal: Rig) -> None:
    oven = microwave(meal)
    oven.stuck = True
    async with meal.agent("Microwave-1", ApplianceOpenDoor) as core:
        result = await run(core, "open_door")
    assert not result.success and result.reason == "execution"
    assert "not open" in result.message and not await door_open(meal)


async def test_opening_an_open_door_is_refused(meal: Rig) -> None:
    microwave(meal)
    await meal.wm.update_element(meal["Microwave-1"], {Prop.doorOpen: True})
    async with meal.agent("Microwave-1", ApplianceOpenDoor) as core:
        with pytest.raises(PreconditionError, match="doorOpen"):
            await core.start(StartRun(skill="open_door"))


async def test_heat_checks_the_cavity_and_heats(meal: Rig) -> None:
    oven = microwave(meal)
    box = meal["MealBox-1"]
    await meal.wm.transact(
        [
            UnsetRelation(subject=meal["Worktop-1"], predicate=Rel.contain, object=box),
            SetRelation(subject=meal["Microwave-1"], predicate=Rel.contain, object=box),
        ]
    )
    async with meal.agent("Microwave-1", Heat) as core:
        empty = await run(core, "heat", object=box)
        assert not empty.success and "not in the appliance" in empty.message
        assert oven.calls == [], "nothing heated an empty cavity"
        oven.contents = ["MealBox-1"]
        heated = await run(core, "heat", object=box, duration=5.0)
    assert heated.success, heated.message
    assert oven.calls == ["heat"] and not oven.heating
    if HEATED:
        assert meal.wm.get_element(box).properties[HEATED] is True


async def test_stopping_heat_stops_the_heater(meal: Rig) -> None:
    oven = microwave(meal)
    oven.contents = ["MealBox-1"]
    oven.hold = anyio.Event()
    box = meal["MealBox-1"]
    await meal.wm.transact(
        [
            UnsetRelation(subject=meal["Worktop-1"], predicate=Rel.contain, object=box),
            SetRelation(subject=meal["Microwave-1"], predicate=Rel.contain, object=box),
        ]
    )
    async with meal.agent("Microwave-1", Heat) as core:
        started = await core.start(StartRun(skill="heat", params={"object": box}))
        with anyio.fail_after(5):
            await oven.started.wait()
        result = await core.stop(started.run_id)
    assert result.reason == "preempted" and oven.stops >= 1 and not oven.heating


@pytest.fixture
def friend(meal: Rig) -> Rig:
    meal.robot_devices("friend", base_pose=Pose2D(0.0, 0.0), camera="friend-camera", dof=7)
    return meal


ARM_SKILLS = (Pick, TakeOut, PutIn, Serve, ArmOpenDoor, ArmCloseDoor)


async def test_the_meal_box_goes_into_the_open_microwave_and_out_onto_the_tray(
    friend: Rig,
) -> None:
    box = friend["MealBox-1"]
    async with friend.agent("friend", *ARM_SKILLS) as core:
        picked = await run(core, "pick", object=box)
        assert picked.success, picked.message
        assert picked.params["holder"] == friend["Worktop-1"]
        assert picked.params["location"] == friend["friend-home"]
        params: dict[str, Value] = {"object": box, "appliance": friend["Microwave-1"]}
        with pytest.raises(PreconditionError, match="doorOpen"):  # the door is shut
            await core.start(StartRun(skill="put_in", params=params))
        await friend.wm.update_element(friend["Microwave-1"], {Prop.doorOpen: True})
        inside = await run(core, "put_in", object=box, appliance=friend["Microwave-1"])
        assert inside.success, inside.message
        assert friend.wm.get_parent(box).id == friend["Microwave-1"]  # type: ignore[union-attr]
        out = await run(core, "take_out", object=box)
        assert out.success, out.message
        served = await run(core, "serve", object=box)
        assert served.success, served.message
    assert friend.wm.get_parent(box).id == friend["Tray-1"]  # type: ignore[union-attr]


async def test_the_meal_box_is_taken_from_the_side(friend: Rig) -> None:
    arm = friend.devices["friend-arm"]
    assert isinstance(arm, FakeArm)
    async with friend.agent("friend", Pick) as core:
        assert (await run(core, "pick", object=friend["MealBox-1"])).success
    approach = [arm.tcp.qx, arm.tcp.qy, arm.tcp.qz, arm.tcp.qw]
    z = Transform((0, 0, 0), tuple(approach)).apply((0.0, 0.0, 1.0))  # type: ignore[arg-type]
    assert z == pytest.approx((1.0, 0.0, 0.0), abs=1e-6), "the graspPose: along +x, level"


async def test_the_arm_swings_a_door_along_its_arc(friend: Rig) -> None:
    arm = friend.devices["friend-arm"]
    assert isinstance(arm, FakeArm)
    async with friend.agent("friend", ArmOpenDoor, ArmCloseDoor) as core:
        opened = await run(core, "open_door", step=0.5)
        assert opened.success, opened.message
        assert await door_open(friend)
        assert arm.calls.count("line") >= 3 + 2  # in, three arc segments, out
        closed = await run(core, "close_door", step=0.5)
        assert closed.success and not await door_open(friend)


def test_the_handle_swings_out_of_the_front() -> None:
    door = Transform((0.0, 0.0, 0.5))  # x out of the front, y hinge -> free edge
    closed = handle_pose(door, (0.02, 0.4, 0.3), 0.0, 0.03)
    opened = handle_pose(door, (0.02, 0.4, 0.3), 1.5707963, 0.03)
    assert (closed.x, closed.y) == pytest.approx((0.01, 0.17))
    assert (opened.x, opened.y) == pytest.approx((0.37, -0.21), abs=1e-6)
    assert closed.z == opened.z == pytest.approx(0.5)


async def test_the_microwave_round_trip_in_simulated_outcome_mode(meal: Rig) -> None:
    box, oven = meal["MealBox-1"], meal["Microwave-1"]
    outcomes = SimulatedOutcomes(seed=3)
    async with (
        meal.agent("friend", *ARM_SKILLS, simulated=outcomes) as friend,
        meal.agent(
            "Microwave-1", ApplianceOpenDoor, ApplianceCloseDoor, Heat, simulated=outcomes
        ) as microwave_agent,
    ):
        steps = [
            (microwave_agent, "open_door", {}),
            (friend, "pick", {"object": box}),
            (friend, "put_in", {"object": box, "appliance": oven}),
            (microwave_agent, "close_door", {}),
            (microwave_agent, "heat", {"object": box}),
            (microwave_agent, "open_door", {}),
            (friend, "take_out", {"object": box}),
            (friend, "serve", {"object": box}),
        ]
        for core, skill, params in steps:
            result = await run(core, skill, **params)
            assert result.success, f"{skill}: {result.message}"
    assert meal.wm.get_parent(box).id == meal["Tray-1"]  # type: ignore[union-attr]
    assert await door_open(meal)
    if HEATED:
        assert meal.wm.get_element(box).properties[HEATED] is True
