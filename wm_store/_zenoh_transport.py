"""The Zenoh adapter of the client: :class:`ZenohTransport` talks to ``skimesh wm`` over a
meshlink :class:`~meshlink.Mesh`: transactions on ``wm/write/<author>`` (on ``wm/rpc`` when
they name no author, or one that is no key segment), every read on the read-only
``wm/query``, changes from ``wm/changes``.

It raises :class:`~wm_store.TransportError` when the store cannot be reached and returns an
error reply as is (the client turns it into the matching :class:`~wm_store.WmError` subclass).
:func:`wait_for_store` waits until a store answers (a service started before it).
"""

from __future__ import annotations

import logging
from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager

from meshlink import Backoff, InvalidKeyError, Mesh, MeshlinkError, NoReplyError
from meshlink import RemoteError as MeshRemoteError
from meshlink.rpc import WireError, encode
from wm_store._errors import ProtocolError, TransportError
from wm_store._transport import WmTransport
from wm_store.protocol import (
    Change,
    GetElements,
    Reply,
    Request,
    Transact,
    decode_change,
    decode_reply,
)

__all__ = ["ZenohTransport", "wait_for_store"]

_log = logging.getLogger(__name__)


class ZenohTransport:
    """Transport over a meshlink :class:`~meshlink.Mesh` session."""

    def __init__(self, mesh: Mesh) -> None:
        self.mesh = mesh

    async def request(self, request: Request, *, timeout: float) -> Reply:
        key = self._key(request)
        try:
            data = await self.mesh.request(key, encode(request), timeout=timeout)
        except MeshRemoteError as exc:
            data = exc.payload
        except NoReplyError as exc:
            raise TransportError(
                f"the world-model store did not answer on {key} {exc.when}: is "
                "`skimesh wm` running on this mesh, and does the ACL allow this client?"
            ) from exc
        except MeshlinkError as exc:
            raise TransportError(str(exc)) from exc
        try:
            return decode_reply(data)
        except WireError as exc:
            raise ProtocolError(f"undecodable reply from the store: {exc}") from exc

    def _key(self, request: Request) -> str:
        keys = self.mesh.keys
        if not isinstance(request, Transact):
            return keys.wm_query()
        try:
            return keys.wm_write(request.author) if request.author else keys.wm_rpc()
        except InvalidKeyError:
            return keys.wm_rpc()

    @asynccontextmanager
    async def changes(self) -> AsyncIterator[AsyncIterator[Change]]:
        async with self.mesh.subscribe(self.mesh.keys.wm_changes()) as subscription:
            yield _decode_changes(subscription)


async def _decode_changes(samples: AsyncIterator[object]) -> AsyncIterator[Change]:
    async for sample in samples:
        payload = getattr(sample, "payload", b"")
        try:
            change = decode_change(payload)
        except WireError as exc:
            # A change we cannot read is a gap: the replica resyncs on the next revision.
            _log.warning("skipped an undecodable change: %s", exc)
            continue
        yield change


async def wait_for_store(
    transport: WmTransport,
    *,
    timeout: float = 5.0,
    say: Callable[[float, TransportError], None] | None = None,
    every: float = 30.0,
) -> float:
    """Wait until the store answers a request: a service started before the store (or while
    it restarts) waits for it instead of failing. ``say(waited, error)`` is called when the
    wait begins and every ``every`` seconds after; returns the seconds waited. Cancel it
    (Ctrl-C, a deadline) to stop waiting."""
    backoff = Backoff(0.2, 2.0, every=every)
    while True:
        try:
            await transport.request(GetElements(ids=[]), timeout=timeout)
            return backoff.waited
        except TransportError as e:
            if say is not None and backoff.due():
                say(backoff.waited, e)
        await backoff.wait()
