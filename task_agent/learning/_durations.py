"""Learned run times: :class:`DurationBook`, one figure per (agent, skill), kept in a file.

Each successful run adds one sample. A skill that moves the robot between two places with
poses (its ``start`` and ``goal`` parameters, :data:`ROUTE_PARAMS`) is learned as a line over
the distance driven (``seconds = overhead + metres * seconds_per_metre``, least squares over
the samples); every other skill as the mean of its samples. Old samples fade: once a figure
has :data:`MEMORY` samples, the sums are scaled down so each new one weighs as much as the
average old one, and a robot that became slower is learned within a few runs.

Persistence (:meth:`DurationBook.snapshot` / :meth:`DurationBook.load`): one JSON file,
written whole to a temporary file beside it and renamed over it (``os.replace``), so a reader
and a restart see either the old or the new book, never a torn one. One task agent writes one
file; snapshots are numbered and a snapshot older than the one on disk is not written (two
tasks ending together in one process). A file that cannot be read is reported and replaced by
the next save (the figures are learned again). Estimates fall back to the same skill on other
agents (robots of one kind drive alike), then to the skill description's figure.
"""

from __future__ import annotations

import logging
import math
import os
import threading
from collections.abc import Iterable
from pathlib import Path

import msgspec

__all__ = ["MEMORY", "ROUTE_PARAMS", "DurationBook", "SkillTime"]

_log = logging.getLogger(__name__)

MEMORY = 30
"""Samples a figure remembers at full weight (older ones fade)."""
ROUTE_PARAMS = ("start", "goal")
"""The parameters whose poses give the distance a step drives."""
FORMAT = 1


class SkillTime(msgspec.Struct, kw_only=True):
    """The samples of one (agent, skill), as sums (weighted: see the module doc)."""

    n: float = 0.0
    t: float = 0.0
    """Sum of run times, s."""
    d: float = 0.0
    """Sum of distances, m (0 for skills that do not drive)."""
    dd: float = 0.0
    dt: float = 0.0
    last: float = 0.0

    def add(self, seconds: float, metres: float | None) -> None:
        if self.n >= MEMORY:
            scale = (MEMORY - 1) / self.n
            self.n, self.t, self.d = self.n * scale, self.t * scale, self.d * scale
            self.dd, self.dt = self.dd * scale, self.dt * scale
        m = metres or 0.0
        self.n += 1
        self.t += seconds
        self.d += m
        self.dd += m * m
        self.dt += m * seconds
        self.last = seconds

    @property
    def mean(self) -> float:
        return self.t / self.n if self.n else math.nan

    def estimate(self, metres: float | None) -> float:
        """Seconds for one run (driving ``metres`` when the skill drives)."""
        if self.n == 0:
            return math.nan
        if metres is None or self.d <= 0:
            return self.mean
        mean_d, mean_t = self.d / self.n, self.t / self.n
        var = self.dd / self.n - mean_d * mean_d
        if var > 1e-3 and self.n >= 2:
            slope = (self.dt / self.n - mean_d * mean_t) / var
            if slope > 0:
                return max(mean_t + slope * (metres - mean_d), 0.2 * mean_t, 0.0)
        return mean_t * max(metres, 0.0) / mean_d if mean_d > 0 else mean_t


class _File(msgspec.Struct, kw_only=True):
    format: int = FORMAT
    times: dict[str, dict[str, SkillTime]] = {}
    """Agent -> skill -> samples."""


class DurationBook:
    """Learned run times per (agent, skill); see the module doc. Touch it from one event loop
    (or one thread); :meth:`save` writes a snapshot taken on the caller's thread."""

    def __init__(self, path: Path | str | None = None) -> None:
        self.path = Path(path) if path is not None else None
        """The file it is kept in (None: in memory only)."""
        self.times: dict[str, dict[str, SkillTime]] = {}
        self._made = 0
        self._written = 0
        self._lock = threading.Lock()

    @classmethod
    def load(cls, path: Path | str | None) -> DurationBook:
        """The book kept in ``path`` (empty if there is no file yet or it cannot be read)."""
        book = cls(path)
        if book.path is None or not book.path.exists():
            return book
        try:
            data = msgspec.json.decode(book.path.read_bytes(), type=_File)
        except (OSError, msgspec.DecodeError, msgspec.ValidationError) as e:
            _log.warning("learned durations in %s not read (%s): learning them again", path, e)
            return book
        book.times = data.times
        return book

    def record(self, agent: str, skill: str, seconds: float, metres: float | None = None) -> None:
        """One successful run of ``skill`` on ``agent`` that took ``seconds``."""
        if seconds >= 0 and math.isfinite(seconds):
            self.times.setdefault(agent, {}).setdefault(skill, SkillTime()).add(seconds, metres)

    def estimate(self, agent: str, skill: str, metres: float | None, default: float) -> float:
        """Seconds ``skill`` will take on ``agent``: its own figure, else the mean of the
        other agents' figures for the skill, else ``default``."""
        own = self.times.get(agent, {}).get(skill)
        if own is not None and own.n:
            return own.estimate(metres)
        others = [s.estimate(metres) for a in self.times.values() if (s := a.get(skill)) and s.n]
        return sum(others) / len(others) if others else default

    def samples(self, agent: str, skill: str) -> int:
        own = self.times.get(agent, {}).get(skill)
        return round(own.n) if own is not None else 0

    def rows(self) -> Iterable[tuple[str, str, SkillTime]]:
        for agent, skills in sorted(self.times.items()):
            for skill, time in sorted(skills.items()):
                yield agent, skill, time

    def snapshot(self) -> tuple[int, bytes]:
        """The book as file content, numbered (take it on the loop; :meth:`save` it anywhere)."""
        self._made += 1
        return self._made, msgspec.json.encode(_File(times=self.times))

    def save(self, snapshot: tuple[int, bytes]) -> None:
        """Write ``snapshot`` atomically (blocking: run it in a worker thread), unless a newer
        one was written already."""
        number, content = snapshot
        with self._lock:
            if self.path is None or number <= self._written:
                return
            self.path.parent.mkdir(parents=True, exist_ok=True)
            tmp = self.path.with_name(f".{self.path.name}.{os.getpid()}.tmp")
            tmp.write_bytes(content)
            os.replace(tmp, self.path)
            self._written = number
