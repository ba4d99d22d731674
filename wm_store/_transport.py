"""How a :class:`~wm_store.WmClient` reaches a store: the transport interface and the
in-process transport.

- :class:`WmTransport` is what the client needs: one request -> one reply, and the change stream.
- :class:`InMemoryTransport` calls a :class:`~wm_store.server.WmService` in the same process
  (unit tests, the one-process demo). Messages still go through the MessagePack codec, so a
  schema bug shows up here as it would on the wire.
- The Zenoh transport (:class:`~wm_store.ZenohTransport`, in its own adapter module) talks to
  ``skimesh wm`` over the mesh.

Both raise :class:`~wm_store.TransportError` when the store cannot be reached and turn an
error reply into the matching :class:`~wm_store.WmError` subclass.
"""

from __future__ import annotations

import logging
import math
from collections.abc import AsyncIterator
from contextlib import AbstractAsyncContextManager, asynccontextmanager
from typing import TYPE_CHECKING, Protocol

import anyio

from meshlink.rpc import encode
from meshlink.rpc import raise_for_error as raise_remote_error
from wm_store._errors import WM_CODES, remote_error
from wm_store.protocol import Change, Reply, Request, decode_change, decode_reply

if TYPE_CHECKING:
    from wm_store.server import WmService

__all__ = ["InMemoryTransport", "WmTransport", "raise_for_error"]

_log = logging.getLogger(__name__)


class WmTransport(Protocol):
    """What the client needs from a transport."""

    async def request(self, request: Request, *, timeout: float) -> Reply:
        """Send one request and return the reply (an error reply is returned as is)."""
        ...

    def changes(self) -> AbstractAsyncContextManager[AsyncIterator[Change]]:
        """An async context manager yielding the stream of published changes."""
        ...


def raise_for_error(reply: Reply) -> Reply:
    """Raise the local exception for an :class:`~meshlink.rpc.ErrorReply` (by its code,
    :data:`~wm_store._errors.WM_CODES`); return any other reply."""
    raise_remote_error(reply, WM_CODES, fallback=remote_error)
    return reply


class InMemoryTransport:
    """Same-process transport over a :class:`WmService`."""

    def __init__(self, service: WmService) -> None:
        self.service = service

    async def request(self, request: Request, *, timeout: float) -> Reply:
        with anyio.fail_after(timeout):
            data, _ok = await self.service.handle_bytes(encode(request))
        return decode_reply(data)

    @asynccontextmanager
    async def changes(self) -> AsyncIterator[AsyncIterator[Change]]:
        send, receive = anyio.create_memory_object_stream[Change](math.inf)

        def listener(_change: Change, payload: bytes) -> None:
            send.send_nowait(decode_change(payload))

        self.service.store.add_listener(listener)
        try:
            async with receive:
                yield receive
        finally:
            self.service.store.remove_listener(listener)
            send.close()
