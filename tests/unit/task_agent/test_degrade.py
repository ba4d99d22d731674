"""Degrade, never drop (in-process agents, the real planner): a lost agent ends the task
``partial`` with every still reachable fact achieved; an unfinished task's robots put down what
they hold (the safe-state phase), or say why they cannot; tokens that vanish together (a lost
router) make their agents unknown for a grace period, not lost, and the task goes on."""

from __future__ import annotations

import time
from collections.abc import Sequence

import anyio
import pytest

from task_agent import parse_goal
from task_agent.discovery import Discovery
from task_agent.execution import held_by
from task_agent.protocol import (
    Replanning,
    SafeState,
    StepFinished,
    StepStarted,
    TaskEvent,
)
from tests.assets.task_fleet import Fleet, fleet
from wm_store.protocol import SetRelation, UnsetRelation, UpdateElement

pytestmark = pytest.mark.anyio


def lost_steps(events: Sequence[TaskEvent]) -> list[StepFinished]:
    return [e for e in events if isinstance(e, StepFinished) and e.reason == "agent_lost"]


def gripper(f: Fleet, robot: int) -> str:
    return f.wm.resolve_element(type="Gripper", label=f"gripper-{robot}")[0].id


def holding(f: Fleet, agent: str) -> list[tuple[str, str]]:
    info = f.discovery.agent(agent)
    assert info is not None
    return held_by(info, f.wm)


async def test_a_lost_agent_ends_partial_with_every_reachable_fact_achieved() -> None:
    """r2 is killed at its first step: its kit cannot be filled by anyone else (it carries
    it), r1 still fills its own kit with both parts, and the task says what was lost and why."""
    async with fleet(start={"r1": 1, "r2": 2}, time_scale=0.05) as f:
        k1, k2, p = f.kits[0], f.kits[1], f.parts
        goal = f"contain({k1}, {p[0]}) and contain({k1}, {p[2]}) and contain({k2}, {p[1]})"

        async def kill_r2() -> None:
            await f.wait_for(StepStarted, "r2")
            await f.runner.vanish("r2")
            f.discovery.set_alive("r2", False)

        executor = f.executor()
        async with anyio.create_task_group() as tg:
            tg.start_soon(kill_r2)
            done = await executor.run_goal(parse_goal(goal, f.wm))
        assert done.outcome == "partial", done.message
        assert done.partial is not None and done.partial == executor.info().partial
        assert done.partial.achieved == ["contain(kit-1, gear-1)", "contain(kit-1, gear-3)"]
        assert [x.fact for x in done.partial.lost] == ["contain(kit-2, gear-2)"]
        assert "r2 lost" in done.partial.lost[0].why
        [agent] = done.partial.lost_agents
        assert agent.agent == "r2" and agent.step >= 0 and agent.skill
        assert len(lost_steps(f.events)) == 1
        assert "2 of 3 goal facts achieved" in done.message
        assert holding(f, "r1") == []  # the survivor holds nothing at the end
        assert not [e for e in f.events if isinstance(e, SafeState)]


async def test_an_abort_puts_down_what_a_robot_holds() -> None:
    async with fleet(start={"r1": 1}, robots=1, time_scale=0.05) as f:
        k1, p = f.kits[0], f.parts
        executor = f.executor()

        async def abort_when_holding() -> None:
            while not any(
                isinstance(e, StepFinished) and e.skill == "pick" and e.success for e in f.events
            ):
                await f.changed.wait()
            executor.abort("stop now")

        async with anyio.create_task_group() as tg:
            tg.start_soon(abort_when_holding)
            done = await executor.run_goal(
                parse_goal(f"contain({k1}, {p[0]}) and contain({k1}, {p[2]})", f.wm)
            )
        assert done.outcome == "aborted", done.message
        [safe] = [e for e in f.events if isinstance(e, SafeState)]
        assert safe.agent == "r1" and safe.ok and safe.holding, [str(e)[:300] for e in f.events]
        put_down = [e for e in f.events if isinstance(e, StepStarted)][-1]
        assert put_down.skill == "place" and put_down.agent == "r1"
        assert [e for e in f.events if isinstance(e, StepFinished)][-1].success
        assert holding(f, "r1") == []
        assert done.seq == safe.seq + 1


async def test_the_safe_state_puts_down_or_says_why_not() -> None:
    async with fleet(start={"r1": 1}, robots=1, time_scale=0.01) as f:
        grip, part, kit = gripper(f, 1), f.parts[0], f.kits[0]
        box = f.wm.query_relation("", "contain", part)[0]
        await f.wm.transact(
            [
                UnsetRelation(subject=box.subject, predicate="contain", object=part),
                SetRelation(subject=grip, predicate="contain", object=part),
            ]
        )
        executor = f.executor()
        await f.wm.transact([UpdateElement(id=kit, properties={"capacity": 0})])
        [refused] = await executor.safe_state.run({"r1"})
        assert not refused.ok and refused.holding == ["gear-1"]
        assert "the put-down did not free gear-1" in refused.message  # the planner cannot count
        assert "place on r1 failed (precondition)" in refused.message
        assert holding(f, "r1") == [(grip, part)]
        await f.wm.transact([UpdateElement(id=kit, properties={"capacity": 20})])
        [report] = await executor.safe_state.run({"r1"})
        assert report.ok, report
        assert holding(f, "r1") == []
        assert f.wm.query_relation(kit, "contain", part)


async def test_tokens_vanishing_together_are_unknown_until_back() -> None:
    """A lost router: both tokens vanish at once; the agents are unknown (not lost, nobody is
    told) and the task's runs go on; the tokens come back and the task succeeds unharmed."""
    async with fleet(start={"r1": 1, "r2": 2}, time_scale=0.25) as f:  # a pick: 1 s
        f.discovery.grace = 10.0
        told: list[tuple[str, bool]] = []
        f.discovery.on_presence(lambda n, alive: told.append((n, alive)))
        executor = f.executor()

        async def router_restart() -> None:
            await f.wait_for(StepStarted, "r2")
            f.discovery.token_gone("r1")
            f.discovery.token_gone("r2")
            with anyio.fail_after(2):
                while f.discovery.unknown != {"r1", "r2"} or f.discovery._gone:
                    await f.discovery.wait_changed()
            with anyio.fail_after(5):  # the picks end meanwhile: runs go on on their agents
                while len([e for e in f.events if isinstance(e, StepFinished)]) < 2:
                    await f.changed.wait()
            starts = len([e for e in f.events if isinstance(e, StepStarted)])
            await anyio.sleep(0.3)  # a ready step waits while its agent is unknown
            assert len([e for e in f.events if isinstance(e, StepStarted)]) == starts
            f.discovery.token_back("r1")
            f.discovery.token_back("r2")

        async with anyio.create_task_group() as tg:
            tg.start_soon(f.discovery.judge)
            tg.start_soon(router_restart)
            done = await executor.run_goal(parse_goal(f.kit_goal(0, 1), f.wm))
            tg.cancel_scope.cancel()
        assert done.outcome == "succeeded", done.message
        assert not lost_steps(f.events) and not [e for e in f.events if isinstance(e, Replanning)]
        assert told == [("r1", True), ("r2", True)]
        assert not f.discovery.unknown


async def test_unknown_agents_are_lost_at_the_end_of_the_grace_period() -> None:
    async with fleet() as f:
        discovery = Discovery(f.wm, grace=0.5, settle=0.05)
        discovery.reset_alive({"r1", "r2"})
        told: list[tuple[str, bool, float]] = []
        discovery.on_presence(lambda n, alive: told.append((n, alive, time.monotonic())))
        async with anyio.create_task_group() as tg:
            tg.start_soon(discovery.judge)
            gone = time.monotonic()
            discovery.token_gone("r1")
            discovery.token_gone("r2")
            with anyio.fail_after(3):
                while len(told) < 2:
                    await discovery.wait_changed()
            tg.cancel_scope.cancel()
        assert [(n, a) for n, a, _ in told] == [("r1", False), ("r2", False)]
        assert all(t - gone >= 0.5 for *_, t in told)
        assert discovery.agents() == [] and not discovery.unknown


async def test_one_token_gone_while_others_stay_is_lost_at_once() -> None:
    async with fleet() as f:
        discovery = Discovery(f.wm, grace=30.0, settle=0.05)
        discovery.reset_alive({"r1", "r2"})
        told: list[tuple[str, bool]] = []
        discovery.on_presence(lambda n, alive: told.append((n, alive)))
        async with anyio.create_task_group() as tg:
            tg.start_soon(discovery.judge)
            discovery.token_gone("r2")
            assert discovery.is_unknown("r2") and not discovery.is_alive("r2")
            with anyio.fail_after(2):
                while not told:
                    await discovery.wait_changed()
            tg.cancel_scope.cancel()
        assert told == [("r2", False)] and not discovery.unknown
        assert [a.name for a in discovery.agents()] == ["r1"]
