"""Room for robots at run time: the navigate skill reserves its goal in the world model with a
compare-and-set before the base moves, waits while the goal is full, gives back its start once
it has arrived and its goal when it is stopped far from it."""

from __future__ import annotations

from collections.abc import AsyncIterator

import anyio
import pytest

from device_drivers import Pose2D
from skill_agent import SkillFailure
from skill_agent.protocol import Progress, StartRun
from skill_agent.runtime import AgentCore
from skill_agent.skills import Navigate
from skill_agent.skills._spots import holders, release, reserve, reserved_by
from tests.unit.skill_agent.test_skills_fakes import FakeBase, Rig, rig, run
from wm_store.ontology import Prop, Rel
from wm_store.protocol import UpdateElement

pytestmark = pytest.mark.anyio


@pytest.fixture
async def kit() -> AsyncIterator[Rig]:
    async with rig("kitting") as r:
        yield r


def reserved(kit: Rig, place: str) -> list[str]:
    return reserved_by(kit.wm.get_element(kit[place]))


async def test_two_robots_reserving_the_last_place_at_once_do_not_both_win(kit: Rig) -> None:
    station, r1, r2 = kit["Station-1"], kit["r1"], kit["r2"]
    won: list[str] = []
    one_won = anyio.Event()

    async def take(robot: str) -> None:
        await reserve(kit.wm, robot, station, wait=10.0)
        won.append(robot)
        one_won.set()

    async with anyio.create_task_group() as tg:
        tg.start_soon(take, r1)
        tg.start_soon(take, r2)
        with anyio.fail_after(5):
            await one_won.wait()
        first = won[0]
        assert reserved(kit, "Station-1") == [first]  # one holder, the other waits
        second = r2 if first == r1 else r1
        assert holders(kit.wm, station) == {first}
        assert await release(kit.wm, first) == [station]
    assert won == [first, second]
    assert reserved(kit, "Station-1") == [second]


async def test_a_full_place_fails_after_the_wait_naming_who_is_there(kit: Rig) -> None:
    station = kit["Station-1"]
    # r2 stands there from the start (at, no reservation): it takes the room too
    await kit.wm.unset_relation(kit["r2"], Rel.at, kit["r2-home"])
    await kit.wm.set_relation(kit["r2"], Rel.at, station)
    with pytest.raises(
        SkillFailure,
        match=r"no room at Station-1 .* r2 \(MobileManipulator-2\) is there \(waited 0.1 s\)",
    ):
        await reserve(kit.wm, kit["r1"], station, wait=0.1)
    assert reserved(kit, "Station-1") == []
    # room for two: r1 gets its place beside r2
    await kit.wm.transact([UpdateElement(id=station, properties={Prop.robotCapacity: 2})])
    assert await reserve(kit.wm, kit["r1"], station, wait=0.1)
    assert not await reserve(kit.wm, kit["r1"], station, wait=0.1)  # it holds one already
    # a place for no robot: refused at once, without waiting
    await kit.wm.transact([UpdateElement(id=station, properties={Prop.robotCapacity: 0})])
    with pytest.raises(SkillFailure, match="Station-1 is no place for a robot"):
        await reserve(kit.wm, kit["r2"], station, wait=60.0)
    # a shelf is a surface: robots work beside it
    with pytest.raises(SkillFailure, match="Shelf-1 is no place for a robot"):
        await reserve(kit.wm, kit["r2"], kit["Shelf-1"], wait=60.0)


def base_of(kit: Rig, robot: str) -> FakeBase:
    base = kit.devices[f"{robot}-base"]
    assert isinstance(base, FakeBase)
    return base


async def test_navigate_waits_for_room_and_gives_back_its_start(kit: Rig) -> None:
    kit.robot_devices("r1", base_pose=Pose2D(-0.6, -1.0), camera="r1-camera")
    base1 = base_of(kit, "r1")
    async with kit.agent("r1", Navigate) as r1:
        kit.robot_devices("r2", base_pose=Pose2D(-0.6, 1.0), camera="r2-camera")
        async with kit.agent("r2", Navigate) as r2:
            await waits_for_room(kit, r1, r2, base1)


async def waits_for_room(kit: Rig, r1: AgentCore, r2: AgentCore, base1: FakeBase) -> None:
    station = kit["Station-1"]
    assert (await run(r2, "navigate", goal=station)).success
    assert reserved(kit, "Station-1") == [kit["r2"]]
    waiting = anyio.Event()
    r1.subscribe(
        lambda e: (
            waiting.set()
            if isinstance(e, Progress) and e.message.startswith("waiting for room at Station-1")
            else None
        )
    )
    started = await r1.start(StartRun(skill="navigate", params={"goal": station}))
    with anyio.fail_after(5):
        await waiting.wait()
    assert base1.calls == []  # it waits instead of driving into r2
    result = await run(r2, "navigate", goal=kit["r2-home"])
    assert result.success, result.message
    done = await r1.wait(started.run_id)
    assert done.success, done.message
    assert base1.calls == ["go_to"]
    assert reserved(kit, "Station-1") == [kit["r1"]]
    assert reserved(kit, "r2-home") == [kit["r2"]]
    # r1 moves on: Station-1 is given back once it has arrived
    assert (await run(r1, "navigate", goal=kit["Station-2"])).success
    assert reserved(kit, "Station-1") == [] and reserved(kit, "Station-2") == [kit["r1"]]


async def test_a_stopped_drive_gives_back_the_goal_it_did_not_reach(kit: Rig) -> None:
    kit.robot_devices("r1", base_pose=Pose2D(-0.6, -1.0), camera="r1-camera")
    base = base_of(kit, "r1")
    async with kit.agent("r1", Navigate) as r1:
        base.hold = anyio.Event()
        started = await r1.start(StartRun(skill="navigate", params={"goal": kit["Station-1"]}))
        with anyio.fail_after(5):
            await base.started.wait()
        assert reserved(kit, "Station-1") == [kit["r1"]]  # reserved before the base moved
        result = await r1.stop(started.run_id)
        assert result.reason == "preempted"
        assert reserved(kit, "Station-1") == []
