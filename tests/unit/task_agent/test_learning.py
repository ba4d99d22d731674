"""Replanning that learns and learned durations, with in-process agents (real agent cores in
simulated-outcome mode, an in-memory world model, the real planner) and scripted physical
failures: the next plan avoids a failed grounded step, a task with nothing left ends with the
step, the robot and the cause; run times are learned, kept in a file and used by the schedule
and the allocation; every task reports estimated against actual makespan."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import anyio
import msgspec
import pytest

from skill_agent.protocol import RunResult, RunStarted, StartRun
from skill_agent.skills import Pick
from task_agent import parse_goal
from task_agent.discovery import agents_from_view
from task_agent.execution import CoreRunner, Executor, StepOutcome
from task_agent.execution._runners import OnEvent, OnStarted
from task_agent.learning import DurationBook, Lessons, changed_params
from task_agent.planning import exclude_steps, to_partial_order
from task_agent.protocol import (
    Planned,
    Replanning,
    StepStarted,
    SubmitGoal,
    TaskFinished,
    TasksReply,
    TaskStatus,
)
from tests.assets.task_fleet import PLANNER, Fleet, fleet
from wm_store.protocol import SetRelation, UnsetRelation, UpdateElement

pytestmark = pytest.mark.anyio

CAUSE = "pick: shoulder_lift did not reach its target (blocked, or overloaded?)"


class ScriptedFailures:
    """A :class:`CoreRunner` whose ``pick`` of ``part`` fails on the robot (reason
    ``execution``, :data:`CAUSE`) before anything moves: on every agent, or (``first_only``)
    on the first agent that picks it; every other run goes to the agent cores."""

    def __init__(self, inner: CoreRunner, part: str, *, first_only: bool = False) -> None:
        self.inner, self.part, self.first_only = inner, part, first_only
        self.failed: list[tuple[str, dict[str, object]]] = []

    async def run(
        self, agent: str, request: StartRun, *, on_started: OnStarted, on_event: OnEvent
    ) -> RunResult:
        scripted = request.skill == "pick" and request.params.get("object") == self.part
        if scripted and not (self.first_only and self.failed and self.failed[0][0] != agent):
            on_started(RunStarted(run_id=request.run_id, params=dict(request.params)))
            self.failed.append((agent, dict(request.params)))
            return RunResult(
                run_id=request.run_id, agent=agent, skill="pick", seq=1, success=False,
                reason="execution", message=CAUSE, params=dict(request.params),
            )  # fmt: skip
        return await self.inner.run(agent, request, on_started=on_started, on_event=on_event)

    async def pause(self, agent: str, run_id: str) -> None:
        await self.inner.pause(agent, run_id)

    async def resume(self, agent: str, run_id: str) -> None:
        await self.inner.resume(agent, run_id)


def learning(f: Fleet, task_id: str, book: DurationBook) -> Executor:
    """The fleet's executor, learning into ``book`` (as the task service shares its book)."""
    executor = f.executor(task_id)
    executor.learning.book = book
    return executor


def picks(f: Fleet, part: str) -> list[tuple[str, str]]:
    """(agent, container) of every pick of ``part`` that started."""
    return [
        (e.agent, str(e.params.get("container", e.params.get("source", ""))))
        for e in f.events
        if isinstance(e, StepStarted) and e.skill == "pick" and e.params.get("object") == part
    ]


async def test_the_next_plan_avoids_the_failed_grounded_step() -> None:
    async with fleet(start={"r1": 1, "r2": 1}) as f:
        part = f.parts[0]
        runner = ScriptedFailures(f.runner, part, first_only=True)
        executor = f.executor()
        executor.steps.runner = runner
        done = await executor.run_goal(parse_goal(f.tray_goal(0), f.wm))
        assert done.outcome == "succeeded", done.message
        (failed_agent, _), *_ = runner.failed
        assert [a for a, _ in runner.failed] == [failed_agent]
        (replan,) = [e for e in f.events if isinstance(e, Replanning)]
        assert CAUSE in replan.reason and "the next plan avoids this step" in replan.reason
        second = f.of(Planned)[1]
        assert isinstance(second, Planned)
        assert (failed_agent, "pick") not in {(s.agent, s.skill) for s in second.steps}
        tried = [a for a, _ in picks(f, part)]
        assert tried[0] == failed_agent and tried[1] != failed_agent


async def test_with_nothing_left_the_task_says_which_step_robot_and_cause() -> None:
    async with fleet(start={"r1": 1, "r2": 1}) as f:
        part = f.parts[0]
        runner = ScriptedFailures(f.runner, part)
        executor = f.executor(max_replans=5)
        executor.steps.runner = runner
        done = await executor.run_goal(parse_goal(f.tray_goal(0), f.wm))
        assert done.outcome == "failed"
        # each robot tried the pick once: the same step never failed the same way twice
        assert sorted(a for a, _ in runner.failed) == ["r1", "r2"]
        assert len(picks(f, part)) == 2
        assert done.message.startswith("nothing left to try for contain(Tray-1, Gear-1)")
        for robot in ("r1", "r2"):
            assert f"on {robot} failed (execution): {CAUSE}" in done.message
        assert "object=gear-1 (Gear-1)" in done.message
        assert "learned_failed" not in done.message and "no plan reaches" not in done.message
        assert done.replans == 2


async def test_a_failed_step_may_run_again_once_its_things_changed() -> None:
    async with fleet() as f:
        lessons = Lessons()
        params = {"object": f.parts[0], "robot": f.robots[0]}
        run = StepOutcome(
            index=0, agent="r1", skill="pick", success=False, reason="execution", message=CAUSE,
            params=dict(params),
        )  # fmt: skip
        lessons.learn(f.wm, run, hardware={f.robots[0]})
        assert lessons.excluded(f.wm) == [("r1", "pick", params)]
        # the robot's own state is not the step's: it still fails the same way
        await f.wm.transact([UpdateElement(id=f.robots[0], properties={"mass": 50.0})])
        assert lessons.excluded(f.wm) == [("r1", "pick", params)]
        await f.wm.transact([UpdateElement(id=f.parts[0], properties={"mass": 0.05})])
        assert lessons.excluded(f.wm) == []
        # what a pick changes is its object (and gripper): a robot coming to the station does not
        # lift the ban, the part's new state does
        assert changed_params(Pick.description) == {"object", "gripper"}
        at_station = msgspec.structs.replace(run, params={**params, "location": f.stations[1]})
        lessons.learn(f.wm, at_station, hardware={f.robots[0]}, changes={"object", "gripper"})
        (was,) = f.wm.query_relation(subject=f.robots[1], predicate="at")
        await f.wm.transact(
            [
                UnsetRelation(subject=f.robots[1], predicate="at", object=was.object),
                SetRelation(subject=f.robots[1], predicate="at", object=f.stations[1]),
            ]
        )
        assert len(lessons.excluded(f.wm)) == 1
        await f.wm.transact([UpdateElement(id=f.parts[0], properties={"mass": 0.07})])
        assert lessons.excluded(f.wm) == []
        stopped = msgspec.structs.replace(run, reason="stopped")
        assert lessons.learn(f.wm, stopped) is None


async def test_exclude_steps_bans_one_grounding_only() -> None:
    async with fleet(start={"r1": 1, "r2": 1}) as f:
        task = (
            await PLANNER.plan(agents_from_view(f.wm), f.wm, parse_goal(f.tray_goal(0), f.wm))
        ).task
        plan = PLANNER.solve(task)
        pick = next(s for s in plan.steps if s.skill == "pick")
        banned = exclude_steps(task, [(pick.agent, "pick", pick.params)])
        again = PLANNER.solve(banned)
        assert all((s.agent, s.params) != (pick.agent, pick.params) for s in again.steps), (
            "the banned grounding was planned again"
        )
        assert any(s.skill == "pick" for s in again.steps)


# --------------------------------------------------------------------------- durations


def test_durations_learn_a_mean_and_a_line_over_distance(tmp_path: Path) -> None:
    book = DurationBook(tmp_path / "d.json")
    book.record("r1", "pick", 3.0)
    book.record("r1", "pick", 5.0)
    assert book.estimate("r1", "pick", None, 9.0) == pytest.approx(4.0)
    book.record("r1", "navigate", 3.0, 1.0)
    book.record("r1", "navigate", 7.0, 3.0)
    assert book.estimate("r1", "navigate", 2.0, 9.0) == pytest.approx(5.0)
    assert book.estimate("r1", "navigate", 5.0, 9.0) == pytest.approx(11.0)
    # another robot of the fleet: the others' figure; an unknown skill: the description's
    assert book.estimate("r2", "pick", None, 9.0) == pytest.approx(4.0)
    assert book.estimate("r1", "serve", None, 9.0) == 9.0
    book.save(book.snapshot())
    again = DurationBook.load(tmp_path / "d.json")
    assert again.estimate("r1", "navigate", 2.0, 9.0) == pytest.approx(5.0)
    assert again.samples("r1", "pick") == 2
    stale = book.snapshot()
    book.record("r1", "pick", 100.0)
    book.save(book.snapshot())
    book.save(stale)  # an older snapshot never overwrites a newer one
    assert DurationBook.load(tmp_path / "d.json").samples("r1", "pick") == 3


def test_an_unreadable_durations_file_is_learned_again(tmp_path: Path) -> None:
    path = tmp_path / "d.json"
    path.write_text("{not json")
    book = DurationBook.load(path)
    assert list(book.rows()) == []
    book.record("r1", "pick", 1.0)
    book.save(book.snapshot())
    assert DurationBook.load(path).samples("r1", "pick") == 1


async def test_learned_durations_make_the_second_estimate_honest(tmp_path: Path) -> None:
    """The first task is estimated from the skill descriptions (seconds), its runs take
    milliseconds (time scale 0.01); the second task, planned with what the first learned
    (kept in a file, read back as a restart would), is estimated within 25 %... of its own
    actual makespan up to the scheduling overhead of a few milliseconds per step."""
    path = tmp_path / "durations.json"
    async with fleet(start={"r1": 1, "r2": 2}, time_scale=0.05) as f:
        first = await learning(f, "t-1", DurationBook.load(path)).run_goal(
            parse_goal(f.tray_goal(0, 1), f.wm)
        )
        assert first.outcome == "succeeded", first.message
        assert first.estimated_makespan is not None and first.actual_makespan is not None
        assert first.estimated_makespan > 4 * first.actual_makespan  # description figures
        book = DurationBook.load(path)
        assert book.samples("r1", "pick") + book.samples("r2", "pick") == 2
        second = await learning(f, "t-2", book).run_goal(parse_goal(f.tray_goal(2, 3), f.wm))
        assert second.outcome == "succeeded", second.message
        assert second.estimated_makespan is not None and second.actual_makespan is not None
        error = abs(second.estimated_makespan - second.actual_makespan)
        assert error <= 0.25 * second.actual_makespan + 0.05, (
            second.estimated_makespan,
            second.actual_makespan,
        )


async def test_the_schedule_and_the_allocation_use_the_timing() -> None:
    """r1 three times slower than r2, both at Station-1 with four of its parts to serve: the
    schedule takes the timing's durations, and balancing moves work (a pick with the serve of
    the part it put in the gripper) from r1 to r2."""

    class SlowR1:
        def seconds(
            self, agent: str, skill: str, params: Mapping[str, object], default: float
        ) -> float:
            return default * (3.0 if agent == "r1" else 1.0)

    async with fleet(parts=8, start={"r1": 1, "r2": 1}) as f:
        goal = " and ".join(f"contain({f.trays[0]}, {f.parts[p]})" for p in (0, 2, 4, 6))
        plan = await PLANNER.plan(agents_from_view(f.wm), f.wm, parse_goal(goal, f.wm))
        timed = to_partial_order(plan, timing=SlowR1(), balance=False)
        for s in timed.steps:
            described = plan.task.actions[s.step.action].duration
            expected = described * (3.0 if s.step.agent == "r1" else 1.0)
            assert s.finish - s.start == pytest.approx(expected)
        balanced = to_partial_order(plan, timing=SlowR1())
        steps = {a: [s.step for s in balanced.steps if s.step.agent == a] for a in ("r1", "r2")}
        assert len(steps["r2"]) > len(steps["r1"]), balanced.render()
        assert balanced.makespan < timed.makespan
        untimed = to_partial_order(plan)  # alike robots: the work split evenly
        assert sum(s.step.agent == "r1" for s in untimed.steps) == 4, untimed.render()
        for robot, own in steps.items():  # each part's pick and serve on one robot
            picked = {s.params["object"] for s in own if s.skill == "pick"}
            assert picked == {s.params["object"] for s in own if s.skill == "serve"}, robot


async def test_the_task_service_shares_and_keeps_the_book(tmp_path: Path) -> None:
    """Every task of a service learns into one book, kept in its file when a task ends; a
    service started on that file (a restart) plans with it; ``TaskStatus`` gives the
    estimated and the actual makespan."""
    path = tmp_path / "durations.json"
    async with fleet(start={"r1": 1, "r2": 2}, time_scale=0.02) as f:
        estimates = []
        for n, parts in enumerate(((0, 1), (2, 3))):
            tasks = f.service(durations=DurationBook.load(path))
            async with anyio.create_task_group() as tg:
                await tg.start(tasks.run)
                await tasks.handle(SubmitGoal(goal=f.tray_goal(*parts), task_id=f"t-{n}"))
                with anyio.fail_after(10):
                    while not any(
                        isinstance(e, TaskFinished) and e.task_id == f"t-{n}" for e in f.events
                    ):
                        await f.changed.wait()
                reply = await tasks.handle(TaskStatus(task_id=f"t-{n}"))
                tg.cancel_scope.cancel()
            assert isinstance(reply, TasksReply)
            (info,) = reply.tasks
            assert info.outcome == "succeeded", info.message
            assert info.estimated_makespan is not None and info.actual_makespan is not None
            estimates.append((info.estimated_makespan, info.actual_makespan))
            kept = DurationBook.load(path)
            assert kept.samples("r1", "pick") + kept.samples("r2", "pick") == 2 * (n + 1)
        (first, _), (second, actual) = estimates
        assert first > 10 * second  # descriptions (seconds) against learned (milliseconds)
        assert second == pytest.approx(actual, rel=0.5, abs=0.05)


async def test_a_ban_names_what_the_step_changes_not_where_it_stood() -> None:
    """A failed serve is banned over its object and tray (what its effects name), not its
    location: serving that part onto that tray is not tried again from elsewhere."""
    async with fleet(start={"r1": 1}) as f:
        goal = parse_goal(f.tray_goal(0), f.wm)
        task = (await PLANNER.plan(agents_from_view(f.wm), f.wm, goal)).task
        serve = next(a for a in task.actions.values() if a.agent == "r1" and a.skill == "serve")
        params = {n: f"{n}-x" for n, _ in serve.params}
        banned = exclude_steps(task, [("r1", "serve", params)])
        (lit,) = [lit for lit in banned.actions[serve.name].pre if lit.pred.startswith("learned")]
        assert [n for n, _ in serve.params] == ["object", "tray", "location"]
        assert not lit.positive and set(lit.args) == {"?object", "?tray"}
        (fact,) = [f for f in banned.init if f[0] == lit.pred]
        assert sorted(fact[1]) == ["object-x", "tray-x"]
