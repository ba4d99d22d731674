"""Each step's world-model writes, from the agents' event logs: RunWrites collects a watched
run's writes (its sub-runs' too) until the run's result entry, drops everything else, and does
not wait for an agent it never heard from; the executor puts them in ``StepFinished``."""

from __future__ import annotations

import anyio
import pytest

from skill_agent.protocol import ResultEntry, RunResult, WmWriteEntry
from task_agent import parse_goal
from task_agent.execution import Executor, RunWrites
from task_agent.protocol import StepFinished, StepStarted
from tests.assets.task_fleet import PLANNER, fleet

pytestmark = pytest.mark.anyio


def write(agent: str, run_id: str, revision: int) -> WmWriteEntry:
    return WmWriteEntry(agent=agent, run_id=run_id, revision=revision, ops=[])


def result(agent: str, run_id: str) -> ResultEntry:
    return ResultEntry(
        result=RunResult(run_id=run_id, agent=agent, skill="s", seq=1, success=True, reason="ok")
    )


async def test_a_run_collects_its_own_and_its_sub_runs_writes_until_its_result() -> None:
    writes = RunWrites()
    with writes.watch("r1", "a") as watched:
        writes.feed(write("r1", "a", 3))
        writes.feed(write("r1", "a.1.2", 4))  # a sub-run of a sub-run
        writes.feed(write("r2", "a", 5))  # another agent's run of the same id
        writes.feed(write("r1", "ab", 6))  # another run
        writes.feed(result("r1", "a.1"))  # a sub-run ending does not end the run
        got: list[int] = []

        async def wait() -> None:
            got.extend(await writes.revisions(watched, timeout=30))

        async with anyio.create_task_group() as tg:
            tg.start_soon(wait)
            await anyio.wait_all_tasks_blocked()
            assert not got, "waits for the run's result entry"
            writes.feed(result("r1", "a"))
        assert got == [3, 4]
    writes.feed(write("r1", "a", 9))  # no longer watched: dropped
    assert watched.revisions == [3, 4]
    assert writes.heard_from("r2") and not writes.heard_from("r9")


async def test_no_wait_for_an_agent_that_publishes_no_log() -> None:
    writes = RunWrites()
    with writes.watch("r9", "c") as silent, anyio.fail_after(5):
        assert await writes.revisions(silent, timeout=60) == []
    writes.feed(write("r9", "x", 1))
    with writes.watch("r9", "d") as quiet:
        assert await writes.revisions(quiet, timeout=0.01) == [], "bounded once heard from"


async def test_step_finished_lists_the_writes_of_its_run() -> None:
    async with fleet(robots=1) as f:
        writes = RunWrites()
        (core,) = f.cores.values()
        core.events.subscribe(writes.feed)
        executor = Executor(
            task_id="t-1",
            wm=f.wm,
            discovery=f.discovery,
            runner=f.runner,
            publish=f.publish,
            planner=PLANNER,
            writes=writes,
        )
        done = await executor.run_goal(parse_goal(f.kit_goal(0), f.wm))
        assert done.outcome == "succeeded", done.message
    logged: dict[str, list[int]] = {}
    for entry in core.events.history():
        if isinstance(entry, WmWriteEntry):
            logged.setdefault(entry.run_id.split(".")[0], []).append(entry.revision)
    runs = {e.step: e.run_id for e in f.events if isinstance(e, StepStarted)}
    steps = [e for e in f.events if isinstance(e, StepFinished)]
    assert steps and all(s.success for s in steps)
    assert {s.step: s.wm_writes for s in steps} == {
        step: logged.get(run_id, []) for step, run_id in runs.items()
    }
    assert any(s.wm_writes for s in steps), "the simulated skills commit their effects"
    assert executor.steps.effects_revision == max(r for rs in logged.values() for r in rs)
