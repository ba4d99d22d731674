"""The recent runs' events of one agent, kept for ``skimesh runs AGENT RUN`` and late
followers: :class:`RunHistory`.

It takes every :data:`~skill_agent.protocol.RunEvent` of the agent's core (sub-runs included),
by run. Bounds: at most ``max_events`` events per run (500 by default; past that the run's
oldest progress events are dropped, never its result) and the events of at most ``max_runs``
runs (256, as many ended runs as the core keeps: the runs that ended first are forgotten first;
running runs are never forgotten). The ``RunEvents`` request reads it (:class:`AgentService
<skill_agent.server.AgentService>`).
"""

from __future__ import annotations

from collections import OrderedDict, deque

from skill_agent.protocol._runs import Progress, RunEvent, RunResult

__all__ = ["MAX_RUNS", "MAX_RUN_EVENTS", "RunHistory"]

MAX_RUN_EVENTS = 500
"""Events kept per run by default."""
MAX_RUNS = 256
"""Runs whose events are kept, by default."""


class _Kept:
    __slots__ = ("dropped", "events", "result")

    def __init__(self) -> None:
        self.events: deque[Progress] = deque()
        self.result: RunResult | None = None
        self.dropped = 0


class RunHistory:
    """Events by run, bounded (see the module doc)."""

    def __init__(self, *, max_events: int = MAX_RUN_EVENTS, max_runs: int = MAX_RUNS) -> None:
        if max_events < 1 or max_runs < 1:
            raise ValueError("a run history keeps at least one run and one event per run")
        self.max_events = max_events
        self.max_runs = max_runs
        self._runs: OrderedDict[str, _Kept] = OrderedDict()
        self._ended: deque[str] = deque()

    def __contains__(self, run_id: str) -> bool:
        return run_id in self._runs

    def add(self, event: RunEvent) -> None:
        """Keep one event (a subscriber of :meth:`AgentCore.subscribe
        <skill_agent.runtime.AgentCore.subscribe>`)."""
        kept = self._runs.get(event.run_id)
        if kept is None:
            kept = self._runs[event.run_id] = _Kept()
        if isinstance(event, RunResult):
            kept.result = event
            self._ended.append(event.run_id)
            while len(self._ended) > self.max_runs:
                self._runs.pop(self._ended.popleft(), None)
        else:
            kept.events.append(event)
        while kept.events and len(kept.events) + (kept.result is not None) > self.max_events:
            kept.events.popleft()
            kept.dropped += 1

    def events(self, run_id: str, after_seq: int = 0) -> tuple[list[RunEvent], int] | None:
        """The kept events of a run with ``seq > after_seq`` (its result last) and how many
        were dropped; None for a run not kept."""
        kept = self._runs.get(run_id)
        if kept is None:
            return None
        found: list[RunEvent] = [e for e in kept.events if e.seq > after_seq]
        if kept.result is not None and kept.result.seq > after_seq:
            found.append(kept.result)
        return found, kept.dropped
