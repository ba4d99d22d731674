"""A task's events as they were published, kept for late watchers: :class:`EventHistory`.

``skimesh task watch`` on a running or finished task asks the task agent for the events so far
(``TaskHistory``), then follows the live stream, deduplicated by ``seq``. The history is
bounded: at most ``max_events`` events per task (2000 by default). Past that bound the oldest
``StepProgress`` events are dropped first (a step's later progress and its ``StepFinished``
supersede them); only if none is left, the oldest other event but ``TaskStarted``. The
service forgets ended tasks beyond its last ``keep_finished`` (256), their histories with them.
"""

from __future__ import annotations

from collections import deque

from ..protocol import StepProgress, TaskEvent

__all__ = ["MAX_TASK_EVENTS", "EventHistory"]

MAX_TASK_EVENTS = 2000
"""Events kept per task by default."""


class EventHistory:
    """The events of one task, in ``seq`` order, at most ``max_events`` of them (see the
    module doc)."""

    def __init__(self, max_events: int = MAX_TASK_EVENTS) -> None:
        if max_events < 2:
            raise ValueError(f"a task history keeps at least 2 events, not {max_events}")
        self.max_events = max_events
        self.dropped = 0
        """How many events were dropped to stay within the bound."""
        self._events: dict[int, TaskEvent] = {}
        self._progress: deque[int] = deque()

    def __len__(self) -> int:
        return len(self._events)

    def add(self, event: TaskEvent) -> None:
        self._events[event.seq] = event
        if isinstance(event, StepProgress):
            self._progress.append(event.seq)
        while len(self._events) > self.max_events:
            self._drop()

    def since(self, after_seq: int = 0, limit: int | None = None) -> list[TaskEvent]:
        """The kept events with ``seq > after_seq``, oldest first, at most ``limit``."""
        found = [e for seq, e in self._events.items() if seq > after_seq]
        return found if limit is None else found[:limit]

    def _drop(self) -> None:
        if self._progress:
            seq = self._progress.popleft()
        else:
            first = min(self._events)
            seq = next(s for s in self._events if s != first)
        del self._events[seq]
        self.dropped += 1
