"""MessagePack encoding of every message and typed decoders of the tagged unions, both from
:mod:`meshlink.rpc` (a decoder's every failure is one :class:`~meshlink.rpc.WireError`)."""

from __future__ import annotations

from meshlink import rpc
from meshlink.rpc import Decoder
from skill_agent.protocol._log import LogEntry
from skill_agent.protocol._runs import AgentReply, AgentRequest, RunEvent

__all__ = [
    "decode_event",
    "decode_log_entry",
    "decode_reply",
    "decode_request",
    "encode",
]

_request: Decoder[AgentRequest] = Decoder(AgentRequest, what="request")
_reply: Decoder[AgentReply] = Decoder(AgentReply, what="reply")
_event: Decoder[RunEvent] = Decoder(RunEvent, what="run event")
_entry: Decoder[LogEntry] = Decoder(LogEntry, what="event-log entry")


def encode(message: object) -> bytes:
    """:func:`meshlink.rpc.encode` (the skill layer's name for it)."""
    return rpc.encode(message)


def decode_request(data: bytes) -> AgentRequest:
    """Raises :class:`~meshlink.rpc.WireError` for bytes that are no request."""
    return _request.decode(data)


def decode_reply(data: bytes) -> AgentReply:
    """Raises :class:`~meshlink.rpc.WireError` for bytes that are no reply."""
    return _reply.decode(data)


def decode_event(data: bytes) -> RunEvent:
    """Raises :class:`~meshlink.rpc.WireError` for bytes that are no run event."""
    return _event.decode(data)


def decode_log_entry(data: bytes) -> LogEntry:
    """Raises :class:`~meshlink.rpc.WireError` for bytes that are no event-log entry."""
    return _entry.decode(data)
