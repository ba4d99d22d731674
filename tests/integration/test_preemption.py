"""Preemption over real Zenoh on loopback, every component in its own process (the set-up of
:func:`tests.integration.test_tasks.running_site`: store, agents r1 and r2 with simulated
outcomes, ``skimesh task-agent``; here each simulated run lasts 0.2 x its duration, a pick
0.8 s): a long low-priority task fills r1's kit box with four gears; once it has run a step, a
user on a session of their own submits a high-priority goal that also needs r1 (a gear into
r1's kit box). The low task gives way at a step boundary (no step of it running, no part left
in r1's gripper), ``task list`` says it was preempted by the high task, the high task runs and
ends first, then the low task takes r1 back, plans again and ends: both succeed, and r1 never
ran steps of the two tasks at once.
"""

from __future__ import annotations

from collections.abc import Iterator

import anyio
import pytest

from meshlink import MeshConfig, open_mesh
from task_agent import TaskClient
from task_agent.protocol import (
    StepFinished,
    TaskEvent,
    TaskFinished,
    TaskOptions,
    TaskPaused,
    TaskResumed,
)

from .test_tasks import Site, running_site, steps

pytestmark = [pytest.mark.zenoh, pytest.mark.slow, pytest.mark.anyio]

LOW = "contain(kit-r1, gear-1) and contain(kit-r1, gear-3) and contain(kit-r1, gear-5) and " \
      "contain(kit-r1, gear-7)"  # fmt: skip
HIGH = "contain(kit-r1, gear-2)"


@pytest.fixture(scope="module")
def slow_site(module_router: str, tmp_path_factory: pytest.TempPathFactory) -> Iterator[Site]:
    with running_site(module_router, tmp_path_factory.mktemp("preempt"), time_scale=0.2) as s:
        yield s


async def test_a_high_priority_task_preempts_a_low_one_at_a_step_boundary(
    slow_site: Site,
) -> None:
    config = MeshConfig(connect=(slow_site.endpoint,), mesh=slow_site.mesh)
    events: dict[str, list[TaskEvent]] = {"low": [], "high": []}
    results: dict[str, TaskFinished] = {}
    waiting_seen: list[str] = []
    ran = anyio.Event()

    def on_low(event: TaskEvent) -> None:
        events["low"].append(event)
        if isinstance(event, StepFinished):
            ran.set()

    async def user(name: str, goal: str, priority: int) -> None:
        async with open_mesh(config) as mesh:
            client = TaskClient(mesh, timeout=10.0)
            results[name] = await client.run_goal(
                goal,
                options=TaskOptions(priority=priority),
                task_id=f"{name}-{slow_site.mesh}",
                on_event=on_low if name == "low" else events[name].append,
                deadline=120,
            )

    async def watch_list() -> None:
        async with open_mesh(config) as mesh:
            client = TaskClient(mesh, timeout=10.0)
            while True:
                waiting_seen.extend(i.waiting for i in await client.list() if i.waiting)
                await anyio.sleep(0.05)

    async with anyio.create_task_group() as tg:
        tg.start_soon(watch_list)
        async with anyio.create_task_group() as users:
            users.start_soon(user, "low", LOW, 0)
            with anyio.fail_after(60):
                await ran.wait()
            users.start_soon(user, "high", HIGH, 5)
        tg.cancel_scope.cancel()

    low, high = results["low"], results["high"]
    assert low.outcome == high.outcome == "succeeded", (low.message, high.message)
    assert high.stamp < low.stamp, "the high-priority task ended first"
    assert low.replans == 0, f"giving way is no replan: {low.message}"
    paused = [e for e in events["low"] if isinstance(e, TaskPaused)]
    resumed = [e for e in events["low"] if isinstance(e, TaskResumed)]
    assert len(paused) == len(resumed) == 1, events["low"]
    assert f"preempted by task high-{slow_site.mesh} (priority 5)" in paused[0].reason
    assert any("preempted by task high" in w for w in waiting_seen), waiting_seen

    low_runs = steps(events["low"])
    before = [(s, f) for s, f in low_runs.values() if s.seq < paused[0].seq]
    assert before and all(f.seq < paused[0].seq for _, f in before), "a step ran at the pause"
    skills = [s.skill for s, _ in before]
    assert skills.count("pick") == skills.count("place"), f"r1 was left holding a part: {skills}"
    assert len(low_runs) > len(before), "the low task gave way before its end"
    high_spans = [(s.stamp, f.stamp) for s, f in steps(events["high"]).values()]
    assert high_spans and {s.agent for s, _ in steps(events["high"]).values()} == {"r1"}
    low_spans = [(s.stamp, f.stamp) for s, f in low_runs.values() if s.agent == "r1"]
    for a0, a1 in high_spans:
        for b0, b1 in low_spans:
            assert a1 <= b0 or b1 <= a0, f"r1 ran both tasks at once: {high_spans} {low_spans}"
