"""Typed decoders of the skill layer's tagged unions, built once with :mod:`meshlink.rpc`'s
``Decoder`` (every failure is one :class:`~meshlink.rpc.WireError`); messages are encoded with
:func:`meshlink.rpc.encode`."""

from __future__ import annotations

from meshlink.rpc import Decoder
from skill_agent.protocol._log import LogEntry
from skill_agent.protocol._runs import AgentReply, AgentRequest, RunEvent

__all__ = [
    "decode_event",
    "decode_log_entry",
    "decode_reply",
    "decode_request",
]

_request: Decoder[AgentRequest] = Decoder(AgentRequest, what="request")
_reply: Decoder[AgentReply] = Decoder(AgentReply, what="reply")
_event: Decoder[RunEvent] = Decoder(RunEvent, what="run event")
_entry: Decoder[LogEntry] = Decoder(LogEntry, what="event-log entry")


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
