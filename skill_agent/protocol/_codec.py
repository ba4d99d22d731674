"""MessagePack encoding of every message, and typed decoders of the tagged unions."""

from __future__ import annotations

from typing import Any

import msgspec

from skill_agent.protocol._log import LogEntry
from skill_agent.protocol._runs import AgentReply, AgentRequest, RunEvent

# --------------------------------------------------------------------------- codecs

_encoder = msgspec.msgpack.Encoder()
_request_decoder = msgspec.msgpack.Decoder(AgentRequest)
_reply_decoder = msgspec.msgpack.Decoder(AgentReply)
_event_decoder = msgspec.msgpack.Decoder(RunEvent)
_entry_decoder = msgspec.msgpack.Decoder(LogEntry)


def encode(message: Any) -> bytes:
    return _encoder.encode(message)


def decode_request(data: bytes) -> AgentRequest:
    return _request_decoder.decode(data)  # type: ignore[no-any-return]  # union decoder is untyped


def decode_reply(data: bytes) -> AgentReply:
    return _reply_decoder.decode(data)  # type: ignore[no-any-return]  # union decoder is untyped


def decode_event(data: bytes) -> RunEvent:
    return _event_decoder.decode(data)  # type: ignore[no-any-return]  # union decoder is untyped


def decode_log_entry(data: bytes) -> LogEntry:
    return _entry_decoder.decode(data)  # type: ignore[no-any-return]  # union decoder is untyped
