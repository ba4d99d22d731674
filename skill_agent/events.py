"""The agent's structured event log (FRIEND II's event-logging server, in process).

Every run started, progress event, result, refused start and world-model write the runtime
makes is recorded as one :data:`LogEntry` (a tagged msgspec Struct, tag field ``kind``). The log
keeps a bounded in-memory history, calls in-process subscribers, and, when given a path,
appends one JSON object per line to that file for offline analysis::

    log = EventLog(Path("events.jsonl"))
    ...
    for entry in EventLog.read(Path("events.jsonl")):
        match entry:
            case ResultEntry(result=r): print(r.run_id, r.reason)

:meth:`EventLog.record` never blocks the loop for long: a line is a buffered write flushed at
once (no fsync), a few microseconds; subscriber callbacks run inline and must be quick (their
exceptions are logged, never raised into the run that produced the event).
"""

from __future__ import annotations

import logging
import time
from collections import deque
from collections.abc import Callable, Iterator
from pathlib import Path
from types import TracebackType
from typing import IO, TypeAlias

import msgspec

from wm_store.protocol import Op, Value

from .protocol import Progress, RunResult

__all__ = [
    "EventLog",
    "LogEntry",
    "ProgressEntry",
    "RefusedEntry",
    "ResultEntry",
    "RunStartedEntry",
    "WmWriteEntry",
]

_log = logging.getLogger(__name__)


class RunStartedEntry(msgspec.Struct, tag="run_started", tag_field="kind", kw_only=True):
    """A run was accepted (parameters specified, resources locked or queued)."""

    agent: str
    run_id: str
    skill: str
    params: dict[str, Value] = {}
    inferred: dict[str, str] = {}
    resources: list[str] = []
    simulated: bool = False
    queued: bool = False
    parent: str = ""
    stamp: float = 0.0


class ProgressEntry(msgspec.Struct, tag="progress", tag_field="kind", kw_only=True):
    progress: Progress
    stamp: float = 0.0


class ResultEntry(msgspec.Struct, tag="result", tag_field="kind", kw_only=True):
    result: RunResult
    stamp: float = 0.0


class RefusedEntry(msgspec.Struct, tag="refused", tag_field="kind", kw_only=True):
    """A start request refused before any run existed (or at its pre-condition check)."""

    agent: str
    skill: str
    code: str
    message: str
    run_id: str = ""
    stamp: float = 0.0


class WmWriteEntry(msgspec.Struct, tag="wm_write", tag_field="kind", kw_only=True):
    """A world-model transaction the runtime committed for a run."""

    agent: str
    run_id: str
    revision: int
    ops: list[Op]
    stamp: float = 0.0


LogEntry: TypeAlias = RunStartedEntry | ProgressEntry | ResultEntry | RefusedEntry | WmWriteEntry

_encoder = msgspec.json.Encoder()
_decoder = msgspec.json.Decoder(LogEntry)


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
