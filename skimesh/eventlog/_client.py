"""Reading the site event log from any host: :class:`EventLogClient`."""

from __future__ import annotations

from collections.abc import AsyncIterator

from meshlink import Mesh, MeshlinkError, NoReplyError, RemoteError
from meshlink.rpc import WireError, decode_error, encode

from ._errors import EventLogError
from ._records import (
    EventFilter,
    EventRecord,
    EventsReply,
    LogInfo,
    LogInfoReply,
    LogReply,
    LogRequest,
    QueryEvents,
    decode_log_reply,
)

__all__ = ["EventLogClient"]


class EventLogClient:
    """Queries the event log on ``mesh`` (``timeout``: per request, beside a long poll)."""

    def __init__(self, mesh: Mesh, *, timeout: float = 5.0) -> None:
        self.mesh, self.timeout = mesh, timeout

    async def info(self) -> LogInfoReply:
        reply = await self._ask(LogInfo())
        assert isinstance(reply, LogInfoReply)
        return reply

    async def query(
        self, where: EventFilter, *, after: int = 0, limit: int = 1000, wait: float = 0.0
    ) -> EventsReply:
        reply = await self._ask(
            QueryEvents(filter=where, after=after, limit=limit, wait=wait), extra=wait
        )
        assert isinstance(reply, EventsReply)
        return reply

    async def records(
        self, where: EventFilter, *, after: int = 0, follow: bool = False, poll: float = 10.0
    ) -> AsyncIterator[EventRecord]:
        """Every stored record matching ``where`` (page by page), then with ``follow`` each
        new one as it is stored, until the caller stops iterating."""
        while True:
            reply = await self.query(where, after=after, wait=0.0 if not follow else poll)
            for record in reply.records:
                yield record
            after = reply.records[-1].seq if reply.more else max(after, reply.last_seq)
            if not follow and not reply.more:
                return

    async def _ask(self, request: LogRequest, *, extra: float = 0.0) -> LogReply:
        key = self.mesh.keys.eventlog_rpc()
        try:
            data = await self.mesh.request(key, encode(request), timeout=self.timeout + extra)
        except RemoteError as e:
            message = decode_error(e.payload).message
            raise EventLogError(f"the event log refused the query: {message}") from None
        except NoReplyError as e:
            raise EventLogError(
                f"no event log answered on {key} {e.when}: is `skimesh eventlog` running on "
                f"mesh {self.mesh.keys.mesh!r}?"
            ) from None
        except MeshlinkError as e:
            raise EventLogError(f"event log: {e}") from e
        try:
            return decode_log_reply(data)
        except WireError as e:
            raise EventLogError(f"undecodable reply from the event log: {e}") from e
