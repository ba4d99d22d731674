"""MessagePack encoding of every protocol Struct and the decoders of requests, replies and
changes."""

from __future__ import annotations

from typing import Any

import msgspec

from wm_store.protocol._changes import Change
from wm_store.protocol._replies import Reply
from wm_store.protocol._requests import Request

# --------------------------------------------------------------------------- codecs
# Built once (msgspec perf tip); decoders are thread-safe.

_encoder = msgspec.msgpack.Encoder()
_request_decoder = msgspec.msgpack.Decoder(Request)
_reply_decoder = msgspec.msgpack.Decoder(Reply)
_change_decoder = msgspec.msgpack.Decoder(Change)


def encode(message: Any) -> bytes:
    """Encode any protocol Struct to MessagePack."""
    return _encoder.encode(message)


def decode_request(data: bytes) -> Request:
    """Decode a request; raises ``msgspec.DecodeError`` / ``ValidationError`` on bad bytes."""
    return _request_decoder.decode(data)  # type: ignore[no-any-return]  # union decoder is untyped


def decode_reply(data: bytes) -> Reply:
    return _reply_decoder.decode(data)  # type: ignore[no-any-return]  # union decoder is untyped


def decode_change(data: bytes) -> Change:
    return _change_decoder.decode(data)
