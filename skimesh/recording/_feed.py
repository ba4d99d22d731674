"""The mesh into the mission recording: every task's events and every agent's event log.

:class:`MissionFeed` is the one path by which ``skimesh demo`` and ``skimesh monitor`` fill a
:class:`~skimesh.recording.MissionRecording` from the mesh:

- **tasks**: it subscribes to every task's events (``tasks/*/events``) and, once subscribed,
  asks the task agent for the tasks running now (a monitor started mid-task) and, with
  ``recent``, those that ended within the last ``recent`` seconds; each task, found
  either way, is followed by :meth:`task_agent.TaskClient.watch`, which fetches the events the
  task agent kept (``TaskHistory``: from ``TaskStarted`` and the plan, seq 1) and then follows
  the live ones, each ``seq`` once. The wildcard subscription only discovers tasks;
- **agents**: every agent's event log (:func:`~skimesh.recording.record_agent_events`);
- **world model**: changes come from the caller's client (``wm.on_change(recording.
  wm_change)``): the demo hooks it as its client connects, to record the scene's first change.

A task whose task agent stops answering is dropped with a warning and found again by its next
event.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable

import anyio
from anyio.abc import TaskGroup, TaskStatus

from meshlink import Mesh
from meshlink.rpc import WireError
from task_agent import TaskClient, TaskError
from task_agent.protocol import TaskEvent, TaskFinished, decode_event

from ._agents import record_agent_events
from ._mission import MissionRecording

__all__ = ["MissionFeed"]

_log = logging.getLogger(__name__)


class MissionFeed:
    """Follows the mesh into ``recording`` (see the module doc). ``on_event``: called with
    each task event after it is recorded (e.g. a terminal view); ``recent``: seconds back in
    which an ended task is still recorded from its history (its end time on the task agent's
    clock, compared with this host's)."""

    def __init__(
        self,
        recording: MissionRecording,
        *,
        on_event: Callable[[TaskEvent], object] | None = None,
        timeout: float = 5.0,
        recent: float = 0.0,
    ) -> None:
        self.recording = recording
        self.recent = recent
        self.on_event = on_event
        self.timeout = timeout
        self.followed: set[str] = set()
        """Tasks followed now or before."""
        self.events = 0
        """Task events recorded."""
        self._ended: dict[str, anyio.Event] = {}
        self._last_seq: dict[str, int] = {}  # a task followed again skips what it recorded

    def _ended_event(self, task_id: str) -> anyio.Event:
        return self._ended.setdefault(task_id, anyio.Event())

    async def wait_ended(self, task_id: str) -> None:
        """Return once ``task_id``'s ``TaskFinished`` is recorded."""
        await self._ended_event(task_id).wait()

    async def run(
        self, mesh: Mesh, *, task_status: TaskStatus[None] = anyio.TASK_STATUS_IGNORED
    ) -> None:
        """Follow until cancelled; ``started`` once every subscription is in place and the
        tasks running then are found (their history is being fetched; a task agent that does
        not answer delays it by ``timeout``)."""
        client = TaskClient(mesh, timeout=self.timeout)
        async with anyio.create_task_group() as tg:
            await tg.start(record_agent_events, mesh, self.recording.agents)
            await tg.start(self._tasks, mesh, client)
            task_status.started()

    async def _tasks(
        self, mesh: Mesh, client: TaskClient, *, task_status: TaskStatus[None]
    ) -> None:
        async with (
            anyio.create_task_group() as tg,
            mesh.subscribe(mesh.keys.tasks_events()) as samples,
        ):
            await self._running(tg, client)
            task_status.started()
            async for sample in samples:
                if sample.kind != "put":
                    continue
                try:
                    task_id = decode_event(sample.payload).task_id
                except WireError as e:
                    _log.warning("undecodable task event on %s: %s", sample.key, e)
                    continue
                self._follow(tg, client, task_id)

    async def _running(self, tg: TaskGroup, client: TaskClient) -> None:
        """The tasks running now and those ended within ``recent`` s (none when no task agent
        answers: new ones are found by their events)."""
        try:
            tasks = await client.list(active_only=self.recent <= 0)
        except TaskError as e:  # e.g. an ACL that keeps tasks/rpc from this user
            _log.warning("running tasks not listed (%s): tasks are followed from their events", e)
            return
        since = time.time() - self.recent
        for info in tasks:
            if info.outcome == "running" or info.finished_at >= since:
                self._follow(tg, client, info.task_id)

    def _follow(self, tg: TaskGroup, client: TaskClient, task_id: str) -> None:
        if task_id and task_id not in self.followed:
            self.followed.add(task_id)
            tg.start_soon(self._watch, client, task_id)

    async def _watch(self, client: TaskClient, task_id: str) -> None:
        try:
            async with client.watch(task_id) as events:
                async for event in events:
                    if event.seq <= self._last_seq.get(task_id, 0):
                        continue
                    self._last_seq[task_id] = event.seq
                    self.recording.task_event(event)
                    self.events += 1
                    if self.on_event is not None:
                        self.on_event(event)
                    if isinstance(event, TaskFinished):
                        _log.info("task %s ended %s: recorded", task_id, event.outcome)
                        self._ended_event(task_id).set()
        except TaskError as e:
            _log.warning("stopped following task %s: %s", task_id, e)
            self.followed.discard(task_id)  # found again by its next event
