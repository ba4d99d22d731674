"""The event log's records and its wire protocol (``skimesh/<mesh>/eventlog/rpc``).

Every record is flat, so the log can index and filter it without decoding the source message
(kept as JSON in ``data`` for offline analysis). Unions are tagged (``request``, ``reply``);
messages only gain fields with defaults.
"""

from __future__ import annotations

from typing import Annotated, Literal, TypeAlias

from msgspec import Meta, Struct

from meshlink.rpc import Decoder, ErrorReply

__all__ = [
    "KINDS",
    "EventFilter",
    "EventKind",
    "EventRecord",
    "EventsReply",
    "LogInfo",
    "LogInfoReply",
    "LogReply",
    "LogRequest",
    "QueryEvents",
    "decode_log_reply",
]

EventKind: TypeAlias = Literal["task", "run", "agent", "wm", "device"]
#: What each kind of record comes from.
KINDS: dict[str, str] = {
    "task": "a task's event (accepted, planned, step started / finished, replanning, finished)",
    "run": "a skill agent's event log (run started, progress, result, refused, world-model write)",
    "agent": "an agent's liveliness (alive, lost)",
    "wm": "a committed world-model change",
    "device": "a device's state change (moving / at rest, holding, door, heating)",
}


class EventRecord(Struct, frozen=True, kw_only=True):
    """One event of the site, as the event log keeps it.

    Attributes:
        seq: the log's own sequence number (1, 2, ...; 0 before the log stores the record).
        stamp: when it happened (seconds since the epoch), by the source's clock.
        kind: where it comes from: ``task``, ``run``, ``agent``, ``wm`` or ``device``.
        event: what it is, e.g. ``StepFinished``, ``result``, ``lost``, ``change``, ``moving``.
        robot: the agent or robot it concerns ("" when none).
        task: the task it belongs to ("" when none; runs are tied to their task's step).
        skill: the skill it concerns ("" when none).
        run: the skill run it concerns ("" when none).
        outcome: how it ended, for records that end something (``succeeded``, ``failed``,
            a task outcome, a refusal code); "" otherwise.
        text: one readable line.
        data: the source message as JSON.
    """

    seq: int = 0
    stamp: float
    kind: EventKind
    event: str
    robot: str = ""
    task: str = ""
    skill: str = ""
    run: str = ""
    outcome: str = ""
    text: str = ""
    data: str = ""


class EventFilter(Struct, frozen=True, kw_only=True):
    """Which records a query wants; every field given must match (empty: any).

    Attributes:
        since: records at or after this time (seconds since the epoch).
        until: records before this time.
        kinds: only these kinds.
        robot: only records of this agent or robot.
        task: only records of this task.
        skill: only records of this skill.
        outcome: only records with this outcome.
        text: only records whose text contains this (case-insensitive).
    """

    since: float | None = None
    until: float | None = None
    kinds: list[EventKind] = []
    robot: str = ""
    task: str = ""
    skill: str = ""
    outcome: str = ""
    text: str = ""


class QueryEvents(Struct, tag=True, tag_field="request", frozen=True, kw_only=True):
    """Records matching ``filter`` with ``seq > after``, oldest first, at most ``limit``.
    ``wait`` > 0: if none match yet, wait up to that long for one (a long poll, to follow)."""

    filter: EventFilter = EventFilter()
    after: Annotated[int, Meta(ge=0)] = 0
    limit: Annotated[int, Meta(ge=1, le=5000)] = 1000
    wait: Annotated[float, Meta(ge=0, le=60)] = 0.0


class LogInfo(Struct, tag=True, tag_field="request", frozen=True, kw_only=True):
    """What the log holds."""


LogRequest: TypeAlias = QueryEvents | LogInfo


class EventsReply(Struct, tag=True, tag_field="reply", frozen=True, kw_only=True):
    """``records`` in ``seq`` order; ``last_seq``: the log's newest record (match or not), the
    ``after`` to give next; ``more``: more matching records are stored past these."""

    records: list[EventRecord]
    last_seq: int
    more: bool = False


class LogInfoReply(Struct, tag=True, tag_field="reply", frozen=True, kw_only=True):
    """``count`` records from ``first_stamp`` to ``last_stamp``; ``wm_revision``: the newest
    world-model change it holds; ``path``: its file on the host that keeps it."""

    count: int
    last_seq: int
    first_stamp: float = 0.0
    last_stamp: float = 0.0
    wm_revision: int = 0
    path: str = ""


LogReply: TypeAlias = EventsReply | LogInfoReply | ErrorReply

_REPLIES: Decoder[LogReply] = Decoder(LogReply, what="event-log reply")


def decode_log_reply(data: bytes) -> LogReply:
    """Decode a reply of the event log (WireError if malformed)."""
    return _REPLIES.decode(data)
