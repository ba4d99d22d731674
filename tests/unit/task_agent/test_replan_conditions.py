"""Replanning after a post-condition and after a hold-condition failure, and step progress
streamed while a step runs: the executor with one in-process agent core running the probe
skills of :mod:`tests.assets.skills.replanning` for real (not in simulated-outcome mode), an
in-memory world model and the real planner. The task's events are the in-memory equivalent of
``tasks/<task>/events`` (:meth:`Fleet.publish`)."""

from __future__ import annotations

from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

import anyio
import msgspec
import pytest

from skill_agent.runtime import AgentCore
from task_agent import parse_goal
from task_agent.discovery import Discovery
from task_agent.execution import CoreRunner
from task_agent.protocol import (
    Planned,
    Replanning,
    StepFinished,
    StepProgress,
    StepStarted,
    TaskFinished,
)
from tests.assets.skills import Probe, ProbedSkill, entries
from tests.assets.skills.replanning import Convey, Stow
from tests.assets.task_fleet import Fleet
from wm_store import InMemoryTransport, RobotRegistration, SkillSpec, WmClient
from wm_store.ontology import Ontology
from wm_store.protocol import AddElement, Relation, SetRelation, UnsetRelation
from wm_store.server import WmService, WmStore

pytestmark = pytest.mark.anyio

_json = msgspec.json.Encoder()


class Scene(msgspec.Struct, kw_only=True):
    fleet: Fleet
    probe: Probe
    gear: str
    boxes: list[str]
    tray: str


@asynccontextmanager
async def probe_fleet(*skills: type[ProbedSkill]) -> AsyncIterator[Scene]:
    """Agent ``r1`` offering ``skills`` (one, so the plan is known); gear-1 in box-1; box-2
    and tray-1 empty."""
    probe = Probe()
    ontology = Ontology.default()
    store = await WmStore.open(ontology)
    async with anyio.create_task_group() as tg:
        await tg.start(store.run)
        transport = InMemoryTransport(WmService(store))
        async with WmClient.connect(transport, ontology, author="test") as wm:
            ids = (
                await wm.transact(
                    [
                        AddElement(type="PartBox", label="box-1", ref="$b1"),
                        AddElement(type="PartBox", label="box-2", ref="$b2"),
                        AddElement(type="Tray", label="tray-1", ref="$t"),
                        AddElement(type="Gear", label="gear-1", ref="$g",
                                   relations=[Relation("$b1", "contain", "$")]),
                    ]
                )
            ).ids  # fmt: skip
            registered = await wm.register_robot(
                RobotRegistration(
                    agent="r1",
                    robot_type="MobileManipulator",
                    robot_label="robot-1",
                    skills=[
                        SkillSpec(name=s.description.name, skill_type=s.description.family,
                                  description=_json.encode(s.description).decode())
                        for s in skills
                    ],
                )
            )  # fmt: skip
            core = AgentCore(
                name="r1", wm=wm, skills=entries(probe, *skills), robot=registered["$robot"]
            )
            await tg.start(core.run)
            discovery = Discovery(wm)
            discovery.reset_alive({"r1"})
            fleet = Fleet(
                wm=wm,
                cores={"r1": core},
                runner=CoreRunner({"r1": core}),
                discovery=discovery,
                robots=[registered["$robot"]],
                kits=[],
                trays=[ids["$t"]],
                stations=[],
                parts=[ids["$g"]],
            )
            yield Scene(
                fleet=fleet, probe=probe, gear=ids["$g"], boxes=[ids["$b1"], ids["$b2"]],
                tray=ids["$t"],
            )  # fmt: skip
        tg.cancel_scope.cancel()


async def reaching(f: Fleet) -> None:
    """Until convey reported that it reaches for the part (its own progress event)."""
    with anyio.fail_after(10):
        while not any(
            isinstance(e, StepProgress) and e.message == "reaching for the part" for e in f.events
        ):
            await f.changed.wait()


async def test_a_false_postcondition_is_replanned_with_its_reason() -> None:
    """The first stow runs but its part number is not read: the run fails ``postcondition``
    and commits nothing; the goal is planned again from the world model, which is as it was,
    so the same stow would fail the same way: it is not tried again, and with no other way to
    the goal the task ends saying which step failed on which robot, and why."""
    async with probe_fleet(Stow) as s:
        f = s.fleet
        done = await f.executor().run_goal(parse_goal(f"contain({s.tray}, {s.gear})", f.wm))
        assert done.outcome == "failed", done.message
        ends = [e for e in f.events if isinstance(e, StepFinished)]
        assert [(e.skill, e.success, e.reason) for e in ends] == [("stow", False, "postcondition")]
        assert "partNumber" in ends[0].message
        (replan,) = [e for e in f.events if isinstance(e, Replanning)]
        assert replan.attempt == 1
        assert f"step {ends[0].step} stow on r1 failed (postcondition)" in replan.reason
        assert [p.attempt for p in f.of(Planned) if isinstance(p, Planned)] == [0]
        assert done.message.startswith("nothing left to try for contain(Tray-1, Gear-1)")
        assert "stow(obj=gear-1 (Gear-1), container=tray-1 (Tray-1)) on r1" in done.message
        assert "failed (postcondition): Gear-1 has no 'partNumber'" in done.message
        assert s.probe.count("execute") == 1  # the same step did not run into it again


async def test_step_progress_is_published_while_the_step_runs() -> None:
    async with probe_fleet(Convey) as s:
        f = s.fleet
        goal = parse_goal(f"contain({s.tray}, {s.gear})", f.wm)
        executor = f.executor()
        seen: list[StepProgress] = []

        async def release_after_progress() -> None:
            await reaching(f)
            seen.extend(e for e in f.events if isinstance(e, StepProgress))
            assert not f.of(StepFinished), "the progress came only after the step"
            s.probe.open("reach")

        async with anyio.create_task_group() as tg:
            tg.start_soon(release_after_progress)
            done = await executor.run_goal(goal)
        assert done.outcome == "succeeded", done.message
        (started,) = [e for e in f.events if isinstance(e, StepStarted)]
        assert started.skill == "convey"
        own = [e for e in seen if e.message == "reaching for the part"]
        assert len(own) == 1 and own[0].state == "executing" and own[0].fraction == 0.5
        assert (own[0].step, own[0].agent, own[0].task_id) == (started.step, "r1", "t-1")
        assert started.seq < own[0].seq  # after StepStarted, before StepFinished
        states = [e.state for e in f.events if isinstance(e, StepProgress)]
        assert "checking_post" in states and states.index("executing") < states.index(
            "checking_post"
        )


async def test_a_violated_hold_condition_is_replanned_with_its_reason() -> None:
    """While convey reaches into box-1, someone moves the part to box-2: the hold-condition
    turns false, the run is stopped (``hold_violated``, the skill's on_preempt brings it to a
    safe state) and the goal is planned again from where the part is now."""
    async with probe_fleet(Convey) as s:
        f = s.fleet
        box1, box2 = s.boxes

        async def move_the_part_while_reaching() -> None:
            await reaching(f)
            await f.wm.transact(
                [
                    UnsetRelation(subject=box1, predicate="contain", object=s.gear),
                    SetRelation(subject=box2, predicate="contain", object=s.gear),
                ]
            )
            await f.wait_for(Replanning)
            s.probe.open("reach")  # the next attempt may reach

        async with anyio.create_task_group() as tg:
            tg.start_soon(move_the_part_while_reaching)
            done = await f.executor().run_goal(parse_goal(f"contain({s.tray}, {s.gear})", f.wm))
        assert isinstance(f.events[-1], TaskFinished)
        assert done.outcome == "succeeded", done.message
        ends = [e for e in f.events if isinstance(e, StepFinished)]
        assert [(e.skill, e.success, e.reason) for e in ends] == [
            ("convey", False, "hold_violated"),
            ("convey", True, "ok"),
        ]
        (replan,) = [e for e in f.events if isinstance(e, Replanning)]
        assert f"step {ends[0].step} convey on r1 failed (hold_violated)" in replan.reason
        assert done.replans == 1 and "(hold_violated)" in done.message
        starts = [e for e in f.events if isinstance(e, StepStarted)]
        assert [e.params["source"] for e in starts] == [box1, box2]  # replanned from the WM
        first_run = starts[0].run_id
        assert s.probe.methods(first_run)[-1] == "on_preempt"  # brought to its safe state
        assert "reached" not in s.probe.methods(first_run)
        assert f.wm.query_relation(s.tray, "contain", s.gear)
