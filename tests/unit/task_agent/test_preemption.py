"""Preemption at a step boundary: the claim book's rule (a waiting task of higher priority asks
the preemptible holders that alone hold it up to give way; a preempted task keeps its place
and is not preempted again by a task of equal or lower priority than the one before) and a
task service in which a long low-priority task gives way to a high-priority one on the same
robot at a step boundary, with no part left in the gripper, and both succeed, the high one
first; asked while its pick runs (a one-robot site: the high task cannot plan around it), the
low task runs the place that puts the part down before it gives way."""

from __future__ import annotations

import anyio
import pytest

from task_agent.claims import ClaimBook
from task_agent.protocol import (
    StepFinished,
    StepStarted,
    SubmitGoal,
    TaskEvent,
    TaskFinished,
    TaskOptions,
    TaskPaused,
    TaskResumed,
)
from tests.assets.task_fleet import Fleet, fleet

pytestmark = pytest.mark.anyio


async def test_a_higher_priority_waiter_asks_the_holder_which_gives_way_and_comes_back() -> None:
    book = ClaimBook()
    await book.acquire("low", {"r1"}, {"Gear-1"}, preemptible=True)
    granted: list[str] = []
    async with anyio.create_task_group() as tg:

        async def want(task: str, agents: set[str], priority: int) -> None:
            await book.acquire(task, agents, priority=priority)
            granted.append(task)

        tg.start_soon(want, "high", {"r1"}, 5)
        with anyio.fail_after(1):
            assert await book.preempted("low") == "high"
        assert book.asked_by("low") == "high" and granted == [], "low holds until it gives way"
        tg.start_soon(want, "low", {"r1"}, 0)  # at its step boundary: give back, ask again
        await anyio.wait_all_tasks_blocked()
        assert granted == ["high"] and book.asked_by("low") == ""
        assert [c.task_id for c in book.waiting()] == ["low"]
        book.release("high")
    assert granted == ["high", "low"]
    claim = book.claim_of("low")
    assert claim is not None and claim.waited and claim.agents == {"r1"}


async def _asked_within(book: ClaimBook, task: str, seconds: float = 0.05) -> str:
    with anyio.move_on_after(seconds):
        return await book.preempted(task)
    return ""


async def test_only_a_strictly_higher_priority_preempts_and_only_a_preemptible_claim() -> None:
    book = ClaimBook()
    await book.acquire("fixed", {"r1"}, priority=0)  # not preemptible
    await book.acquire("low", {"r2"}, priority=3, preemptible=True)
    async with anyio.create_task_group() as tg:
        tg.start_soon(lambda: book.acquire("equal", {"r2"}, priority=3))
        tg.start_soon(lambda: book.acquire("high-on-fixed", {"r1"}, priority=9))
        await anyio.wait_all_tasks_blocked()
        assert await _asked_within(book, "low") == "", "equal priority does not preempt"
        assert await _asked_within(book, "fixed") == "", "not preemptible"
        tg.start_soon(lambda: book.acquire("high-on-both", {"r1", "r2"}, priority=9))
        await anyio.wait_all_tasks_blocked()
        assert await _asked_within(book, "low") == "", (
            "r1 (not preemptible) would still hold it up: nobody is asked"
        )
        tg.cancel_scope.cancel()


async def test_a_preempted_task_is_not_preempted_again_by_equal_or_lower_priority() -> None:
    book = ClaimBook()
    await book.acquire("low", {"r1"}, preemptible=True)
    async with anyio.create_task_group() as tg:
        tg.start_soon(lambda: book.acquire("first", {"r1"}, priority=5))
        assert await _asked_within(book, "low", 1) == "first"
        tg.start_soon(lambda: book.acquire("low", {"r1"}, preemptible=True))  # gives way
        await anyio.wait_all_tasks_blocked()
        book.release("first")
        await anyio.wait_all_tasks_blocked()
        held = book.claim_of("low")
        assert held is not None, "low holds r1 again"
        tg.start_soon(lambda: book.acquire("second", {"r1"}, priority=5))
        tg.start_soon(lambda: book.acquire("lower", {"r1"}, priority=2))
        await anyio.wait_all_tasks_blocked()
        assert await _asked_within(book, "low") == "", "5 preempted it already: 5 waits"
        tg.start_soon(lambda: book.acquire("urgent", {"r1"}, priority=8))
        assert await _asked_within(book, "low", 1) == "urgent", "a higher priority still may"
        tg.cancel_scope.cancel()


async def test_a_preempted_task_keeps_its_place_before_later_tasks_of_its_priority() -> None:
    book = ClaimBook()
    await book.acquire("low", {"r1"}, preemptible=True)
    order: list[str] = []

    async def want(task: str, priority: int, preemptible: bool = False) -> None:
        await book.acquire(task, {"r1"}, priority=priority, preemptible=preemptible)
        order.append(task)

    async with anyio.create_task_group() as tg:
        tg.start_soon(want, "later", 0)  # queued behind low's claim
        tg.start_soon(want, "high", 5)
        assert await _asked_within(book, "low", 1) == "high"
        tg.start_soon(want, "low", 0, True)
        await anyio.wait_all_tasks_blocked()
        book.release("high")
        await anyio.wait_all_tasks_blocked()
        assert order == ["high", "low"], "low asked first: it goes before 'later'"
        book.release("low")
    assert order == ["high", "low", "later"]


# --------------------------------------------------------------------------- a task service


def _of(events: list[TaskEvent], task: str, kind: type[TaskEvent]) -> list[TaskEvent]:
    return [e for e in events if e.task_id == task and isinstance(e, kind)]


async def _until(f: Fleet, done: object, timeout: float = 30) -> None:
    with anyio.fail_after(timeout):
        while not done():  # type: ignore[operator]
            await f.changed.wait()


async def test_a_long_low_priority_task_gives_way_at_a_step_boundary_and_both_succeed() -> None:
    async with fleet(robots=2, parts=8, time_scale=0.05) as f:
        tasks = f.service()
        low_goal = " and ".join(f"contain({f.kits[0]}, {f.parts[p]})" for p in (0, 2, 4, 6))
        high_goal = f"contain({f.kits[0]}, {f.parts[1]})"  # r1's kit again: only r1 can
        waiting: list[str] = []
        async with anyio.create_task_group() as tg:
            await tg.start(tasks.run)
            await tasks.handle(SubmitGoal(goal=low_goal, task_id="low"))
            await _until(f, lambda: _of(f.events, "low", StepFinished))  # it runs on r1
            await tasks.handle(
                SubmitGoal(goal=high_goal, task_id="high", options=TaskOptions(priority=5))
            )
            await _until(f, lambda: _of(f.events, "low", TaskPaused))
            waiting += [i.waiting for i in tasks.tasks() if i.task_id == "low"]
            await _until(f, lambda: len(f.of(TaskFinished)) == 2)
            tg.cancel_scope.cancel()
    ends = {e.task_id: e for e in f.of(TaskFinished) if isinstance(e, TaskFinished)}
    assert ends["high"].outcome == ends["low"].outcome == "succeeded", ends
    assert ends["high"].stamp < ends["low"].stamp, "the high one first"
    assert ends["low"].replans == 0, "giving way is no replan"
    (paused,) = _of(f.events, "low", TaskPaused)
    assert isinstance(paused, TaskPaused) and "preempted by task high (priority 5)" in paused.reason
    assert waiting and "preempted by task high" in waiting[0], waiting
    resumed = _of(f.events, "low", TaskResumed)[0]
    low = _of(f.events, "low", StepStarted) + _of(f.events, "low", StepFinished)
    high = _of(f.events, "high", StepStarted) + _of(f.events, "high", StepFinished)
    before = [e for e in low if e.seq < paused.seq]
    assert all(isinstance(e, StepStarted | StepFinished) for e in before)
    started = [e for e in before if isinstance(e, StepStarted)]
    finished = [e for e in before if isinstance(e, StepFinished)]
    assert len(started) == len(finished), "no step of low was running when it gave way"
    skills = [e.skill for e in started]
    assert skills.count("pick") == skills.count("place"), f"r1 held a part: {skills}"
    assert len(started) < 1 + 2 * 4, "low gave way before its end"
    assert max(e.stamp for e in before) <= min(e.stamp for e in high), "high ran after"
    after = [e for e in low if e.seq > resumed.seq]
    assert after and min(e.stamp for e in after) >= max(e.stamp for e in high), (
        "low went on after high ended"
    )
    for p in (0, 1, 2, 4, 6):
        assert f.wm.query_relation(f.kits[0], "contain", f.parts[p]), f"part {p} not in the kit"


async def test_a_robot_asked_mid_pick_puts_the_part_down_before_it_gives_way() -> None:
    """The high task arrives while the low task's pick runs: r1 will hold a gear at the next
    step boundary, so the low task runs its place first and gives way only then."""
    async with fleet(robots=1, parts=4, time_scale=0.05) as f:
        tasks = f.service()
        low_goal = f"contain({f.kits[0]}, {f.parts[0]}) and contain({f.kits[0]}, {f.parts[2]})"
        high_goal = f"contain({f.kits[0]}, {f.parts[1]})"

        def picking() -> bool:
            return any(
                isinstance(e, StepStarted) and e.skill == "pick"
                for e in _of(f.events, "low", StepStarted)
            )

        async with anyio.create_task_group() as tg:
            await tg.start(tasks.run)
            await tasks.handle(SubmitGoal(goal=low_goal, task_id="low"))
            await _until(f, picking)
            await tasks.handle(
                SubmitGoal(goal=high_goal, task_id="high", options=TaskOptions(priority=5))
            )
            await _until(f, lambda: len(f.of(TaskFinished)) == 2)
            tg.cancel_scope.cancel()
    ends = {e.task_id: e for e in f.of(TaskFinished) if isinstance(e, TaskFinished)}
    assert ends["high"].outcome == ends["low"].outcome == "succeeded", ends
    assert ends["high"].stamp < ends["low"].stamp
    (paused,) = _of(f.events, "low", TaskPaused)
    done = [
        e.skill
        for e in _of(f.events, "low", StepFinished)
        if isinstance(e, StepFinished) and e.seq < paused.seq
    ]
    assert done[-2:] == ["pick", "place"], f"r1 gave way holding the gear: {done}"
