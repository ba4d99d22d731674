"""The kitting skills (navigate, locate, pick, place, place_on) through the agent core, on the
kitting scenario's world model, with fake devices: predictions committed, honest failures (not
seen, grasp failed, dropped on the way, unreachable, a part that lands in a box instead of on
the shelf), stops that halt the hardware, the same skills in simulated-outcome mode, and a
planner that uses place_on for a part wanted on a shelf."""

from __future__ import annotations

from collections.abc import AsyncIterator

import anyio
import msgspec
import pytest

from device_drivers import Pose2D, UnreachableError
from skill_agent import ParameterTypeError, PreconditionError
from skill_agent.conditions import describe, symbolic
from skill_agent.parameters import check_description
from skill_agent.protocol import Progress, RunEvent, StartRun
from skill_agent.runtime import AgentCore, SimulatedOutcomes, load_config
from skill_agent.skills import Locate, Navigate, Pick, Place, PlaceOn
from skill_agent.skills._sensing import move_ops
from task_agent import parse_goal
from task_agent.discovery import agents_from_view
from task_agent.planning import Planner
from tests.unit.skill_agent.scenario_planning import CONFIGS, register_agent
from tests.unit.skill_agent.test_skills_fakes import FakeArm, FakeGripper, Rig, rig, run
from wm_store import WmClient
from wm_store.ontology import Ontology, Prop, Rel
from wm_store.protocol import Pose, Value

pytestmark = pytest.mark.anyio

SKILLS = (Navigate, Locate, Pick, Place, PlaceOn)
SHELF_TOP = 0.70  # Shelf-1: 0.6 x 1.2 m, 0.70 m high, its front edge at x = 0.93


@pytest.fixture
async def kit() -> AsyncIterator[Rig]:
    async with rig("kitting") as r:
        r.robot_devices("r1", base_pose=Pose2D(-0.6, -1.0), camera="r1-camera")
        yield r


@pytest.fixture
async def r1(kit: Rig) -> AsyncIterator[AgentCore]:
    async with kit.agent("r1", *SKILLS) as core:
        yield core


async def at_station(core: AgentCore, kit: Rig) -> None:
    result = await run(core, "navigate", goal=kit["Station-1"])
    assert result.success, result.message


def arm(kit: Rig) -> FakeArm:
    device = kit.devices["r1-arm"]
    assert isinstance(device, FakeArm)
    return device


def gripper(kit: Rig) -> FakeGripper:
    device = kit.devices["r1-gripper"]
    assert isinstance(device, FakeGripper)
    return device


async def test_navigate_moves_the_robot_and_what_it_carries(kit: Rig, r1: AgentCore) -> None:
    kit_box = kit.wm.spatial.world_pose(kit["KitBox-1"]).position
    result = await run(r1, "navigate", goal=kit["Station-1"])
    assert result.success, result.message
    assert result.params["start"] == kit["r1-home"], "start inferred from at(robot, start)"
    assert kit.wm.query_relation(kit["r1"], Rel.at, kit["Station-1"])
    assert not kit.wm.query_relation(kit["r1"], Rel.at, kit["r1-home"])
    robot = kit.wm.spatial.world_pose(kit["r1"]).position
    assert (robot.x, robot.y) == pytest.approx((0.55, -1.0))
    moved = kit.wm.spatial.world_pose(kit["KitBox-1"]).position
    assert moved.x - kit_box.x == pytest.approx(1.15) and moved.y == pytest.approx(kit_box.y)
    observed = kit.wm.get_element(kit["r1"]).observations[Prop.pose]
    assert [o.source for o in observed] == [kit["r1-base"]]


async def test_navigate_refuses_a_goal_where_the_robot_is(kit: Rig, r1: AgentCore) -> None:
    from skill_agent import PreconditionError

    with pytest.raises(PreconditionError, match="at"):
        await r1.start(StartRun(skill="navigate", params={"goal": kit["r1-home"]}))


async def test_locate_observes_the_pose_with_source_and_confidence(kit: Rig, r1: AgentCore) -> None:
    kit.world.objects["Gear-2"] = kit.world.objects["Gear-2"].__class__(1.07, -1.25, 0.72)
    result = await run(r1, "locate", object=kit["Gear-2"])
    assert result.success, result.message
    gear = kit.wm.get_element(kit["Gear-2"])
    pose = gear.properties[Prop.pose]
    assert isinstance(pose, Pose) and pose.position.x == pytest.approx(1.07)
    [obs] = gear.observations[Prop.pose]
    assert obs.source == kit["r1-camera"] and obs.confidence == pytest.approx(0.9)
    assert isinstance(gear.properties[Prop.seenAt], float)


async def test_locate_fails_honestly_when_nothing_sees_the_object(kit: Rig, r1: AgentCore) -> None:
    kit.world.hidden.add("Gear-2")
    before = kit.wm.get_element(kit["Gear-2"])
    result = await run(r1, "locate", object=kit["Gear-2"])
    assert not result.success and result.reason == "execution"
    assert "not seen" in result.message
    assert kit.wm.get_element(kit["Gear-2"]).rev == before.rev  # nothing written


async def test_locate_moves_an_object_found_elsewhere(kit: Rig, r1: AgentCore) -> None:
    box = kit.wm.spatial.world_pose(kit["PartBox-2"]).position
    kit.world.objects["Gear-2"] = kit.world.objects["Gear-2"].__class__(box.x, box.y, box.z)
    result = await run(r1, "locate", object=kit["Gear-2"])
    assert result.success, result.message
    parent = kit.wm.get_parent(kit["Gear-2"])
    assert parent is not None and parent.id == kit["PartBox-2"]


async def test_pick_then_place_commits_both_predictions(kit: Rig, r1: AgentCore) -> None:
    await at_station(r1, kit)
    picked = await run(r1, "pick", object=kit["Gear-1"])
    assert picked.success, picked.message
    assert (
        picked.params["holder"] == kit["PartBox-1"]
        and picked.params["location"] == kit["Station-1"]
    )
    assert kit.wm.get_parent(kit["Gear-1"]).id == kit["r1-gripper"]  # type: ignore[union-attr]
    assert gripper(kit).holding == "Gear-1"
    assert arm(kit).calls[:3] == ["joints", "free", "line"]  # home, pre-grasp, straight in
    placed = await run(r1, "place", object=kit["Gear-1"], container=kit["KitBox-1"])
    assert placed.success, placed.message
    assert kit.wm.get_parent(kit["Gear-1"]).id == kit["KitBox-1"]  # type: ignore[union-attr]
    assert kit.wm.spatial.is_inside(kit["Gear-1"], kit["KitBox-1"])
    assert gripper(kit).holding == ""


async def test_a_second_part_goes_beside_the_first(kit: Rig, r1: AgentCore) -> None:
    await at_station(r1, kit)
    for part in ("Gear-1", "Gear-2"):
        assert (await run(r1, "pick", object=kit[part])).success
        assert (await run(r1, "place", object=kit[part], container=kit["KitBox-1"])).success
    a = kit.wm.spatial.world_pose(kit["Gear-1"]).position
    b = kit.wm.spatial.world_pose(kit["Gear-2"]).position
    assert ((a.x - b.x) ** 2 + (a.y - b.y) ** 2) ** 0.5 > 0.056  # no stacking


async def test_a_failed_grasp_fails_the_pick_and_opens_the_gripper(kit: Rig, r1: AgentCore) -> None:
    await at_station(r1, kit)
    gripper(kit).slip = True
    result = await run(r1, "pick", object=kit["Gear-1"])
    assert not result.success and result.reason == "execution"
    assert result.message.startswith("grasp failed: r1-gripper holds nothing, not Gear-1")
    assert kit.wm.get_parent(kit["Gear-1"]).id == kit["PartBox-1"]  # type: ignore[union-attr]
    assert gripper(kit).calls[-1] == "open"


async def test_an_unreachable_grasp_fails_before_closing(kit: Rig, r1: AgentCore) -> None:
    await at_station(r1, kit)
    arm(kit).fail_next["free"] = UnreachableError(
        position_error=0.1,
        orientation_error=0.0,
        iterations=9,
        solver="fake",
        joints={},
        whole_body=False,
    )
    result = await run(r1, "pick", object=kit["Gear-1"])
    assert not result.success and "UnreachableError" in result.message
    assert "close" not in gripper(kit).calls


async def test_pick_needs_the_robot_at_the_objects_location(kit: Rig, r1: AgentCore) -> None:
    from skill_agent import PreconditionError

    params: dict[str, Value] = {
        "object": kit["Gear-1"],
        "holder": kit["PartBox-1"],
        "location": kit["Station-1"],
    }
    with pytest.raises(PreconditionError, match=r"at\(MobileManipulator-1, Station-1\)"):
        await r1.start(StartRun(skill="pick", params=params))
    assert not arm(kit).calls


async def test_a_part_dropped_on_the_way_fails_the_place(kit: Rig, r1: AgentCore) -> None:
    await at_station(r1, kit)
    assert (await run(r1, "pick", object=kit["Gear-1"])).success
    arm(kit).drop_during = "free"
    result = await run(r1, "place", object=kit["Gear-1"], container=kit["KitBox-1"])
    assert not result.success and result.reason == "execution"
    assert "dropped on the way" in result.message and "lost Gear-1" in result.message
    parent = kit.wm.get_parent(kit["Gear-1"])
    assert parent is None or parent.id != kit["r1-gripper"]  # the world model knows
    assert not kit.wm.query_relation(kit["KitBox-1"], Rel.contain, kit["Gear-1"])


async def test_a_part_lost_before_the_place_fails_it(kit: Rig, r1: AgentCore) -> None:
    await at_station(r1, kit)
    assert (await run(r1, "pick", object=kit["Gear-1"])).success
    gripper(kit).holding = ""  # it slipped out while the robot stood still
    result = await run(r1, "place", object=kit["Gear-1"], container=kit["KitBox-1"])
    assert not result.success and "no longer holds it" in result.message


async def test_stop_mid_motion_halts_the_arm_and_opens_the_empty_gripper(
    kit: Rig, r1: AgentCore
) -> None:
    await at_station(r1, kit)
    hold = arm(kit).hold = anyio.Event()
    events: list[RunEvent] = []
    r1.subscribe(events.append)
    arm(kit).started = anyio.Event()
    started = await r1.start(StartRun(skill="pick", params={"object": kit["Gear-1"]}))
    with anyio.fail_after(5):
        await arm(kit).started.wait()
    result = await r1.stop(started.run_id)
    assert result.reason == "preempted"
    assert arm(kit).stops >= 1 and not arm(kit).moving
    assert gripper(kit).calls[-1] == "open"
    safe = [e for e in events if isinstance(e, Progress) and e.step == "safe_state"]
    assert safe and "gripper open" in safe[-1].message
    hold.set()


async def test_stop_while_carrying_keeps_the_part(kit: Rig, r1: AgentCore) -> None:
    await at_station(r1, kit)
    assert (await run(r1, "pick", object=kit["Gear-1"])).success
    arm(kit).hold = anyio.Event()
    arm(kit).started = anyio.Event()
    started = await r1.start(
        StartRun(skill="place", params={"object": kit["Gear-1"], "container": kit["KitBox-1"]})
    )
    with anyio.fail_after(5):
        await arm(kit).started.wait()
    result = await r1.stop(started.run_id)
    assert result.reason == "preempted" and gripper(kit).holding == "Gear-1"
    assert kit.wm.get_parent(kit["Gear-1"]).id == kit["r1-gripper"]  # type: ignore[union-attr]


async def test_progress_reports_fractions_and_steps(kit: Rig, r1: AgentCore) -> None:
    await at_station(r1, kit)
    events: list[RunEvent] = []
    r1.subscribe(events.append)
    assert (await run(r1, "pick", object=kit["Gear-1"])).success
    steps = [e.step for e in events if isinstance(e, Progress)]
    assert {"located", "home", "approach", "grasp", "lift"} <= set(steps)
    fractions = [e.fraction for e in events if isinstance(e, Progress) and e.fraction >= 0]
    assert fractions and max(fractions) == pytest.approx(1.0)


async def test_the_kit_in_simulated_outcome_mode(kit: Rig) -> None:
    outcomes = SimulatedOutcomes(seed=1)
    async with kit.agent("r1", *SKILLS, simulated=outcomes) as core:
        assert (await run(core, "navigate", goal=kit["Station-1"])).success
        assert (await run(core, "pick", object=kit["Shaft-1"])).success
        assert (await run(core, "place", object=kit["Shaft-1"], container=kit["KitBox-1"])).success
    assert kit.wm.get_parent(kit["Shaft-1"]).id == kit["KitBox-1"]  # type: ignore[union-attr]
    assert all(not d.calls for d in kit.devices.values()), "no hardware was touched"


async def test_a_simulated_failure_commits_nothing(kit: Rig) -> None:
    async with kit.agent("r1", *SKILLS, simulated=SimulatedOutcomes({"navigate": 0.0})) as core:
        result = await run(core, "navigate", goal=kit["Station-1"])
    assert not result.success and result.reason == "execution"
    assert kit.wm.query_relation(kit["r1"], Rel.at, kit["r1-home"])


# --------------------------------------------------------------------------- place_on a surface


def test_place_on_is_described_for_the_planner() -> None:
    desc = PlaceOn.description
    check_description(desc, Ontology.default())
    assert desc.family == Place.description.family == "place"
    atoms = [a for c in [*desc.pre, *desc.hold, *desc.post] for a in symbolic(c) or []]
    assert len(atoms) == len(desc.pre) + len(desc.hold) + len(desc.post), "all plannable"
    assert [describe(c) for c in desc.post] == [
        "contain(surface, object)",
        "not contain(gripper, object)",
    ]


async def test_place_on_puts_the_part_on_the_shelf_top_nearest_the_robot(
    kit: Rig, r1: AgentCore
) -> None:
    await at_station(r1, kit)
    assert (await run(r1, "pick", object=kit["Gear-1"])).success

    def fall(event: RunEvent) -> None:  # released `drop` m above the top, it lands on it
        if isinstance(event, Progress) and event.step == "retreat":
            gear = kit.world.objects["Gear-1"]
            kit.world.objects["Gear-1"] = gear.__class__(gear.x, gear.y, SHELF_TOP + 0.0125)

    r1.subscribe(fall)
    placed = await run(r1, "place_on", object=kit["Gear-1"], surface=kit["Shelf-1"])
    assert placed.success, placed.message
    assert placed.params["location"] == kit["Station-1"], "inferred from at(robot, location)"
    assert kit.wm.get_parent(kit["Gear-1"]).id == kit["Shelf-1"]  # type: ignore[union-attr]
    assert gripper(kit).holding == ""
    release = [c for c in arm(kit).calls if c == "line"]
    assert release, "a straight move down to the release pose"
    gear = kit.world.objects["Gear-1"]
    assert gear.x == pytest.approx(0.93 + 0.03 + 0.028)  # the front strip: nearest the robot
    assert gear.y == pytest.approx(-1.0)  # the free gap between the two part boxes
    for box in ("PartBox-1", "PartBox-2"):  # between the boxes, not in one
        assert not kit.wm.spatial.is_inside(kit["Gear-1"], kit[box])
    seen = kit.wm.spatial.world_pose(kit["Gear-1"]).position
    assert (seen.x, seen.y) == pytest.approx((gear.x, gear.y))  # the sighting was written


async def test_place_on_fails_when_the_part_lands_in_a_box_instead(kit: Rig, r1: AgentCore) -> None:
    await at_station(r1, kit)
    assert (await run(r1, "pick", object=kit["Gear-1"])).success
    box = kit.wm.spatial.world_pose(kit["PartBox-2"]).position

    def bounce(event: RunEvent) -> None:  # released, it rolls into the next box
        if isinstance(event, Progress) and event.step == "retreat":
            kit.world.objects["Gear-1"] = kit.world.objects["Gear-1"].__class__(box.x, box.y, box.z)

    r1.subscribe(bounce)
    result = await run(r1, "place_on", object=kit["Gear-1"], surface=kit["Shelf-1"])
    assert not result.success and result.reason == "execution"
    assert "did not land in the target" in result.message and "PartBox-2" in result.message
    assert kit.wm.get_parent(kit["Gear-1"]).id == kit["PartBox-2"]  # type: ignore[union-attr]
    assert not kit.wm.query_relation(kit["Shelf-1"], Rel.contain, kit["Gear-1"])


async def test_place_on_needs_a_surface_where_the_robot_is(kit: Rig, r1: AgentCore) -> None:
    await kit.wm.transact(move_ops(kit.wm, kit["Gear-1"], kit["r1-gripper"]))  # held at home
    params: dict[str, Value] = {
        "object": kit["Gear-1"],
        "surface": kit["Shelf-1"],
        "location": kit["r1-home"],  # where r1 is
    }
    with pytest.raises(PreconditionError, match=r"contain\(Location-1, Shelf-1\)"):
        await r1.start(StartRun(skill="place_on", params=params))
    params["surface"] = kit["PartBox-1"]  # a box is no surface
    with pytest.raises(ParameterTypeError, match="Surface"):
        await r1.start(StartRun(skill="place_on", params=params))
    assert not arm(kit).calls


async def test_a_planner_puts_a_part_on_a_shelf_with_place_on(kit: Rig) -> None:
    config = load_config(CONFIGS / "kitting" / "r1.toml")
    paths = [*config.skills.paths, "skill_agent.skills:PlaceOn"]
    config = msgspec.structs.replace(
        config, skills=msgspec.structs.replace(config.skills, paths=paths)
    )
    wm: WmClient = kit.wm
    await register_agent(wm, config)
    found = agents_from_view(wm)
    assert all(not a.problems for a in found), [a.problems for a in found]
    plan = await Planner(timeout=60).plan(found, wm, parse_goal("contain(Shelf-2, Gear-1)", wm))
    skills = [s.skill for s in plan.steps]
    assert skills[-1] == "place_on" and "place" not in skills  # not into the kit box
    assert skills.index("pick") < len(skills) - 2 and skills[-2] == "navigate"  # carried over
    last = plan.steps[-1].params
    assert last["surface"] == kit["Shelf-2"] and last["location"] == kit["Station-2"]
