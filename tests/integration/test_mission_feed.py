"""The mission feed over real Zenoh (loopback router, unique mesh), the path ``skimesh demo``
and ``skimesh monitor`` record tasks through: joined while a task is held in its middle, it
finds the task (the task agent's list), records its kept history from seq 1, then its live
events to the end, each once and in order, each at its own time (the history before the
recording began); the agent's event log lands beside it. Joined after
the task's end, it records the task from its history only when asked to (``recent``)."""

from __future__ import annotations

import uuid
from pathlib import Path

import anyio
import pytest
import rerun as rr

from meshlink import MeshConfig, open_mesh
from skimesh.recording import MissionFeed, MissionRecording
from task_agent import TaskClient, new_task_id
from task_agent.protocol import StepFinished, TaskEvent, TaskFinished, TaskStarted

from .rrd import chunks, column
from .services import AGENT, running_services

pytestmark = [pytest.mark.zenoh, pytest.mark.anyio]

CALL = f'\n[[root.children]]\nblock = "call"\nagent = "{AGENT}"\nskill = "noop"\n'
TASK = 'name = "noop four times"\n\n[root]\nblock = "sequence"\n' + CALL * 4


async def test_a_feed_joined_mid_task_records_it_from_seq_1_each_event_once(
    router_endpoint: str, tmp_path: Path
) -> None:
    config = MeshConfig(connect=(router_endpoint,), mesh=f"feed-{uuid.uuid4().hex[:8]}")
    async with (
        running_services(config, tmp_path / "wm", devices=False) as services,
        open_mesh(config) as monitor,
    ):
        client = TaskClient(services.mesh, timeout=10.0)
        task_id = new_task_id()
        async with client.watch(task_id, existing=False) as events:
            await client.submit_file(TASK, task_id=task_id)
            async for event in events:
                if isinstance(event, StepFinished):
                    break
        await client.pause(task_id)  # held in its middle: no new step starts
        before = len((await client.history(task_id)).events)

        rec = rr.RecordingStream("skimesh-test")
        rec.set_sinks(rr.FileSink(str(tmp_path / "feed.rrd")))
        recording = MissionRecording(rec, sim_clock=lambda: 0.0, label_of=str)
        seen: list[TaskEvent] = []
        caught_up = anyio.Event()  # the history before the hold is recorded

        def take(event: TaskEvent) -> None:
            seen.append(event)
            if len(seen) >= before:
                caught_up.set()

        feed = MissionFeed(recording, on_event=take)
        async with anyio.create_task_group() as tg:
            await tg.start(feed.run, monitor)
            with anyio.fail_after(20):
                await caught_up.wait()
            await client.resume(task_id)
            with anyio.fail_after(30):
                await feed.wait_ended(task_id)
            tg.cancel_scope.cancel()
        rec.flush()
        rec.disconnect()

        # after its end: recorded from its history only when asked for (recent), else not
        later: dict[float, list[TaskEvent]] = {0.0: [], 600.0: []}
        for recent, got in later.items():
            quiet = MissionRecording(
                rr.RecordingStream("skimesh-test"), sim_clock=float, label_of=str
            )
            after = MissionFeed(quiet, on_event=got.append, recent=recent)
            async with anyio.create_task_group() as tg:
                await tg.start(after.run, monitor)  # the tasks to follow found
                assert after.followed == ({task_id} if recent else set())
                if recent:
                    with anyio.fail_after(20):
                        await after.wait_ended(task_id)
                tg.cancel_scope.cancel()
        assert later[0.0] == []
        assert [e.seq for e in later[600.0]] == [e.seq for e in seen]

    assert feed.followed == {task_id}
    assert [e.seq for e in seen] == list(range(1, len(seen) + 1)), "from seq 1, each once"
    assert isinstance(seen[0], TaskStarted) and isinstance(seen[-1], TaskFinished)
    assert seen[-1].outcome == "succeeded"
    assert sum(isinstance(e, StepFinished) for e in seen) == 4
    assert f"agents/{AGENT}/events" in recording.agents.entities()
    wall_times = {  # each task event's line: its wall_time (s since the recording began)
        str(text): float(str(wall)) / 1e9
        for chunk in chunks(tmp_path / "feed.rrd")
        if str(chunk.entity_path) == "/task/events"
        for text, wall in zip(
            column(chunk, "TextLog:text"),
            chunk.to_record_batch().column("wall_time").cast("int64").to_pylist(),
            strict=True,
        )
    }
    started = [t for text, t in wall_times.items() if text.startswith(f"task {task_id} started")]
    ended = [t for text, t in wall_times.items() if text.startswith(f"task {task_id} succeeded")]
    assert len(started) == len(ended) == 1
    assert started[0] < 0.0 < ended[0], "the history at its own time, before the recording"
