"""A task's kept events (bounded; ``TaskHistory`` pages), the client's merge of history and
live stream (each ``seq`` once), and the task-level pause on in-process agents: no step starts
while the task is held, the held runs resume, abort works while paused."""

from __future__ import annotations

import anyio
import pytest

from task_agent._client import SeqMerge
from task_agent.execution import EventHistory
from task_agent.protocol import (
    AbortTask,
    HistoryReply,
    OkReply,
    PauseTask,
    Planned,
    ResumeTask,
    StepFinished,
    StepProgress,
    StepStarted,
    SubmitGoal,
    TaskEvent,
    TaskFinished,
    TaskHistory,
    TaskPaused,
    TaskResumed,
    TasksReply,
    TaskStarted,
    TaskStatus,
)
from tests.unit.task_agent.test_service import call, refused, service


def started(seq: int = 1) -> TaskStarted:
    return TaskStarted(task_id="t", seq=seq, stamp=float(seq))


def progress(seq: int, step: int = 0) -> StepProgress:
    return StepProgress(task_id="t", seq=seq, stamp=float(seq), step=step, agent="r1", state="x")


def finished(seq: int, step: int = 0) -> StepFinished:
    return StepFinished(
        task_id="t", seq=seq, stamp=float(seq), step=step, agent="r1", skill="s", success=True,
        reason="ok",
    )  # fmt: skip


def test_the_history_drops_the_oldest_progress_first_and_keeps_the_start() -> None:
    history = EventHistory(max_events=4)
    events: list[TaskEvent] = [started(), progress(2), progress(3), finished(4), progress(5)]
    for event in events:
        history.add(event)
    assert [e.seq for e in history.since()] == [1, 3, 4, 5] and history.dropped == 1
    for seq in range(6, 9):
        history.add(finished(seq))
    assert [e.seq for e in history.since()] == [1, 6, 7, 8] and history.dropped == 4
    assert [e.seq for e in history.since(6)] == [7, 8]
    assert [e.seq for e in history.since(0, limit=2)] == [1, 6]
    assert len(history) == 4
    with pytest.raises(ValueError, match="at least 2"):
        EventHistory(max_events=1)


def test_the_merge_takes_each_seq_once_and_sees_gaps() -> None:
    merge = SeqMerge()
    assert merge.take(started(1)) and merge.take(progress(2))
    assert not merge.take(progress(2)) and not merge.take(started(1))
    assert merge.gap(4) and not merge.gap(3)
    assert merge.take(finished(5)) and merge.last_seq == 5 and not merge.take(progress(4))


@pytest.mark.anyio
async def test_the_history_of_a_finished_task_is_every_published_event_in_pages() -> None:
    async with service() as (f, tasks):
        goal = f"contain({f.kits[0]}, {f.parts[0]})"
        await call(tasks, SubmitGoal(goal=goal, task_id="h"))
        await f.wait_for(TaskFinished)
        reply, ok = await call(tasks, TaskHistory(task_id="h"))
        assert ok and isinstance(reply, HistoryReply) and not reply.more
        assert reply.events == f.events and reply.outcome == "succeeded"
        assert isinstance(reply.events[0], TaskStarted) and isinstance(reply.events[1], Planned)
        assert [e.seq for e in reply.events] == list(range(1, len(f.events) + 1))
        page, _ = await call(tasks, TaskHistory(task_id="h", after_seq=2, limit=3))
        assert isinstance(page, HistoryReply) and page.more
        assert [e.seq for e in page.events] == [3, 4, 5]
        await refused(tasks, TaskHistory(task_id="nope"), "unknown_task", "no task 'nope'")


def steps_started(events: list[TaskEvent]) -> list[int]:
    return [e.step for e in events if isinstance(e, StepStarted)]


@pytest.mark.anyio
async def test_a_paused_task_starts_no_step_until_resumed_then_succeeds() -> None:
    async with service(time_scale=0.05) as (f, tasks):
        goal = f"contain({f.kits[0]}, {f.parts[0]})"
        await call(tasks, SubmitGoal(goal=goal, task_id="p"))
        await f.wait_for(StepStarted)
        reply, ok = await call(tasks, PauseTask(task_id="p", reason="coffee"))
        assert ok and isinstance(reply, OkReply) and "paused" in reply.message, reply
        (paused,) = [e for e in f.events if isinstance(e, TaskPaused)]
        assert paused.reason == "coffee" and len(paused.runs) == 1
        agent, run_id = paused.runs[0].split("/")
        assert f.cores[agent].status(run_id).state == "paused"
        again, _ = await call(tasks, PauseTask(task_id="p"))
        assert again == OkReply(message="task p is paused already")
        status, _ = await call(tasks, TaskStatus(task_id="p"))
        assert isinstance(status, TasksReply) and status.tasks[0].paused
        # let the held run finish on its own agent: the task still starts no step
        await f.cores[agent].resume(run_id)
        await f.wait_for(StepFinished)
        await anyio.wait_all_tasks_blocked()
        assert steps_started(f.events) == [0], "a step started while the task was paused"
        reply, ok = await call(tasks, ResumeTask(task_id="p"))
        assert ok and reply == OkReply(message="task p resumed")
        await f.wait_for(TaskFinished)
        last = f.events[-1]
        assert isinstance(last, TaskFinished) and last.outcome == "succeeded", last
        resumed = [i for i, e in enumerate(f.events) if isinstance(e, TaskResumed)]
        second = [i for i, e in enumerate(f.events) if isinstance(e, StepStarted) and e.step]
        assert resumed and second and resumed[0] < second[0]
        await refused(tasks, PauseTask(task_id="p"), "task_ended", "has ended: succeeded")


@pytest.mark.anyio
async def test_a_paused_task_can_be_aborted() -> None:
    async with service(time_scale=0.2) as (f, tasks):
        await call(tasks, SubmitGoal(goal=f"contain({f.kits[0]}, {f.parts[0]})", task_id="a"))
        await f.wait_for(StepStarted)
        await call(tasks, PauseTask(task_id="a"))
        reply, ok = await call(tasks, AbortTask(task_id="a", reason="enough"))
        assert ok and reply == OkReply(message="task a: aborted")
        last = f.events[-1]
        assert isinstance(last, TaskFinished) and last.outcome == "aborted"
        runs = f.cores["r1"].runs(active_only=False)
        assert runs and all(r.result is not None and r.result.reason == "preempted" for r in runs)
