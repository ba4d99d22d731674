"""The executor with in-process agents (real agent cores in simulated-outcome mode, an
in-memory world model, the real planner): scheduling and parallelism, replanning after a skill
failure or an agent loss, the bound on replans, abort, unsolvable goals, task files."""

from __future__ import annotations

from collections.abc import Sequence

import anyio
import pytest

from task_agent import parse_goal
from task_agent.execution import unmet_goal
from task_agent.protocol import (
    Call,
    Parallel,
    Planned,
    Replanning,
    StepFinished,
    StepStarted,
    TaskEvent,
    TaskFile,
    TaskFinished,
)
from task_agent.protocol import (
    Sequence as SequenceBlock,
)
from tests.assets.task_fleet import Fleet, fleet
from tests.conftest import SlowSteps

pytestmark = pytest.mark.anyio


def started(events: Sequence[TaskEvent]) -> dict[int, StepStarted]:
    return {e.step: e for e in events if isinstance(e, StepStarted)}


def finished(events: Sequence[TaskEvent]) -> dict[int, StepFinished]:
    return {e.step: e for e in events if isinstance(e, StepFinished)}


def intervals(events: Sequence[TaskEvent], agent: str) -> list[tuple[float, float]]:
    begin, end = started(events), finished(events)
    return [(begin[i].stamp, end[i].stamp) for i in begin if begin[i].agent == agent]


def check_stream(events: Sequence[TaskEvent]) -> TaskFinished:
    """Sequence numbers 1..n, one TaskFinished at the end, every started step finished."""
    assert [e.seq for e in events] == list(range(1, len(events) + 1))
    assert isinstance(events[-1], TaskFinished)
    assert sum(isinstance(e, TaskFinished) for e in events) == 1
    assert set(started(events)) <= set(finished(events))
    return events[-1]


async def test_independent_steps_run_in_parallel_on_two_robots(
    blocking_detector: SlowSteps,
) -> None:
    async with fleet(time_scale=0.02) as f:
        goal = parse_goal(f.kit_goal(0, 1), f.wm)
        blocking_detector.reports.clear()  # setting the fleet up is not under test
        done = await f.executor().run_goal(goal)
        assert done.outcome == "succeeded", done.message
        assert check_stream(f.events) is done
        plan = f.of(Planned)[0]
        assert isinstance(plan, Planned) and {s.agent for s in plan.steps} == {"r1", "r2"}
        # every step started after its predecessors finished (partial order honoured)
        begin, end = started(f.events), finished(f.events)
        for step in plan.steps:
            assert all(end[p].stamp <= begin[step.index].stamp for p in step.after)
        # and the two robots worked at the same time
        (a0, a1), (b0, b1) = intervals(f.events, "r1")[0], intervals(f.events, "r2")[0]
        assert max(a0, b0) < min(a1, b1), "r1's and r2's first steps do not overlap"
        assert unmet_goal(parse_goal(f.kit_goal(0, 1), f.wm), f.wm) == []
        assert done.steps_run == 6 and done.replans == 0
        assert not blocking_detector.reports, "planning or execution blocked the event loop"


async def test_a_failing_skill_is_replanned_around() -> None:
    """r2 cannot pick (probability 0): its step fails, the goal is planned again from the
    world model without r2's pick, and r1 does the rest."""
    async with fleet(probabilities={"r2": {"pick": 0.0}}, start={"r1": 1, "r2": 2}) as f:
        done = await f.executor().run_goal(parse_goal(f.tray_goal(0, 1), f.wm))
        assert done.outcome == "succeeded", done.message
        check_stream(f.events)
        failed = [e for e in finished(f.events).values() if not e.success]
        assert [(e.agent, e.skill, e.reason) for e in failed] == [("r2", "pick", "execution")]
        replans = [e for e in f.events if isinstance(e, Replanning)]
        assert len(replans) == 1 and "pick on r2 failed (execution)" in replans[0].reason
        second = f.of(Planned)[1]
        assert isinstance(second, Planned) and second.attempt == 1
        assert ("r2", "pick") not in {(s.agent, s.skill) for s in second.steps}
        first = f.of(Planned)[0]
        assert isinstance(first, Planned)
        assert min(s.index for s in second.steps) > max(s.index for s in first.steps)
        assert done.replans == 1 and "1 replan: 1. step" in done.message


async def test_losing_an_agent_mid_run_lets_the_other_robot_finish() -> None:
    async with fleet(start={"r1": 1, "r2": 2}, time_scale=0.05) as f:
        executor = f.executor()

        async def kill_r2() -> None:
            await f.wait_for(StepStarted, "r2")
            await f.runner.vanish("r2")
            f.discovery.set_alive("r2", False)

        async with anyio.create_task_group() as tg:
            tg.start_soon(kill_r2)
            done = await executor.run_goal(parse_goal(f.tray_goal(0, 1), f.wm))
        assert done.outcome == "succeeded", done.message
        check_stream(f.events)
        lost = [e for e in finished(f.events).values() if e.agent == "r2"]
        assert len(lost) == 1 and lost[0].reason == "agent_lost"
        r1_first = intervals(f.events, "r1")[0]
        assert lost[0].stamp < r1_first[1], "the loss was not seen while r1 was still working"
        replan = next(e for e in f.events if isinstance(e, Replanning))
        assert replan.stamp >= r1_first[1]  # r1's in-flight step finished first
        assert all(
            e.agent == "r1" for e in f.events if isinstance(e, StepStarted) and e.seq > replan.seq
        )


async def test_replans_are_bounded() -> None:
    probabilities = {"r1": {"pick": 0.0}, "r2": {"pick": 0.0}}
    async with fleet(probabilities=probabilities, start={"r1": 1, "r2": 2}) as f:
        done = await f.executor(max_replans=1).run_goal(parse_goal(f.tray_goal(0, 1), f.wm))
        assert done.outcome == "failed" and done.replans == 1
        assert "no replan left of 1" in done.message
        assert len(f.of(Planned)) == 2


async def test_abort_preempts_every_run() -> None:
    async with fleet(time_scale=0.1) as f:
        executor = f.executor()

        async def abort_soon() -> None:  # once both robots are driving
            await f.wait_for(StepStarted, "r1")
            await f.wait_for(StepStarted, "r2")
            executor.abort("operator pressed stop")

        async with anyio.create_task_group() as tg:
            tg.start_soon(abort_soon)
            done = await executor.run_goal(parse_goal(f.kit_goal(0, 1), f.wm))
        assert done.outcome == "aborted" and done.message == "operator pressed stop"
        check_stream(f.events)
        ends = finished(f.events)
        assert ends and all(e.reason == "preempted" and not e.success for e in ends.values())
        runs = [r for core in f.cores.values() for r in core.runs(active_only=False)]
        assert len(runs) == len(ends) == 2
        assert all(r.result is not None and r.result.reason == "preempted" for r in runs)
        assert executor.info().outcome == "aborted"


async def test_an_unsolvable_goal_says_why() -> None:
    async with fleet() as f:
        goal = parse_goal(f"not contain({f.stations[0]}, PartBox-1)", f.wm)
        done = await f.executor().run_goal(goal)
        assert done.outcome == "unsolvable"
        assert "no skill's post-condition undoes it" in done.message
        assert [type(e).__name__ for e in f.events] == ["TaskStarted", "TaskFinished"]


async def test_a_goal_that_holds_needs_no_step() -> None:
    async with fleet() as f:
        done = await f.executor().run_goal(parse_goal(f"contain({f.stations[0]}, PartBox-1)", f.wm))
        assert done.outcome == "succeeded" and done.steps_run == 0


def kitting_file(f: Fleet, *, holder: str = "PartBox-1") -> TaskFile:
    """r1 fills its kit with gear 1 while r2 drives to station 2, in parallel; data flow
    from the pick to the place."""
    station, kit = f.stations[0], f.kits[0]
    r1 = SequenceBlock(
        children=[
            Call(agent="r1", skill="navigate", params={"start": "label:depot", "goal": station}),
            Call(
                agent="r1",
                skill="pick",
                id="pick1",
                params={"object": f.parts[0], "holder": holder, "location": station},
            ),
            Call(agent="r1", skill="place", params={"object": "@pick1.object", "container": kit}),
        ]
    )
    r2 = Call(skill="navigate", agent="r2", params={"start": "label:depot", "goal": f.stations[1]})
    return TaskFile(name="kit one gear", root=Parallel(children=[r1, r2]))


async def test_a_task_file_runs_as_written_with_data_flow() -> None:
    async with fleet(time_scale=0.05) as f:
        done = await f.executor().run_file(kitting_file(f))
        assert done.outcome == "succeeded", done.message
        check_stream(f.events)
        plan = f.of(Planned)[0]
        assert isinstance(plan, Planned) and plan.planner == "task file"
        assert [s.after for s in plan.steps] == [[], [0], [1], []]
        begin = started(f.events)
        assert begin[2].params["object"] == f.parts[0]  # "@pick1.object"
        (a0, a1), (b0, b1) = intervals(f.events, "r1")[0], intervals(f.events, "r2")[0]
        assert max(a0, b0) < min(a1, b1)
        assert f.wm.query_relation(f.kits[0], "contain", f.parts[0])


async def test_a_failing_task_file_step_fails_the_task() -> None:
    async with fleet() as f:
        done = await f.executor().run_file(kitting_file(f, holder="PartBox-2"))
        assert done.outcome == "failed"
        assert "step 1 pick on r1 failed (precondition)" in done.message
        assert not f.of(Replanning)
        assert 2 not in started(f.events)  # the place never started
