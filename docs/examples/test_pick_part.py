"""Testing the example skill without Zenoh or hardware (docs/guides/write-a-skill.md, "Test it").

The agent's runtime (:class:`~skill_agent.AgentCore`) runs in-process against an in-memory world
model; the skill loads through the same :class:`~skill_agent.SkillRegistry` as in an agent, so
the load-time ontology checks run too. Collected with the unit tests
(``tests/unit/skill_agent/test_plugins.py`` imports these tests).
"""

from __future__ import annotations

from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from pathlib import Path

import anyio
import pytest

from skill_agent.protocol import StartRun, WmWriteEntry
from skill_agent.runtime import AgentCore, SimulatedOutcomes, SkillRegistry
from wm_store import InMemoryTransport, WmClient
from wm_store.ontology import Ontology
from wm_store.protocol import Relation, UpdateElement, Value
from wm_store.server import WmService, WmStore

HERE = Path(__file__).resolve().parent


@asynccontextmanager
async def picker(
    simulated: SimulatedOutcomes | None = None,
) -> AsyncIterator[tuple[AgentCore, WmClient]]:
    """An agent core with the example skill, a robot with a gripper, and a box with a gear."""
    ontology = Ontology.default()
    store = await WmStore.open(ontology)
    async with anyio.create_task_group() as tg:
        await tg.start(store.run)
        async with WmClient.connect(InMemoryTransport(WmService(store)), ontology) as wm:
            robot = await wm.add_element("Robot", "picker-robot")
            await wm.add_element("Gripper", "left", relations=[Relation(robot, "hasA", "$")])
            box = await wm.add_element("PartBox", "box")
            await wm.add_branch(box, "contain", "Gear", "gear")
            skills = SkillRegistry(ontology, paths=[str(HERE / "pick_part.py")]).load()
            core = AgentCore(name="picker", wm=wm, skills=skills, robot=robot, simulated=simulated)
            await tg.start(core.run)
            yield core, wm
            tg.cancel_scope.cancel()


@pytest.mark.anyio
async def test_pick_part_runs_and_commits_its_prediction() -> None:
    async with picker() as (core, wm):
        gear = wm.resolve_element(type="Gear")[0].id
        started = await core.start(StartRun(skill="pick_part", params={"part": gear}))
        assert set(started.inferred) == {"container", "gripper"}, "inferred, with reasons"
        result = await core.wait(started.run_id)
        assert result.success, result.message
        gripper = started.params["gripper"]
        assert wm.get_parent(gear).id == gripper  # type: ignore[union-attr]


@pytest.mark.anyio
async def test_pick_part_in_simulated_outcome_mode() -> None:
    for probability, success in ((1.0, True), (0.0, False)):
        async with picker(SimulatedOutcomes({"pick_part": probability}, seed=7)) as (core, wm):
            gear = wm.resolve_element(type="Gear")[0].id
            box = wm.get_parent(gear)
            started = await core.start(StartRun(skill="pick_part", params={"part": gear}))
            result = await core.wait(started.run_id)
            assert result.success is success
            where = wm.get_parent(gear)
            assert where is not None
            if success:  # the prediction is committed, though nothing moved
                assert where.id == started.params["gripper"]
            else:  # a drawn failure commits nothing
                assert result.reason == "execution" and box is not None and where.id == box.id


@pytest.mark.anyio
async def test_a_stop_opens_the_gripper_and_the_event_log_records_it() -> None:
    async with picker() as (core, wm):
        gear = wm.resolve_element(type="Gear")[0].id
        params: dict[str, Value] = {"part": gear, "motion_time": 30.0}
        started = await core.start(StartRun(skill="pick_part", params=params))
        with anyio.fail_after(5):
            result = await core.stop(started.run_id)
        assert result.reason == "preempted"
        gripper = started.params["gripper"]
        assert isinstance(gripper, str)
        assert wm.get_element(gripper).properties["graspWidth"] == 0.08  # OPEN_WIDTH
        assert wm.get_parent(gear).id != gripper  # type: ignore[union-attr]  # nothing committed
    (write,) = [e for e in core.events.history() if isinstance(e, WmWriteEntry)]
    assert (write.run_id, write.step) == (started.run_id, "preempt")  # on_preempt's write
    assert write.ops == [UpdateElement(id=gripper, properties={"graspWidth": 0.08})]
