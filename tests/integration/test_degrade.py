"""Degrade, never drop, over real Zenoh on loopback with every component in its own process
(store, two ``skimesh agent --simulate`` robots, ``skimesh task-agent``; in one test the router
too, ``skimesh router``):

- an agent killed with SIGKILL mid-task: the task ends ``partial``, the other robot's facts
  achieved, nothing left in its gripper, ``skimesh task watch`` exits 6 and says what was lost;
- the router process stopped mid-task and started again on the same port within 2 s: every
  process reconnects, the task agent follows the same runs, and the task succeeds.
"""

from __future__ import annotations

import os
import signal
import time
from collections.abc import Awaitable, Callable
from pathlib import Path

import anyio
import pytest

from meshlink.testing import free_port
from skimesh.errors import Exit
from task_agent import TaskClient, new_task_id
from task_agent.protocol import SafeState, StepFinished, StepStarted, TaskEvent, TaskFinished

from .test_cli_router import start_router
from .test_tasks import Site, place_robot, running_site

pytestmark = [pytest.mark.zenoh, pytest.mark.slow]


async def held(site: Site, robot: str) -> list[str]:
    """What the robot's gripper holds, in the world model."""
    async with site.connected() as (_, wm, _client):
        gripper = wm.resolve_element(type="Gripper", label=f"{robot}-gripper")[0].id
        return [r.object for r in wm.query_relation(gripper, "contain")]


async def run_goal(
    site: Site, goal: str, on_event: Callable[[TaskClient, TaskEvent], Awaitable[None]]
) -> list[TaskEvent]:
    """Robots r1 at station-1, r2 at station-2; ``goal`` submitted and followed to its end."""
    async with site.connected() as (_, wm, client):
        await place_robot(wm, "r1", "station-1")
        await place_robot(wm, "r2", "station-2")
        task_id, events = new_task_id(), list[TaskEvent]()
        async with client.watch(task_id, existing=False, deadline=120) as stream:
            await client.submit_goal(goal, task_id=task_id)
            async for event in stream:
                events.append(event)
                await on_event(client, event)
    return events


def test_killing_an_agent_mid_task_ends_partial(module_router: str, tmp_path: Path) -> None:
    with running_site(module_router, tmp_path) as site:

        async def kill_r2(_client: TaskClient, event: TaskEvent) -> None:
            if isinstance(event, StepStarted) and event.agent == "r2":
                os.kill(site.agents["r2"].pid, signal.SIGKILL)

        goal = "contain(kit-r1, gear-1) and contain(kit-r1, gear-3) and contain(kit-r2, gear-2)"
        events = anyio.run(run_goal, site, goal, kill_r2)
        site.agents["r2"].kill()
        done = events[-1]
        assert isinstance(done, TaskFinished) and done.outcome == "partial", done
        assert done.partial is not None
        assert done.partial.achieved == ["contain(kit-r1, gear-1)", "contain(kit-r1, gear-3)"]
        assert [f.fact for f in done.partial.lost] == ["contain(kit-r2, gear-2)"]
        assert [a.agent for a in done.partial.lost_agents] == ["r2"]
        assert done.partial.lost_agents[0].step >= 0
        assert anyio.run(held, site, "r1") == []
        watched = site.skimesh("task", "watch", done.task_id)
        assert watched.returncode == Exit.PARTIAL, watched.stdout + watched.stderr
        assert "lost:     contain(kit-r2, gear-2)" in watched.stdout, watched.stdout


def test_an_abort_while_a_robot_holds_a_part_puts_it_down(
    module_router: str, tmp_path: Path
) -> None:
    with running_site(module_router, tmp_path, time_scale=0.2) as site:

        async def abort_when_held(client: TaskClient, event: TaskEvent) -> None:
            if isinstance(event, StepFinished) and event.skill == "pick" and event.success:
                await client.abort(event.task_id, "test abort while holding")

        goal = "contain(kit-r1, gear-1) and contain(kit-r1, gear-3)"
        events = anyio.run(run_goal, site, goal, abort_when_held)
        done = events[-1]
        assert isinstance(done, TaskFinished) and done.outcome == "aborted", done
        [safe] = [e for e in events if isinstance(e, SafeState)]
        assert safe.agent == "r1" and safe.ok and safe.holding, safe
        assert anyio.run(held, site, "r1") == []
        watched = site.skimesh("task", "watch", done.task_id)
        assert watched.returncode == Exit.ABORTED, watched.stdout + watched.stderr
        assert f"safe state r1: put down {safe.holding[0]}" in watched.stdout, watched.stdout


def test_a_router_restart_mid_task_ends_in_success(tmp_path: Path) -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    routers = [start_router("--listen", endpoint, name="router")]
    try:
        with running_site(endpoint, tmp_path, time_scale=0.3) as site:  # a pick: 1.2 s
            outage: list[float] = []

            def restart() -> None:
                stopped = time.monotonic()
                assert routers[-1].stop() == 0, routers[-1].log()
                routers.append(start_router("--listen", endpoint, name="router"))
                outage.append(time.monotonic() - stopped)

            async def restart_once(_client: TaskClient, event: TaskEvent) -> None:
                if not outage and isinstance(event, StepStarted):
                    await anyio.to_thread.run_sync(restart)

            goal = "contain(kit-r1, gear-1) and contain(kit-r2, gear-2)"
            events = anyio.run(run_goal, site, goal, restart_once)
            done, story = events[-1], "\n".join(map(str, events))
            assert isinstance(done, TaskFinished) and done.outcome == "succeeded", story
            # the router is back within 2 s (a loaded machine may start its process slower)
            assert outage and outage[0] < 5.0, outage
            failed = [e for e in events if isinstance(e, StepFinished) and not e.success]
            assert not [e for e in failed if e.reason == "agent_lost"], story
    finally:
        for router in routers:
            router.stop()
