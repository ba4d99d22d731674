"""The site event log over real Zenoh (loopback router, unique mesh): it records a task's
events, its runs (tied to the task), the agent's liveliness and the world model's changes,
answers filtered queries and long polls from another session, takes nothing but valid
requests, and after a restart on the same file fetches the world-model changes it missed,
each once."""

from __future__ import annotations

import functools
import uuid
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from pathlib import Path

import anyio
import pytest

from meshlink import Mesh, MeshConfig, RemoteError, open_mesh
from meshlink.rpc import BAD_REQUEST, decode_error
from skimesh.eventlog import EventFilter, EventLogClient, EventRecord, serve_event_log
from task_agent import TaskClient
from wm_store.protocol import AddElement, Transact

from .services import AGENT, running_services

pytestmark = [pytest.mark.zenoh, pytest.mark.anyio]

TASK = f"""
name = "noop twice"

[root]
block = "sequence"

[[root.children]]
block = "call"
agent = "{AGENT}"
skill = "noop"

[[root.children]]
block = "call"
agent = "{AGENT}"
skill = "noop"
"""


@asynccontextmanager
async def event_log(config: MeshConfig, path: Path) -> AsyncIterator[Mesh]:
    """The event log on a session of its own, recording into ``path`` while the block runs."""
    async with open_mesh(config) as mesh, anyio.create_task_group() as tg:
        await tg.start(functools.partial(serve_event_log, mesh, path))
        yield mesh
        tg.cancel_scope.cancel()


async def until(client: EventLogClient, where: EventFilter, count: int) -> list[EventRecord]:
    """The first ``count`` records matching ``where``, waiting for them (long polls)."""
    found: list[EventRecord] = []
    with anyio.fail_after(20):
        async for r in client.records(where, follow=True, poll=2.0):
            found.append(r)
            if len(found) >= count:
                return found
    raise AssertionError("unreachable")  # pragma: no cover


async def test_a_task_its_runs_and_the_world_model_land_in_one_log(
    router_endpoint: str, tmp_path: Path
) -> None:
    config = MeshConfig(connect=(router_endpoint,), mesh=f"evlog-{uuid.uuid4().hex[:8]}")
    path = tmp_path / "events.sqlite"
    async with (
        running_services(config, tmp_path / "wm", devices=False) as services,
        event_log(config, path),
        open_mesh(config) as reader,
    ):
        done = await TaskClient(services.mesh, timeout=10.0).run_file(TASK)
        assert done.outcome == "succeeded", done.message
        client = EventLogClient(reader, timeout=5.0)
        task = done.task_id
        (finished,) = await until(
            client, EventFilter(task=task, kinds=["task"], outcome="succeeded", text="after"), 1
        )
        assert finished.event == "TaskFinished"
        steps = await until(
            client, EventFilter(task=task, kinds=["task"], text="started: r1 noop"), 2
        )
        runs = {s.run for s in steps}
        assert len(runs) == 2 and all(s.robot == AGENT and s.skill == "noop" for s in steps)
        results = await until(client, EventFilter(task=task, kinds=["run"], outcome="succeeded"), 2)
        assert {r.run for r in results} == runs, "each run's result is tied to its task"
        assert (await client.query(EventFilter(robot="nobody"))).records == []
        alive = await until(client, EventFilter(kinds=["agent"], robot=AGENT), 1)
        assert alive[0].event == "alive"
        changes = await until(client, EventFilter(kinds=["wm"]), 1)
        assert changes[0].text.startswith("rev ")

        with pytest.raises(RemoteError) as refused:  # not a request: an error reply
            await reader.request(reader.keys.eventlog_rpc(), b"\xc1garbage", timeout=5.0)
        assert decode_error(refused.value.payload).code == BAD_REQUEST


async def test_after_a_restart_the_log_fetches_the_changes_it_missed_once(
    router_endpoint: str, tmp_path: Path
) -> None:
    config = MeshConfig(connect=(router_endpoint,), mesh=f"evlog-{uuid.uuid4().hex[:8]}")
    path = tmp_path / "events.sqlite"
    async with running_services(config, tmp_path / "wm", devices=False) as services:
        wm_store = services.store
        async with event_log(config, path) as mesh:
            client = EventLogClient(mesh)
            await until(client, EventFilter(kinds=["wm"], robot=AGENT), 1)  # its registration
            before = await client.info()
        # while the log is down: two changes it must not miss
        first = await wm_store.transact(
            Transact(ops=[AddElement(type="Gear", label="gear-missed-1")])
        )
        second = await wm_store.transact(
            Transact(ops=[AddElement(type="Gear", label="gear-missed-2")])
        )
        async with event_log(config, path) as mesh:
            client = EventLogClient(mesh)
            found = await until(client, EventFilter(kinds=["wm"], text="gear-missed"), 2)
            assert [
                f"rev {first.revision}" in found[0].text,
                f"rev {second.revision}" in found[1].text,
            ] == [True, True]
            every = [r async for r in client.records(EventFilter(kinds=["wm"]))]
            revisions = [r.text.split()[1] for r in every]
            assert len(revisions) == len(set(revisions)), "no change is recorded twice"
            assert (await client.info()).wm_revision == second.revision > before.wm_revision
