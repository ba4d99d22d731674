"""Run events and event-log entries onto the mesh, in order, in bursts."""

from __future__ import annotations

import logging
from collections.abc import Callable

import anyio
import anyio.lowlevel

from meshlink import Mesh, MeshlinkError
from meshlink.rpc import encode
from skill_agent.protocol._log import LogEntry
from skill_agent.protocol._runs import (
    RunEvent,
    RunResult,
)
from skill_agent.runtime._agent import AgentCore

__all__ = ["RunEventPublisher"]

_log = logging.getLogger(__name__)


class RunEventPublisher:
    """Publishes run events on ``agents/<a>/runs/<run>/progress`` and event-log entries on
    ``agents/<a>/events``, in order, in bursts.

    A Zenoh put after the session was idle for a moment costs far more than puts back to back
    (the wake-up of Zenoh's send path; see docs/benchmarks.md, section Skills, "Why the 3x
    target is not met"). So progress events and log entries wait (at most ``max_delay``
    seconds) and go out together, and a :class:`RunResult` sends everything pending at once,
    itself last, in the loop's next turn (after a ``call``'s reply, which carries the same
    result, has gone out): a short run's seven events cost about one put, and no result waits
    for ``max_delay``.
    :meth:`publish` and :meth:`record` only queue (they are called inline by the core and its
    event log)."""

    def __init__(self, mesh: Mesh, agent: str, *, max_delay: float = 0.002) -> None:
        self.mesh = mesh
        self.agent = agent
        self.max_delay = max_delay
        self._events_key = mesh.keys.agent_events(agent)
        self._pending: list[tuple[str, bytes]] = []
        self._wake = anyio.Event()
        self._result = anyio.Event()  # a result is pending: no waiting for company

    def attach(self, core: AgentCore) -> Callable[[], None]:
        """Publish ``core``'s run events and its event log; returns the detach function."""
        detach_events = core.subscribe(self.publish)
        detach_log = core.events.subscribe(self.record)

        def detach() -> None:
            detach_events()
            detach_log()

        return detach

    def record(self, entry: LogEntry) -> None:
        """Queue an event-log entry (an :class:`EventLog` subscriber, on the loop)."""
        self._pending.append((self._events_key, encode(entry)))
        self._wake.set()

    def publish(self, event: RunEvent) -> None:
        """Queue ``event`` (from the core's subscriber callback, on the loop)."""
        try:
            key = self.mesh.keys.run_progress(self.agent, event.run_id)
        except ValueError as e:
            _log.warning("cannot publish run %r: %s", event.run_id, e)
            return
        self._pending.append((key, encode(event)))
        if isinstance(event, RunResult):
            self._result.set()
        self._wake.set()

    def flush(self) -> None:
        """Put every pending event now, in order (short synchronous Zenoh calls)."""
        batch, self._pending = self._pending, []
        for key, payload in batch:
            try:
                self.mesh.put(key, payload)
            except MeshlinkError as e:
                _log.warning("could not publish on %s: %s", key, e)

    async def run(self) -> None:
        """Flush progress events ``max_delay`` seconds after the first of a burst, and at once
        when a result comes: right after the tasks that were waiting for it (a ``call``'s or a
        stop's reply carries the same result) have taken their turn on the loop."""
        while True:
            await self._wake.wait()
            self._wake = anyio.Event()
            if not self._result.is_set():
                with anyio.move_on_after(self.max_delay):
                    await self._result.wait()
            if self._result.is_set():
                self._result = anyio.Event()
                await anyio.lowlevel.checkpoint()  # let a waiting reply go out first
            self.flush()
