"""A hardware parameter the agent's configuration binds names one device everywhere: the
device the agent registers with its skills is the one the planner's domain binds, the one the
task verification predicts the call locks, and the one the run locks.

The kitting agents bind ``sensor`` to the overhead camera (``[hardware] sensor = "Camera-1"``)
while each robot has a camera of its own: a planner reading only the robot's devices bound the
robot's camera while the run locked the overhead one."""

from __future__ import annotations

from collections.abc import AsyncIterator
from pathlib import Path

import pytest

from scenario import load_scenario
from scenario.wm import scenario_ops
from skill_agent.parameters import bindings
from skill_agent.runtime import AgentCore, SkillRegistry, load_config
from skill_agent.server._serving import _register
from task_agent import parse_goal
from task_agent.discovery import agents_from_view
from task_agent.domain import build_task
from task_agent.protocol import Call, TaskFile
from task_agent.protocol import Parallel as Par
from task_agent.protocol import Sequence as Seq
from task_agent.verification import check
from tests.unit.wm_store.stores import memory_client
from wm_store import WmClient

pytestmark = pytest.mark.anyio

ROOT = Path(__file__).resolve().parents[3]


@pytest.fixture
async def wm() -> AsyncIterator[WmClient]:
    async with memory_client() as client:
        yield client


async def test_the_planned_sensor_is_the_locked_sensor(wm: WmClient) -> None:
    scenario = load_scenario(ROOT / "configs/scenarios/kitting/scenario.toml")
    ids = {k[1:]: v for k, v in (await wm.transact(scenario_ops(scenario))).ids.items()}
    overhead, wrist = ids["Camera-1"], ids["r1-camera"]
    assert overhead != wrist
    config = load_config(ROOT / "configs/agents/kitting/r1.toml")
    registry = SkillRegistry.from_config(config, wm.ontology)
    core = AgentCore(name=config.name, wm=wm, skills=registry.load(), registry=registry.conditions)
    await _register(wm, core, config, "skimesh/test/r1", None)

    # what the agent registered: its skills' sensor defaults to the bound camera
    (r1,) = [a for a in agents_from_view(wm) if a.name == "r1"]
    locate = r1.skill("locate")
    assert locate is not None and bindings(locate) == {"sensor": overhead}
    assert wrist in r1.devices and overhead not in r1.devices  # the robot's own camera is hasA

    # the planner's domain binds it
    task = build_task([r1], wm, parse_goal(f"contain(KitBox-1, {ids['Gear-1']})", wm))
    (schema,) = [a for a in task.actions.values() if a.skill == "locate"]
    assert schema.bound["sensor"] == overhead

    # the verification predicts the call locks it, and the run locks it
    call = Call(agent="r1", skill="locate", params={"object": ids["Gear-1"]})
    report = check(TaskFile(root=Seq(children=[call])), wm, [r1])
    assert report.problems == []
    assert overhead in report.steps[0].locks and wrist not in report.steps[0].locks
    for given in ({"object": ids["Gear-1"]}, {"object": ids["Gear-1"], "sensor": wrist}):
        specified = core._specify(locate, given)
        assert specified.values["sensor"] == overhead
        assert overhead in core._resources(locate, specified.values)


async def test_a_device_two_agents_share_is_no_conflict_between_them(wm: WmClient) -> None:
    scenario = load_scenario(ROOT / "configs/scenarios/kitting/scenario.toml")
    ids = {k[1:]: v for k, v in (await wm.transact(scenario_ops(scenario))).ids.items()}
    for name in ("r1", "r2"):
        config = load_config(ROOT / f"configs/agents/kitting/{name}.toml")
        registry = SkillRegistry.from_config(config, wm.ontology)
        core = AgentCore(name=name, wm=wm, skills=registry.load(), registry=registry.conditions)
        await _register(wm, core, config, f"skimesh/test/{name}", None)
    agents = [a for a in agents_from_view(wm) if a.name in ("r1", "r2")]

    def locate(agent: str, part: str) -> Call:
        return Call(agent=agent, skill="locate", params={"object": ids[part]})

    # agents lock devices for their own runs: r1 and r2 may both use the overhead camera
    apart = check(
        TaskFile(root=Par(children=[locate("r1", "Gear-1"), locate("r2", "Bolt-1")])), wm, agents
    )
    assert apart.problems == []
    assert all(ids["Camera-1"] in step.locks for step in apart.steps)
    # one agent: one run per device at a time
    one = check(
        TaskFile(root=Par(children=[locate("r1", "Gear-1"), locate("r1", "Gear-2")])), wm, agents
    )
    assert [p.kind for p in one.problems] == ["resource"]
    assert "Camera-1" in one.problems[0].message
