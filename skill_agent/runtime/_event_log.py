"""The agent's structured event log (FRIEND II's event-logging server).

Every run started, progress event, result, refused start and world-model write the runtime
makes is recorded as one :data:`~skill_agent.protocol.LogEntry` (a tagged msgspec Struct, tag
field ``kind``; wire schema in :mod:`skill_agent.protocol`). The log keeps a bounded in-memory
history, calls in-process subscribers, and, when given a path, appends one JSON object per line
to that file for offline analysis::

    log = EventLog(Path("events.jsonl"))
    ...
    for entry in EventLog.read(Path("events.jsonl")):
        match entry:
            case ResultEntry(result=r): print(r.run_id, r.reason)

On the mesh, :func:`~skill_agent.server.serve_agent` subscribes its publisher to the log: every
entry goes out on ``agents/<agent>/events`` (MessagePack, congestion control BLOCK), read with
:class:`~skill_agent.client.EventFeed`.

:meth:`EventLog.record` never blocks the loop for long: a line is a buffered write flushed at
once (no fsync), a few microseconds; subscriber callbacks run inline and must be quick (the
mesh publisher only queues the entry; their exceptions are logged, never raised into the run
that produced the event).
"""

from __future__ import annotations

import logging
import time
from collections import deque
from collections.abc import Callable, Iterator
from pathlib import Path
from types import TracebackType
from typing import IO

import msgspec

from skill_agent.protocol._log import (
    LogEntry,
    ProgressEntry,
    RefusedEntry,
    ResultEntry,
    RunStartedEntry,
    WmWriteEntry,
)

__all__ = [
    "EventLog",
    "LogEntry",
    "ProgressEntry",
    "RefusedEntry",
    "ResultEntry",
    "RunStartedEntry",
    "WmWriteEntry",
    "entry_agent",
    "entry_run",
]

_log = logging.getLogger(__name__)
_encoder = msgspec.json.Encoder()
_decoder = msgspec.json.Decoder(LogEntry)


def entry_agent(entry: LogEntry) -> str:
    """The agent that recorded ``entry``."""
    if isinstance(entry, ProgressEntry):
        return entry.progress.agent
    if isinstance(entry, ResultEntry):
        return entry.result.agent
    return entry.agent


def entry_run(entry: LogEntry) -> str:
    """The run ``entry`` is about (``""``: a start refused before the run had an id)."""
    if isinstance(entry, ProgressEntry):
        return entry.progress.run_id
    if isinstance(entry, ResultEntry):
        return entry.result.run_id
    return entry.run_id


class EventLog:
    """Bounded history + subscribers + optional JSON-lines file. Not shared between agents
    unless you pass the same instance; no global state."""

    def __init__(self, path: Path | None = None, *, history: int = 1000) -> None:
        self.path = path
        self._history: deque[LogEntry] = deque(maxlen=history)
        self._subscribers: list[Callable[[LogEntry], None]] = []
        self._file: IO[bytes] | None = None
        if path is not None:
            path.parent.mkdir(parents=True, exist_ok=True)
            self._file = path.open("ab")

    def record(self, entry: LogEntry) -> None:
        """Add an entry (its ``stamp`` is set to now if 0). Quick; never raises for a failing
        subscriber or file (those are logged)."""
        if not entry.stamp:
            entry.stamp = time.time()
        self._history.append(entry)
        if self._file is not None:
            try:
                self._file.write(_encoder.encode(entry) + b"\n")
                self._file.flush()
            except OSError:
                _log.exception("could not append to the event log %s", self.path)
        for callback in list(self._subscribers):
            try:
                callback(entry)
            except Exception:
                _log.exception("an event-log subscriber failed")

    def subscribe(self, callback: Callable[[LogEntry], None]) -> Callable[[], None]:
        """Call ``callback(entry)`` for every later entry; returns the unsubscribe function."""
        self._subscribers.append(callback)

        def unsubscribe() -> None:
            if callback in self._subscribers:
                self._subscribers.remove(callback)

        return unsubscribe

    def history(self) -> list[LogEntry]:
        """The most recent entries, oldest first."""
        return list(self._history)

    def close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None

    def __enter__(self) -> EventLog:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    @staticmethod
    def read(path: Path) -> Iterator[LogEntry]:
        """Decode a log file written by :class:`EventLog` (a torn last line is skipped)."""
        with path.open("rb") as file:
            for line in file:
                if not line.strip():
                    continue
                try:
                    yield _decoder.decode(line)
                except msgspec.DecodeError:
                    _log.warning("skipped an undecodable event-log line in %s", path)
