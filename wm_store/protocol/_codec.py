"""Decoders of the store's requests, replies and changes (:class:`meshlink.rpc.Decoder`, built
once): every way bytes can fail to decode raises one :class:`meshlink.rpc.WireError`. Encoding
is :func:`meshlink.rpc.encode`."""

from __future__ import annotations

from meshlink.rpc import Decoder
from wm_store.protocol._changes import Change
from wm_store.protocol._replies import Reply
from wm_store.protocol._requests import Request

_request: Decoder[Request] = Decoder(Request, what="request")
_reply: Decoder[Reply] = Decoder(Reply, what="reply")
_change: Decoder[Change] = Decoder(Change, what="change")


def decode_request(data: bytes) -> Request:
    """The request in ``data``; raises :class:`~meshlink.rpc.WireError` on bad bytes."""
    return _request.decode(data)


def decode_reply(data: bytes) -> Reply:
    """The reply in ``data``; raises :class:`~meshlink.rpc.WireError` on bad bytes."""
    return _reply.decode(data)


def decode_change(data: bytes) -> Change:
    """The change in ``data``; raises :class:`~meshlink.rpc.WireError` on bad bytes."""
    return _change.decode(data)
