"""Reading agents' event logs over the mesh: :class:`EventFeed`.

Every agent publishes its :class:`~skill_agent.runtime.EventLog` on ``agents/<agent>/events``
(:mod:`skill_agent.server`); a feed subscribes to one agent's log or to every agent's
(``agents/*/events``) and yields each :data:`~skill_agent.protocol.LogEntry`, in the order
each agent recorded them::

    async with EventFeed.open(mesh) as feed:          # every agent; EventFeed.open(mesh, "r1")
        async for entry in feed:
            match entry:
                case WmWriteEntry(agent=a, run_id=r, revision=rev): print(a, r, "wrote", rev)
                case RefusedEntry(agent=a, code=code, message=m): print(a, "refused:", code, m)

A feed sees what is published while it is open (no history: the agent's JSON-lines file, the
``event_log`` key of its config, keeps that). A payload that is no log entry (another
publisher's garbage, a newer agent's unknown entry kind) is skipped and logged with its key
and the decoder's reason, and counted in :attr:`EventFeed.skipped`; it never ends the feed.
"""

from __future__ import annotations

import logging
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from typing import Self

import anyio

from meshlink import Mesh, Sample, Subscription
from meshlink.rpc import WireError
from skill_agent.protocol._codec import decode_log_entry
from skill_agent.protocol._log import LogEntry

__all__ = ["EventFeed"]

_log = logging.getLogger(__name__)


class EventFeed:
    """An async iterator of :data:`~skill_agent.protocol.LogEntry` (see the module doc).
    Iteration ends when the feed's context exits or the session closes."""

    def __init__(self, samples: Subscription[Sample]) -> None:
        self._samples = samples
        self.skipped = 0
        """Samples that were no log entry (undecodable, or a delete)."""

    @classmethod
    @asynccontextmanager
    async def open(cls, mesh: Mesh, agent: str | None = None) -> AsyncIterator[EventFeed]:
        """Subscribe to ``agent``'s event log (None: every agent's). On entry the subscription
        is known to the router: every entry published afterwards arrives.

        Raises:
            InvalidKeyError: ``agent`` is no valid name.
        """
        key = mesh.keys.agents_events() if agent is None else mesh.keys.agent_events(agent)
        async with mesh.subscribe(key) as samples:
            yield cls(samples)

    def decode(self, sample: Sample) -> LogEntry | None:
        """The entry ``sample`` carries, or None (skipped and logged) if it carries none."""
        if sample.kind != "put":
            self.skipped += 1
            _log.warning("skipped a %s sample on the event log %s", sample.kind, sample.key)
            return None
        try:
            return decode_log_entry(sample.payload)
        except WireError as e:
            self.skipped += 1
            _log.warning(
                "skipped an undecodable event-log entry on %s (%d bytes): %s",
                sample.key,
                len(sample.payload),
                e,
            )
            return None

    async def receive(self) -> LogEntry:
        """The next entry (waits). Raises ``anyio.EndOfStream`` once the feed ended."""
        while True:
            entry = self.decode(await self._samples.receive())
            if entry is not None:
                return entry

    def receive_nowait(self) -> LogEntry:
        """The next entry if one is waiting; else raises ``anyio.WouldBlock`` (or
        ``anyio.EndOfStream`` once the feed ended)."""
        while True:
            entry = self.decode(self._samples.receive_nowait())
            if entry is not None:
                return entry

    def __aiter__(self) -> Self:
        return self

    async def __anext__(self) -> LogEntry:
        try:
            return await self.receive()
        except anyio.EndOfStream:
            raise StopAsyncIteration from None
