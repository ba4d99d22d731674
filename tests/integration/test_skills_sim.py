"""The standard skills in the MuJoCo simulation (fast mode), through the agent core, on both
scenarios: a part picked and placed into the kit box with real physics and attachment (the
world model and the world's ground truth agree), a part picked at a station and put down on
its shelf (place_on), a sensed pose written with its source, a part
dropped mid-carry detected as a failure, a stop mid-motion that halts the arm, the microwave
agent's door, heat and button (operate / operate_stop) skills, and the meal box served on the
tray with a side grasp."""

from __future__ import annotations

from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager
from pathlib import Path
from typing import Any

import anyio
import numpy as np
import pytest

from device_drivers import Appliance
from mujoco_sim import SimWorld, WorldOptions, running_world, sim_devices
from scenario import Scenario, load_scenario
from scenario.wm import scenario_ops
from skill_agent import PreconditionError, Skill
from skill_agent.protocol import Progress, RunEvent, RunResult, StartRun
from skill_agent.runtime import AgentCore, SkillEntry
from skill_agent.skills import (
    ApplianceCloseDoor,
    ApplianceOpenDoor,
    Heat,
    Locate,
    Navigate,
    Operate,
    OperateStop,
    Pick,
    Place,
    PlaceOn,
    Serve,
)
from tests.conftest import SlowSteps
from wm_store import InMemoryTransport, WmClient
from wm_store.ontology import Ontology, Prop, Rel
from wm_store.protocol import Pose
from wm_store.server import WmService, WmStore

pytestmark = [pytest.mark.sim, pytest.mark.anyio]

SCENARIOS = Path(__file__).resolve().parents[2] / "configs" / "scenarios"
KITTING = (Navigate, Locate, Pick, Place)


class Sim:
    """A running world, its world model (the scenario's scene) and element ids by label."""

    def __init__(self, world: SimWorld, wm: WmClient, ids: dict[str, str]) -> None:
        self.world, self.wm, self.ids = world, wm, ids

    def __getitem__(self, label: str) -> str:
        return self.ids[label]

    @asynccontextmanager
    async def agent(
        self, owner: str, *skills: type[Skill], sensors: tuple[str, ...] = ()
    ) -> AsyncIterator[AgentCore]:
        """An agent for ``owner`` (a robot or an appliance) with the world's drivers of its
        devices and of the shared ``sensors`` (the first binds the ``sensor`` parameter)."""
        drivers = {
            self.ids[d.name]: d
            for key, d in sim_devices(self.world).items()
            if key[0] == owner or d.name in sensors
        }
        core = AgentCore(
            name=owner,
            wm=self.wm,
            skills={s.description.name: SkillEntry(s.description, s, s.__module__) for s in skills},
            devices=drivers,
            robot=self.ids[owner],
            hardware={"sensor": self.ids[sensors[0]]} if sensors else {},
            preempt_timeout=3.0,
        )
        async with anyio.create_task_group() as tg:
            await tg.start(core.run)
            yield core
            tg.cancel_scope.cancel()


@asynccontextmanager
async def simulation(
    name: str, seed: int = 0, edit: Callable[[Scenario], Scenario] | None = None
) -> AsyncIterator[Sim]:
    """Scenario ``name`` (changed by ``edit`` first, if given) in a fast world beside its
    world-model scene."""
    scenario = load_scenario(SCENARIOS / name / "scenario.toml")
    if edit is not None:
        scenario = edit(scenario)
    ontology = Ontology.default()
    store = await WmStore.open(ontology)
    async with anyio.create_task_group() as tg:
        await tg.start(store.run)
        async with (
            running_world(scenario, WorldOptions(fast=True, seed=seed)) as world,
            WmClient.connect(InMemoryTransport(WmService(store)), ontology) as wm,
        ):
            reply = await wm.transact(scenario_ops(scenario))
            ids = {ref[1:]: eid for ref, eid in reply.ids.items() if ref.startswith("$")}
            yield Sim(world, wm, ids)
        tg.cancel_scope.cancel()


@pytest.fixture
async def kitting() -> AsyncIterator[Sim]:
    async with simulation("kitting") as sim:
        yield sim


@pytest.fixture
async def meal() -> AsyncIterator[Sim]:
    async with simulation("meal") as sim:
        yield sim


async def run(core: AgentCore, skill: str, **params: Any) -> RunResult:
    started = await core.start(StartRun(skill=skill, params=params))
    with anyio.fail_after(60):
        return await core.wait(started.run_id)


def when(core: AgentCore, test: Callable[[Progress], bool]) -> anyio.Event:
    """An event set by the first progress event of the agent that passes ``test``."""
    seen = anyio.Event()

    def check(event: RunEvent) -> None:
        if isinstance(event, Progress) and test(event):
            seen.set()

    core.subscribe(check)
    return seen


async def arm_speed(world: SimWorld, robot: str) -> float:
    def read(model: Any, data: Any) -> float:
        prefix = f"{robot}/"
        dofs = [
            model.jnt_dofadr[j]
            for j in range(model.njnt)
            if model.joint(j).name.startswith(prefix)
            and not model.joint(j).name.endswith(("finger", "base_x", "base_y", "base_yaw"))
        ]
        return float(np.abs(data.qvel[dofs]).max())

    return await world.call(read)


# --------------------------------------------------------------------------- kitting


async def test_pick_and_place_a_part_into_the_kit_box(
    kitting: Sim, blocking_detector: SlowSteps
) -> None:
    sim = kitting
    async with sim.agent("r1", *KITTING, sensors=("Camera-1",)) as r1:
        for skill, params in (
            ("navigate", {"goal": sim["Station-1"]}),
            ("pick", {"object": sim["Gear-1"]}),
            ("place", {"object": sim["Gear-1"], "container": sim["KitBox-1"]}),
        ):
            result = await run(r1, skill, **params)
            assert result.success, f"{skill}: {result.message}"
            assert result.effects_revision > 0
    assert sim.wm.query_relation(sim["KitBox-1"], Rel.contain, sim["Gear-1"])
    await sim.world.sleep(0.5)
    assert sim.world.object_in("Gear-1", "KitBox-1"), "the ground truth agrees"
    assert "Gear-1" not in sim.world.snapshot.attached
    kit = sim.world.body_pose("KitBox-1")
    believed = sim.wm.spatial.world_pose(sim["KitBox-1"]).position
    assert (believed.x, believed.y) == pytest.approx((kit.x, kit.y), abs=0.02)
    runs = [r for r in blocking_detector.reports if "skill run" in r]  # the skills' own tasks
    assert not runs, "no skill step held the event loop for 50 ms"


async def test_pick_a_part_and_place_it_on_the_stations_shelf(kitting: Sim) -> None:
    sim = kitting
    async with sim.agent("r1", *KITTING, PlaceOn, sensors=("Camera-1",)) as r1:
        for skill, params in (
            ("navigate", {"goal": sim["Station-1"]}),
            ("pick", {"object": sim["Gear-1"]}),
            ("place_on", {"object": sim["Gear-1"], "surface": sim["Shelf-1"]}),
        ):
            result = await run(r1, skill, **params)
            assert result.success, f"{skill}: {result.message}"
    assert sim.wm.query_relation(sim["Shelf-1"], Rel.contain, sim["Gear-1"])
    await sim.world.sleep(0.5)
    gear, shelf = sim.world.body_pose("Gear-1"), sim.world.body_pose("Shelf-1")
    assert "Gear-1" not in sim.world.snapshot.attached
    assert gear.z - 0.0125 == pytest.approx(0.70, abs=0.003), "resting on the shelf top"
    assert abs(gear.x - shelf.x) < 0.3 and abs(gear.y - shelf.y) < 0.6, "within its top"
    assert not any(sim.world.object_in("Gear-1", box) for box in ("PartBox-1", "PartBox-2"))
    believed = sim.wm.spatial.world_pose(sim["Gear-1"]).position  # the camera's sighting
    assert np.hypot(believed.x - gear.x, believed.y - gear.y) < 0.01
    assert abs(believed.z - gear.z) < 0.01


async def test_locate_writes_the_pose_it_sees(kitting: Sim) -> None:
    """The scene starts with rough prior part poses (the scenario's ``prior_noise``); locate
    replaces the prior with what the camera sees, within a centimetre of the physics."""
    sim = kitting
    prior = sim.wm.get_element(sim["Shaft-2"]).properties[Prop.pose]
    truth = sim.world.body_pose("Shaft-2")
    assert isinstance(prior, Pose)
    assert np.hypot(prior.position.x - truth.x, prior.position.y - truth.y) > 0.004
    async with sim.agent("r1", *KITTING, sensors=("Camera-1",)) as r1:
        result = await run(r1, "locate", object=sim["Shaft-2"])
    assert result.success, result.message
    shaft = sim.wm.get_element(sim["Shaft-2"])
    pose = shaft.properties[Prop.pose]
    truth = sim.world.body_pose("Shaft-2")
    assert isinstance(pose, Pose)
    p = pose.position
    assert np.hypot(p.x - truth.x, p.y - truth.y) < 0.01 and abs(p.z - truth.z) < 0.01
    [seen] = shaft.observations[Prop.pose]
    assert seen.source == sim["Camera-1"] and 0.0 < seen.confidence <= 1.0
    assert shaft.properties[Prop.seenAt] == pytest.approx(seen.stamp)


async def test_a_part_dropped_mid_carry_fails_the_place(kitting: Sim) -> None:
    sim = kitting

    def drop(model: Any, data: Any) -> None:
        data.eq_active[model.equality("r1/grasp/Gear-2").id] = 0
        data.ctrl[model.actuator("r1/gripper").id] = 0.085  # and the fingers let go

    async with sim.agent("r1", *KITTING, sensors=("Camera-1",)) as r1:
        assert (await run(r1, "navigate", goal=sim["Station-1"])).success
        assert (await run(r1, "pick", object=sim["Gear-2"])).success
        carrying = when(r1, lambda e: e.skill == "place" and e.step == "home" and e.fraction > 0.1)
        started = await r1.start(
            StartRun(skill="place", params={"object": sim["Gear-2"], "container": sim["KitBox-1"]})
        )
        with anyio.fail_after(30):
            await carrying.wait()
        await sim.world.call(drop)
        with anyio.fail_after(60):
            result = await r1.wait(started.run_id)
    assert not result.success and result.reason == "execution"
    assert "dropped on the way" in result.message and "lost Gear-2" in result.message
    assert not sim.wm.query_relation(sim["r1-gripper"], Rel.contain, sim["Gear-2"])
    assert not sim.wm.query_relation(sim["KitBox-1"], Rel.contain, sim["Gear-2"])
    await sim.world.sleep(0.5)
    assert not sim.world.object_in("Gear-2", "KitBox-1")


async def test_stop_mid_motion_halts_the_arm(kitting: Sim) -> None:
    sim = kitting
    async with sim.agent("r1", *KITTING, sensors=("Camera-1",)) as r1:
        assert (await run(r1, "navigate", goal=sim["Station-1"])).success
        moving = when(r1, lambda e: e.step == "approach" and e.fraction > 0.1)
        started = await r1.start(StartRun(skill="pick", params={"object": sim["Gear-3"]}))
        with anyio.fail_after(30):
            await moving.wait()
        assert await arm_speed(sim.world, "r1") > 0.05, "really moving"
        result = await r1.stop(started.run_id)
    assert result.reason == "preempted"
    assert await arm_speed(sim.world, "r1") < 0.05
    arm = sim_devices(sim.world, "r1")[("r1", "arm")]
    held = (await arm.state()).joints  # type: ignore[attr-defined]
    await sim.world.sleep(0.5)
    assert (await arm.state()).joints == pytest.approx(held, abs=2e-3)  # type: ignore[attr-defined]
    gripper = sim_devices(sim.world, "r1")[("r1", "gripper")]
    state = await gripper.state()  # type: ignore[attr-defined]
    assert state.holding == "" and state.opening > 0.08  # the empty gripper is open
    assert sim.wm.get_parent(sim["Gear-3"]).id == sim["PartBox-1"]  # type: ignore[union-attr]


# --------------------------------------------------------------------------- meal


async def test_the_microwave_agent_opens_and_closes_its_door(meal: Sim) -> None:
    sim = meal
    oven = sim_devices(sim.world, "Microwave-1")[("Microwave-1", "appliance")]
    async with sim.agent("Microwave-1", ApplianceOpenDoor, ApplianceCloseDoor, Heat) as agent:
        opened = await run(agent, "open_door")
        assert opened.success, opened.message
        assert (await oven.state()).door_open  # type: ignore[attr-defined]
        assert sim.wm.get_element(sim["Microwave-1"]).properties[Prop.doorOpen] is True
        closed = await run(agent, "close_door")
        assert closed.success, closed.message
        assert sim.wm.get_element(sim["Microwave-1"]).properties[Prop.doorOpen] is False
        empty = await run(agent, "heat", object=sim["MealBox-1"])  # the world model is wrong
    assert not empty.success and "not in the appliance" in empty.message
    assert not (await oven.state()).heating  # type: ignore[attr-defined]


async def test_the_microwave_buttons_start_and_stop_its_heater(meal: Sim) -> None:
    sim = meal
    oven = sim_devices(sim.world, "Microwave-1")[("Microwave-1", "appliance")]
    assert isinstance(oven, Appliance)
    skills = (ApplianceOpenDoor, ApplianceCloseDoor, Operate, OperateStop)
    async with sim.agent("Microwave-1", *skills) as agent:
        assert (await run(agent, "open_door")).success
        with pytest.raises(PreconditionError, match="doorOpen"):
            await agent.start(StartRun(skill="operate"))
        assert not (await oven.state()).heating
        assert (await run(agent, "close_door")).success
        started = await run(agent, "operate")
        assert started.success, started.message
        state = await oven.state()
        assert state.heating and 0.0 < state.remaining <= 30.0  # the scenario's default time
        assert sim.wm.get_element(sim["Microwave-1"]).properties[Prop.heating] is True
        stopped = await run(agent, "operate_stop")
        assert stopped.success, stopped.message
    assert not (await oven.state()).heating
    assert sim.wm.get_element(sim["Microwave-1"]).properties[Prop.heating] is False


async def test_heating_started_by_operate_ends_by_itself(meal: Sim) -> None:
    sim = meal
    oven = sim_devices(sim.world, "Microwave-1")[("Microwave-1", "appliance")]
    assert isinstance(oven, Appliance)
    async with sim.agent("Microwave-1", Operate) as agent:
        assert (await run(agent, "operate")).success
        remaining = (await oven.state()).remaining
        with anyio.fail_after(60):
            await sim.world.sleep(remaining + 0.1)  # simulated time: the heater's own timer
        assert not (await oven.state()).heating
        assert sim.wm.get_element(sim["Microwave-1"]).properties[Prop.heating] is True  # stale
        again = await run(agent, "operate")  # the stale heating = true is read from the oven
        assert again.success, again.message
    assert (await oven.state()).heating


async def test_the_meal_box_is_served_on_the_tray(meal: Sim) -> None:
    sim = meal
    async with sim.agent(
        "friend", Locate, Pick, Serve, sensors=("Camera-1", "Worktop-1")
    ) as friend:
        located = await run(friend, "locate", object=sim["MealBox-1"], platform=sim["Worktop-1"])
        assert located.success, located.message
        sources = {o.source for o in sim.wm.get_element(sim["MealBox-1"]).observations[Prop.pose]}
        assert sources == {sim["Camera-1"], sim["Worktop-1"]}
        picked = await run(friend, "pick", object=sim["MealBox-1"])
        assert picked.success, picked.message
        served = await run(friend, "serve", object=sim["MealBox-1"])
        assert served.success, served.message
    assert sim.wm.query_relation(sim["Tray-1"], Rel.contain, sim["MealBox-1"])
    await sim.world.sleep(0.5)
    assert sim.world.object_in("MealBox-1", "Tray-1")
