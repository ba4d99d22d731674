"""How a :class:`~wm_store.client.WmClient` reaches a store: the transport interface and its two
implementations.

- :class:`InMemoryTransport` calls a :class:`~wm_store.service.WmService` in the same process
  (unit tests, the one-process demo). Messages still go through the MessagePack codec, so a
  schema bug shows up here as it would on the wire.
- :class:`ZenohTransport` talks to ``skimesh wm`` over Zenoh: transactions on ``wm/rpc``, every
  read on the read-only ``wm/query``, changes from ``wm/changes``.

Both raise :class:`~wm_store.errors.TransportError` when the store cannot be reached and turn an
error reply into the matching :class:`~wm_store.errors.WmError` subclass.
"""

from __future__ import annotations

import logging
import math
from collections.abc import AsyncIterator
from contextlib import AbstractAsyncContextManager, asynccontextmanager
from typing import Protocol

import anyio
import msgspec

from meshlink import Mesh, MeshlinkError, NoReplyError
from meshlink import RemoteError as MeshRemoteError

from .errors import ProtocolError, TransportError, error_for_code
from .protocol import (
    Change,
    ErrorReply,
    Reply,
    Request,
    Transact,
    decode_change,
    decode_reply,
    encode,
)
from .service import WmService

__all__ = ["InMemoryTransport", "WmTransport", "ZenohTransport", "raise_for_error"]

_log = logging.getLogger(__name__)


class WmTransport(Protocol):
    """What the client needs from a transport."""

    async def request(self, request: Request, *, timeout: float) -> Reply:
        """Send one request and return the reply (an :class:`ErrorReply` is returned as is)."""
        ...

    def changes(self) -> AbstractAsyncContextManager[AsyncIterator[Change]]:
        """An async context manager yielding the stream of published changes."""
        ...


def raise_for_error(reply: Reply) -> Reply:
    """Raise the local exception for an :class:`ErrorReply`; return any other reply."""
    if isinstance(reply, ErrorReply):
        raise error_for_code(reply.code, reply.message)
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


class ZenohTransport:
    """Transport over a meshlink :class:`~meshlink.Mesh` session."""

    def __init__(self, mesh: Mesh) -> None:
        self.mesh = mesh

    async def request(self, request: Request, *, timeout: float) -> Reply:
        keys = self.mesh.keys
        key = keys.wm_rpc() if isinstance(request, Transact) else keys.wm_query()
        try:
            data = await self.mesh.request(key, encode(request), timeout=timeout)
        except MeshRemoteError as exc:
            data = exc.payload
        except NoReplyError as exc:
            raise TransportError(
                f"the world-model store did not answer on {key} within {timeout} s: is "
                "`skimesh wm` running on this mesh, and does the ACL allow this client?"
            ) from exc
        except MeshlinkError as exc:
            raise TransportError(str(exc)) from exc
        try:
            return decode_reply(data)
        except (msgspec.DecodeError, msgspec.ValidationError) as exc:
            raise ProtocolError(f"undecodable reply from the store: {exc}") from exc

    @asynccontextmanager
    async def changes(self) -> AsyncIterator[AsyncIterator[Change]]:
        async with self.mesh.subscribe(self.mesh.keys.wm_changes()) as subscription:
            yield _decode_changes(subscription)


async def _decode_changes(samples: AsyncIterator[object]) -> AsyncIterator[Change]:
    async for sample in samples:
        payload = getattr(sample, "payload", b"")
        try:
            change = decode_change(payload)
        except (msgspec.DecodeError, msgspec.ValidationError) as exc:
            # A change we cannot read is a gap: the replica resyncs on the next revision.
            _log.warning("skipped an undecodable change: %s", exc)
            continue
        yield change
