"""Following runs' progress from outside: :class:`RunFeed` and :func:`follow_run`.

A :class:`RunFeed` is one subscription to one run's or every run's progress of an agent, plus a
watch on the agent's liveliness token; it routes each event to the inbox of its run and tells
every inbox when the token disappears or comes back. :func:`follow_run` turns one inbox into the
run's events, ending with its result (the waits behind :meth:`AgentClient.run
<skill_agent.client.AgentClient.run>` and ``watch``).
"""

from __future__ import annotations

import logging
import math
from collections.abc import AsyncGenerator, AsyncIterator, Iterator
from contextlib import asynccontextmanager, contextmanager
from typing import TYPE_CHECKING

import anyio
from anyio.streams.memory import MemoryObjectReceiveStream, MemoryObjectSendStream

from meshlink import Liveness, Mesh, Sample, Subscription
from meshlink.rpc import WireError
from skill_agent._errors import AgentTransportError
from skill_agent.protocol._codec import decode_event
from skill_agent.protocol._runs import RunEvent, RunResult

if TYPE_CHECKING:
    from skill_agent.client._calls import AgentClient

__all__ = ["RunFeed", "follow_run"]

_log = logging.getLogger(__name__)


class RunFeed:
    """Routes one agent's progress events to per-run inboxes, and tells every inbox when the
    agent's liveliness token disappears or comes back (as :class:`~meshlink.Liveness`)."""

    def __init__(self) -> None:
        self._inboxes: dict[str, MemoryObjectSendStream[RunEvent | Liveness]] = {}

    @classmethod
    @asynccontextmanager
    async def open(
        cls, mesh: Mesh, agent: str, key: str, *, via: str | None = None
    ) -> AsyncIterator[RunFeed]:
        """Subscribe to ``key`` (one run's or every run's progress; ``via``: through a shared
        subscriber on that wildcard, see ``Mesh.subscribe``) and watch ``agent``."""
        feed = cls()
        try:
            async with (
                mesh.subscribe(key, via=via) as samples,
                mesh.watch_liveliness(mesh.keys.agent(agent)) as presence,
                anyio.create_task_group() as tg,
            ):
                tg.start_soon(feed._pump_events, samples)
                tg.start_soon(feed._pump_presence, presence)
                try:
                    yield feed
                finally:
                    tg.cancel_scope.cancel()
        except BaseExceptionGroup as group:  # the caller's error, not a group of ours
            if len(group.exceptions) == 1 and isinstance(group.exceptions[0], Exception):
                raise group.exceptions[0] from None
            raise

    @contextmanager
    def register(self, run_id: str) -> Iterator[MemoryObjectReceiveStream[RunEvent | Liveness]]:
        send, receive = anyio.create_memory_object_stream[RunEvent | Liveness](math.inf)
        self._inboxes[run_id] = send
        try:
            with receive:
                yield receive
        finally:
            del self._inboxes[run_id]
            send.close()

    async def _pump_events(self, samples: Subscription[Sample]) -> None:
        async for sample in samples:
            # ``.../runs/<run>/progress``: other clients' runs are skipped undecoded.
            inbox = self._inboxes.get(sample.key.rsplit("/", 2)[-2])
            if inbox is None:
                continue
            try:
                event = decode_event(sample.payload)
            except WireError as e:
                _log.warning("undecodable progress event on %s: %s", sample.key, e)
                continue
            inbox.send_nowait(event)

    async def _pump_presence(self, presence: Subscription[Liveness]) -> None:
        async for change in presence:
            for inbox in list(self._inboxes.values()):
                inbox.send_nowait(change)


async def follow_run(
    client: AgentClient, run_id: str, inbox: MemoryObjectReceiveStream[RunEvent | Liveness]
) -> AsyncGenerator[RunEvent, None]:
    """The events of ``run_id`` arriving in ``inbox``, ending with its :class:`RunResult`.

    When the inbox stays quiet for ``client.status_every`` seconds, or the agent's token comes
    back after a loss, the run's status is asked for (a result missed during a reconnect is
    found that way). The agent out of reach (its token gone, or its status not answered) is
    waited for up to ``client.lost_grace`` seconds, its status asked every
    ``status_every`` s meanwhile; longer raises :class:`AgentTransportError`, saying how long
    it was out of reach."""
    lost_since: float | None = None
    while True:
        now = anyio.current_time()
        if lost_since is not None and now - lost_since >= client.lost_grace:
            raise AgentTransportError(
                f"agent {client.agent!r} disappeared: out of reach for "
                f"{now - lost_since:.1f} s (its liveliness token gone or its status not "
                f"answered; grace "
                f"{client.lost_grace:g} s) while run {run_id} was running"
            )
        wait = client.status_every
        if lost_since is not None:
            wait = min(wait, lost_since + client.lost_grace - now)
        item: RunEvent | Liveness | None = None
        try:
            item = inbox.receive_nowait()  # a burst of events needs no timer each
        except anyio.WouldBlock:
            with anyio.move_on_after(wait):
                item = await inbox.receive()
        if isinstance(item, Liveness):
            if not item.alive:
                lost_since = lost_since if lost_since is not None else anyio.current_time()
                continue
            if lost_since is None:
                continue  # the first "alive" of the watch's history
        elif item is not None:
            yield item
            if isinstance(item, RunResult):
                return
            continue
        elif lost_since is not None and anyio.current_time() - lost_since >= client.lost_grace:
            continue  # out of reach too long: raised above
        # quiet, or back after a loss (router restart): a result may have been missed
        try:
            result = (await client.status(run_id)).result
        except AgentTransportError as e:
            if lost_since is None:
                lost_since = anyio.current_time()
            _log.info("run %s on %s: status not answered (%s); waiting", run_id, client.agent, e)
            continue
        lost_since = None
        if result is not None:
            yield result
            return
