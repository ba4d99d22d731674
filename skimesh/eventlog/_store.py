"""The event log's file: :class:`EventStore`, one SQLite database.

SQLite because the log must be durable (a committed batch survives a crash of the process or
the host: write-ahead log, ``synchronous=NORMAL``), queryable by time, robot, task, skill and
outcome (indexed columns) and readable offline by any tool, with nothing to install.

The methods block (disk I/O): the recorder and the service call them through
``anyio.to_thread``; one lock serialises them, so one store may be shared by both.
"""

from __future__ import annotations

import sqlite3
import threading
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

from ._errors import EventLogError
from ._records import EventFilter, EventRecord, LogInfoReply

__all__ = ["EventStore"]

_SCHEMA = """
CREATE TABLE IF NOT EXISTS events (
    seq INTEGER PRIMARY KEY AUTOINCREMENT,
    stamp REAL NOT NULL,
    kind TEXT NOT NULL,
    event TEXT NOT NULL,
    robot TEXT NOT NULL,
    task TEXT NOT NULL,
    skill TEXT NOT NULL,
    run TEXT NOT NULL,
    outcome TEXT NOT NULL,
    text TEXT NOT NULL,
    data TEXT NOT NULL
);
CREATE INDEX IF NOT EXISTS events_stamp ON events (stamp);
CREATE INDEX IF NOT EXISTS events_robot ON events (robot, seq);
CREATE INDEX IF NOT EXISTS events_task ON events (task, seq);
CREATE INDEX IF NOT EXISTS events_skill ON events (skill, seq);
CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
"""
_COLUMNS = ("stamp", "kind", "event", "robot", "task", "skill", "run", "outcome", "text", "data")


class EventStore:
    """The records of one site in the SQLite file ``path`` (``":memory:"`` for none).

    Raises:
        EventLogError: the file cannot be opened or is no event log.
    """

    def __init__(self, path: str | Path) -> None:
        self.path = str(path)
        if self.path != ":memory:":
            Path(self.path).parent.mkdir(parents=True, exist_ok=True)
        self._lock = threading.Lock()
        try:
            self._db = sqlite3.connect(self.path, check_same_thread=False, isolation_level=None)
            self._db.execute("PRAGMA journal_mode=WAL")
            self._db.execute("PRAGMA synchronous=NORMAL")
            self._db.executescript(_SCHEMA)
        except sqlite3.DatabaseError as e:
            raise EventLogError(f"{self.path} is no usable event log: {e}") from None

    def close(self) -> None:
        with self._lock:
            self._db.close()

    def append(
        self,
        records: Sequence[EventRecord],
        *,
        wm_revision: int | None = None,
        runs: Sequence[tuple[str, str]] = (),
    ) -> int:
        """Store ``records`` (and the newest world-model revision they hold) in one
        transaction; returns the newest ``seq``. ``runs``: (run, task) pairs learnt since the
        last batch: stored records of those runs (and their sub-runs ``<run>.<n>``) that
        arrived before their task named them get the task."""
        rows = [tuple(getattr(r, c) for c in _COLUMNS) for r in records]
        with self._lock, self._db:
            self._db.execute("BEGIN")
            self._db.executemany(
                f"INSERT INTO events ({', '.join(_COLUMNS)}) VALUES ({', '.join('?' * 10)})",
                rows,
            )
            self._db.executemany(
                "UPDATE events SET task = ? WHERE task = '' AND kind = 'run' "
                "AND (run = ? OR substr(run, 1, ?) = ?)",
                [(task, run, len(run) + 1, f"{run}.") for run, task in runs],
            )
            if wm_revision is not None:
                self._db.execute(
                    "INSERT INTO meta VALUES ('wm_revision', ?) "
                    "ON CONFLICT(key) DO UPDATE SET value = excluded.value "
                    "WHERE CAST(meta.value AS INTEGER) < CAST(excluded.value AS INTEGER)",
                    (str(wm_revision),),
                )
            return self._last_seq()

    def query(self, where: EventFilter, *, after: int = 0, limit: int = 1000) -> list[EventRecord]:
        """Records matching ``where`` with ``seq > after``, oldest first, at most ``limit``."""
        clauses, params = _where(where)
        clauses.append("seq > ?")
        params.append(after)
        sql = (
            f"SELECT seq, {', '.join(_COLUMNS)} FROM events WHERE {' AND '.join(clauses)} "
            "ORDER BY seq LIMIT ?"
        )
        with self._lock:
            rows = self._db.execute(sql, (*params, limit)).fetchall()
        return [_record(row) for row in rows]

    def info(self) -> LogInfoReply:
        with self._lock:
            count, first, last = self._db.execute(
                "SELECT COUNT(*), MIN(stamp), MAX(stamp) FROM events"
            ).fetchone()
            revision = self._db.execute(
                "SELECT value FROM meta WHERE key = 'wm_revision'"
            ).fetchone()
            return LogInfoReply(
                count=count,
                last_seq=self._last_seq(),
                first_stamp=first or 0.0,
                last_stamp=last or 0.0,
                wm_revision=int(revision[0]) if revision else 0,
                path=self.path,
            )

    def _last_seq(self) -> int:
        row = self._db.execute("SELECT MAX(seq) FROM events").fetchone()
        return int(row[0] or 0)


def _where(f: EventFilter) -> tuple[list[str], list[Any]]:
    clauses: list[str] = []
    params: list[Any] = []
    if f.since is not None:
        clauses.append("stamp >= ?")
        params.append(f.since)
    if f.until is not None:
        clauses.append("stamp < ?")
        params.append(f.until)
    if f.kinds:
        clauses.append(f"kind IN ({', '.join('?' * len(f.kinds))})")
        params.extend(f.kinds)
    for column in ("robot", "task", "skill", "outcome"):
        value = getattr(f, column)
        if value:
            clauses.append(f"{column} = ?")
            params.append(value)
    if f.text:
        clauses.append("instr(lower(text), ?) > 0")
        params.append(f.text.lower())
    return clauses, params


def _record(row: Iterable[Any]) -> EventRecord:
    seq, *values = row
    return EventRecord(seq=seq, **dict(zip(_COLUMNS, values, strict=True)))
