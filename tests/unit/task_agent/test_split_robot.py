"""One robot run by two agents (a component split): the example configs
``configs/agents/kitting/split/r1-base.toml`` (navigate; the base) and ``r1-arm.toml`` (locate,
pick, place; arm, gripper, wrist camera) over the kitting scenario's scene, in memory.

Covers: the two configs together are r1.toml cut in two; both agents register for the scene's
robot r1 and discovery sees one robot with the union of their skills; unregistering one
leaves the other; the planner drives r1 with one agent and picks with the other, in order.
Two agents registering a robot that is not in the world model yet at the same moment find
one robot: a registration commits only at the revision it was made from, else it is made again.
The same over Zenoh, with each agent in its own process: tests/integration/test_split_robot.py.
"""

from __future__ import annotations

from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from pathlib import Path

import anyio
import pytest

from scenario import load_scenario
from scenario.wm import scenario_ops
from skill_agent.runtime import AgentConfig, load_config
from task_agent.discovery import agents_from_view
from task_agent.planning import to_partial_order
from tests.unit.skill_agent.scenario_planning import plan_scenario, register_agent
from wm_store import DeviceSpec, InMemoryTransport, RobotRegistration, WmClient
from wm_store.ontology import Ontology
from wm_store.server import WmService, WmStore

ROOT = Path(__file__).resolve().parents[3]
CONFIGS = ROOT / "configs" / "agents"
SCENARIO = ROOT / "configs" / "scenarios" / "kitting" / "scenario.toml"
SPLIT = ("kitting/split/r1-base", "kitting/split/r1-arm")


def config(name: str) -> AgentConfig:
    """``configs/agents/<name>.toml``."""
    return load_config(CONFIGS / f"{name}.toml")


@asynccontextmanager
async def running_store(ontology: Ontology) -> AsyncIterator[WmService]:
    store = await WmStore.open(ontology)
    async with anyio.create_task_group() as tg:
        await tg.start(store.run)
        yield WmService(store)
        tg.cancel_scope.cancel()


@pytest.fixture
async def wm() -> AsyncIterator[WmClient]:
    ontology = Ontology.default()
    async with (
        running_store(ontology) as service,
        WmClient.connect(InMemoryTransport(service), ontology) as client,
    ):
        yield client


def test_the_split_configs_are_r1_cut_in_two() -> None:
    whole = config("kitting/r1")
    base, arm = (config(name) for name in SPLIT)
    assert base.robot == arm.robot == whole.robot, "one robot: the same [robot] in both"
    base_devices = {d.label for d in base.devices}
    arm_devices = {d.label for d in arm.devices}
    assert not base_devices & arm_devices, "each device has one agent"
    assert base_devices | arm_devices == {d.label for d in whole.devices}
    assert sorted(base.skills.paths + arm.skills.paths) == sorted(whole.skills.paths)
    assert base.simulation.probabilities | arm.simulation.probabilities == (
        whole.simulation.probabilities
    )
    assert arm.hardware == whole.hardware and not base.hardware
    assert base.name != arm.name, "two agents: two liveliness tokens"


@pytest.mark.anyio
async def test_both_agents_control_one_robot_and_discovery_joins_their_skills(
    wm: WmClient,
) -> None:
    await wm.transact(scenario_ops(load_scenario(SCENARIO)))
    for name in SPLIT:
        await register_agent(wm, config(name))
    [robot] = wm.resolve_element(type="Robot", label="r1")
    agents = {a.name: a for a in agents_from_view(wm) if a.robot == robot.id}
    assert sorted(agents) == ["r1-arm", "r1-base"]
    assert not any(a.problems for a in agents.values())
    skills = {s.name for a in agents.values() for s in a.skills}
    assert skills == {"locate", "navigate", "pick", "place", "place_on"}
    labels = {wm.get_element(d).label for d in agents["r1-arm"].devices}
    assert {"r1-arm", "r1-gripper", "r1-camera", "r1-base"} <= labels, "the robot's parts"

    await wm.unregister_robot("r1-base")
    left = [a for a in agents_from_view(wm) if a.robot == robot.id]
    assert [a.name for a in left] == ["r1-arm"], "the other agent stays"
    assert wm.resolve_element(type="MobileBase", label="r1-base"), "the robot keeps its base"
    await register_agent(wm, config("kitting/split/r1-base"))  # back
    assert len([a for a in agents_from_view(wm) if a.robot == robot.id]) == 2


@pytest.mark.anyio
async def test_a_plan_drives_with_one_agent_then_picks_with_the_other(wm: WmClient) -> None:
    plan = await plan_scenario(wm, "kitting", list(SPLIT), "contain(KitBox-1, Gear-1)")
    steps = [(s.agent, s.skill) for s in plan.steps]
    assert steps[0] == ("r1-base", "navigate")
    assert ("r1-arm", "pick") in steps and steps[-1] == ("r1-arm", "place")
    [robot] = wm.resolve_element(type="Robot", label="r1")
    assert {s.params["robot"] for s in plan.steps} == {robot.id}, "both bind the same robot"
    order = to_partial_order(plan)
    pick = next(s.step.index for s in order.steps if s.step.skill == "pick")
    assert order.predecessors(pick), "the pick waits for the drive"
    assert order.makespan == pytest.approx(order.sequential), "one robot: one step at a time"


@pytest.mark.anyio
async def test_two_agents_registering_a_new_robot_at_once_make_one_robot() -> None:
    ontology = Ontology.default()
    async with (
        running_store(ontology) as service,
        WmClient.connect(InMemoryTransport(service), ontology) as base,
        WmClient.connect(InMemoryTransport(service), ontology) as arm,
    ):
        async with anyio.create_task_group() as tg:
            for client, agent, device in ((base, "r1-base", "MobileBase"), (arm, "r1-arm", "Arm")):
                registration = RobotRegistration(
                    agent=agent,
                    robot_type="MobileManipulator",
                    robot_label="r1",
                    devices=[DeviceSpec(type=device, label=f"r1-{device.lower()}")],
                )
                tg.start_soon(client.register_robot, registration)
        await base.wait_for_revision((await base.info()).revision)
        assert len(base.resolve_element(type="Robot", label="r1")) == 1
