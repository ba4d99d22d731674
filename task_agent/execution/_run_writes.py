"""What the task's runs wrote to the world model, from the agents' event logs: :class:`RunWrites`.

Each agent publishes its event log on ``agents/<agent>/events``
(:class:`~skill_agent.client.EventFeed`); :meth:`RunWrites.follow` reads every agent's, and
the step scheduler watches the runs it starts. For a watched run it collects the revisions of
every world-model transaction the run made: its committed effects, a skill's own writes
(through ``ctx.transact`` or ``ctx.wm``: an observation, a measured pose, also in
``on_preempt``) and those of its sub-runs (composite skills: run ids ``<run>.<n>``). Each
``StepFinished`` carries them (``wm_writes``), and the executor
waits for its replica to show the newest before it checks the goal or replans, also for writes
that were no effects (``RunResult.effects_revision`` only names the effects' transaction).

A run's entries precede its result on the agent's side, but they arrive on their own
subscription: :meth:`RunWrites.revisions` waits (at most ``timeout`` seconds) for the run's own
result entry, and only for agents whose log was ever heard from (an agent that does not publish
one, or a router ACL that hides it, costs no wait). Entries of runs nobody watches are dropped
at once: the memory is bounded by the runs in flight.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field

import anyio
from anyio.abc import TaskStatus

from meshlink import Mesh
from skill_agent.client import EventFeed
from skill_agent.protocol import LogEntry, RefusedEntry, ResultEntry, WmWriteEntry
from skill_agent.runtime import entry_agent, entry_run

__all__ = ["RunWrites", "WatchedRun"]


@dataclass(eq=False)
class WatchedRun:
    """One run being watched: the revisions seen so far, and whether its log ended."""

    agent: str
    run_id: str
    revisions: list[int] = field(default_factory=list)
    ended: anyio.Event = field(default_factory=anyio.Event)


class RunWrites:
    """World-model writes of watched runs (see the module doc). Feed it every entry of the
    agents' logs (:meth:`feed`, or :meth:`follow` over the mesh); no global state."""

    def __init__(self) -> None:
        self._runs: dict[str, WatchedRun] = {}
        self._heard: set[str] = set()

    def heard_from(self, agent: str) -> bool:
        """True once an entry of ``agent``'s event log arrived."""
        return agent in self._heard

    def feed(self, entry: LogEntry) -> None:
        """Take one entry of any agent's log (quick; entries of unwatched runs are dropped)."""
        agent, run_id = entry_agent(entry), entry_run(entry)
        self._heard.add(agent)
        watched, root = None, run_id
        while root:  # a sub-run "<run>.<n>" counts for its top-level run
            watched = self._runs.get(root)
            if watched is not None or "." not in root:
                break
            root = root.rsplit(".", 1)[0]
        if watched is None or watched.agent != agent:
            return
        if isinstance(entry, WmWriteEntry):
            watched.revisions.append(entry.revision)
        elif isinstance(entry, ResultEntry | RefusedEntry) and run_id == watched.run_id:
            watched.ended.set()

    @contextmanager
    def watch(self, agent: str, run_id: str) -> Iterator[WatchedRun]:
        """Collect ``run_id``'s writes while the block runs; enter before starting the run."""
        watched = self._runs[run_id] = WatchedRun(agent, run_id)
        try:
            yield watched
        finally:
            del self._runs[run_id]

    async def revisions(self, watched: WatchedRun, *, timeout: float = 1.0) -> list[int]:
        """The revisions ``watched`` wrote, once its log ended (at most ``timeout`` s later;
        no wait for an agent never heard from)."""
        if self.heard_from(watched.agent):
            with anyio.move_on_after(timeout):
                await watched.ended.wait()
        return list(watched.revisions)

    async def follow(
        self, mesh: Mesh, *, task_status: TaskStatus[None] = anyio.TASK_STATUS_IGNORED
    ) -> None:
        """Feed every agent's event log from ``mesh`` until cancelled; ``started`` once
        subscribed."""
        async with EventFeed.open(mesh) as entries:
            task_status.started()
            async for entry in entries:
                self.feed(entry)
