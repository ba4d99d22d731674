"""History, pause and resume from the command line, over real Zenoh on loopback, each command
a subprocess: ``skimesh task watch`` on a task that is paused mid-run prints the task's history
from ``seq`` 1 (its start, the plan, the steps so far, times on the task's own clock) and then
follows it, each event once; ``skimesh task pause`` holds the task (no new step starts) until
``skimesh task resume``, after which it succeeds; ``skimesh pause`` / ``resume`` hold and release
one run; ``skimesh runs`` lists the agent's runs and shows one run's history (``--follow``).

The set-up is :func:`tests.integration.test_tasks.running_site` (store, agents r1 and r2,
``skimesh task-agent``) plus an agent ``hist`` whose simulated skills take 10x the site's time
(navigating 2.5 s), so there is a run to pause.
"""

from __future__ import annotations

import json
import queue
import re
from collections.abc import Iterator
from typing import Any

import anyio
import pytest

from task_agent import new_task_id
from task_agent.protocol import StepFinished, StepStarted, TaskEvent, TaskFinished

from .procs import Child
from .test_tasks import Site, add_robots, running_site

pytestmark = [pytest.mark.zenoh, pytest.mark.slow, pytest.mark.anyio]

AGENT = "hist"


@pytest.fixture(scope="module")
def hist_site(module_router: str, tmp_path_factory: pytest.TempPathFactory) -> Iterator[Site]:
    with running_site(module_router, tmp_path_factory.mktemp("history")) as site:
        site.spawn_agent(AGENT, time_scale=0.5).wait_stderr(f"agent {AGENT} ready")

        async def robots() -> None:
            async with site.connected() as (_, wm, _client):
                await add_robots(wm, [AGENT])

        anyio.run(robots)
        yield site


async def cli(site: Site, *args: str) -> str:
    done = await anyio.to_thread.run_sync(site.skimesh, *args)
    assert done.returncode == 0, f"skimesh {' '.join(args)}: {done.stdout}{done.stderr}"
    return done.stdout


async def cli_json(site: Site, *args: str) -> Any:
    return json.loads(await cli(site, *args, "--json"))


async def all_lines(child: Child, timeout: float = 60.0) -> list[str]:
    """Every stdout line of ``child`` until it exits."""

    def read() -> list[str]:
        lines: list[str] = []
        while True:
            try:
                line = child.stdout.get(timeout=timeout)
            except queue.Empty:
                why = f"{child.name}: no output in {timeout} s:\n{child.log()}"
                raise AssertionError(why) from None
            if line is None:
                return lines
            lines.append(line.rstrip("\n"))

    return await anyio.to_thread.run_sync(read)


async def wait_for(
    events: list[TaskEvent], changed: list[anyio.Event], kind: type, step: int
) -> Any:
    with anyio.fail_after(30):
        while True:
            for e in events:
                if isinstance(e, kind) and getattr(e, "step", None) == step:
                    return e
            changed[0] = anyio.Event()
            await changed[0].wait()


async def test_watch_a_paused_task_from_its_start_then_resume_it(hist_site: Site) -> None:
    s, task_id = hist_site, new_task_id()
    flags = s.flags()
    async with s.connected() as (_, _wm, client), anyio.create_task_group() as tg:
        events: list[TaskEvent] = []
        changed = [anyio.Event()]

        def seen(event: TaskEvent) -> None:
            events.append(event)
            changed[0].set()

        async def run() -> None:
            await client.run_goal(
                f"contain(kit-{AGENT}, gear-9)", task_id=task_id, on_event=seen, deadline=120
            )

        tg.start_soon(run)
        first = await wait_for(events, changed, StepStarted, 0)
        assert first.agent == AGENT, first
        run_id = first.run_id

        # the run first, by hand; then the whole task (its run is paused already)
        assert "paused" in await cli(s, "pause", AGENT, run_id)
        info = (await cli(s, "runs", AGENT, run_id, "--json")).splitlines()
        assert json.loads(info[0])["state"] == "paused"
        assert "paused: no new step starts" in await cli(s, "task", "pause", task_id)
        follower = Child(["-m", "skimesh", "runs", AGENT, run_id, "--follow", "--json", *flags],
                         name="runs --follow")  # fmt: skip
        assert "resumed" in await cli(s, "resume", AGENT, run_id)  # step 0 may end now
        await wait_for(events, changed, StepFinished, 0)

        watch_json = Child(["-m", "skimesh", "task", "watch", task_id, "--json", *flags],
                           name="task watch --json")  # fmt: skip
        watch_lines = Child(["-m", "skimesh", "task", "watch", task_id, *flags], name="task watch")
        try:
            history = [
                await anyio.to_thread.run_sync(watch_json.expect, lambda _: True) for _ in range(3)
            ]
            assert [h["seq"] for h in history] == [1, 2, 3], history
            assert [h["event"] for h in history] == ["TaskStarted", "Planned", "StepStarted"]
            status = await cli_json(s, "task", "status", task_id)
            assert status["outcome"] == "running" and status["paused"], status
            # the watcher started, read the history and followed for a while: still held
            assert [e.step for e in events if isinstance(e, StepStarted)] == [0]
            listed = await cli_json(s, "runs", AGENT)
            mine = [r for r in listed if r["run_id"] == run_id]
            assert mine and mine[0]["state"] == "succeeded" and mine[0]["skill"] == "navigate"

            assert "resumed" in await cli(s, "task", "resume", task_id)
            rest = await all_lines(watch_json)
            lines = await all_lines(watch_lines)
        finally:
            for child in (watch_json, watch_lines):
                child.stop()
        followed = await all_lines(follower)
        assert follower.stop() == 0, follower.log()

    done = events[-1]
    assert isinstance(done, TaskFinished) and done.outcome == "succeeded", done
    watched = [*history, *(json.loads(line) for line in rest)]
    assert (
        [w["seq"] for w in watched] == [e.seq for e in events] == list(range(1, len(events) + 1))
    ), "the watcher missed or repeated events"
    kinds = [w["event"] for w in watched]
    assert "TaskPaused" in kinds and "TaskResumed" in kinds
    resumed = kinds.index("TaskResumed")
    assert all(k != "StepStarted" for k in kinds[kinds.index("TaskPaused") : resumed])
    assert "StepStarted" in kinds[resumed:]

    # the line output: the plan first, the step already run, times from the task's start
    t0 = events[0].stamp
    assert lines[0] == f"task {task_id}: " + events[0].goal, lines[:3]  # type: ignore[union-attr]
    assert lines[1].startswith("plan 0 "), lines[:3]
    started = f"{first.stamp - t0:7.2f}s  {AGENT:<10} step 0   navigate   started"
    assert started in lines, lines
    assert any(re.search(r"paused \(paused from the command line\)", line) for line in lines)
    assert any(line.startswith(f"task {task_id} succeeded in ") for line in lines), lines

    # the run's history, then its end, each event once
    head, *run_events = (json.loads(line) for line in followed)
    assert head["run_id"] == run_id and head["skill"] == "navigate"
    seqs = [e["seq"] for e in run_events]
    assert seqs == sorted(set(seqs)) and seqs[0] == 1, seqs
    assert run_events[-1]["event"] == "RunResult" and run_events[-1]["success"]
    states = [e.get("state") for e in run_events]
    assert "paused" in states, states
