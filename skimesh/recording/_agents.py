"""The skill agents' event logs in the mission recording: one ``agents/<agent>/events`` TextLog
per agent.

Each agent publishes its event log on ``agents/<agent>/events``
(:class:`~skill_agent.client.EventFeed`); :func:`record_agent_events` follows every agent's
and hands the entries to :class:`AgentEventLines`. What the task events already show (each
step's progress, on ``robots/<robot>/skill``) is left out; what they do not is kept, one line
each: runs started (sub-runs of composite skills and runs from outside the task included, with
the resources they lock), results (duration, effects revision, sensing skipped), refused starts
(WARN) and every world-model write a skill made (revision and what it did).

Lines are buffered and sent with one ``send_columns`` per agent (one ``rr.log`` per line costs
more in a running world; see docs/benchmarks.md, section Simulation): at the latest
``flush_every`` wall seconds after the first buffered line, at once when ``max_lines`` are
waiting, and when the follower stops. Each line is
on the ``sim_time`` and ``wall_time`` timelines, taken when the entry arrived (like the task
events of :class:`~skimesh.recording.MissionRecording`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence

import anyio
import numpy as np
import rerun as rr
from anyio.abc import TaskStatus

from meshlink import Mesh
from skill_agent.client import EventFeed
from skill_agent.protocol import (
    LogEntry,
    RefusedEntry,
    ResultEntry,
    RunStartedEntry,
    WmWriteEntry,
)
from skill_agent.runtime import entry_agent
from wm_store.protocol import (
    AddElement,
    DefineClass,
    DefineTemplate,
    Observe,
    Op,
    RemoveElement,
    SetRelation,
    UnsetRelation,
    UpdateElement,
    Value,
)

__all__ = ["AgentEventLines", "describe_ops", "entry_line", "record_agent_events"]

LabelOf = Callable[[str], str]
CallText = Callable[[str, str, Mapping[str, Value]], str]
_MAX_ITEMS = 6


def describe_ops(ops: Sequence[Op], label_of: LabelOf) -> str:
    """What a transaction does, as people read it: ``+contain(kit, gear), update gear (pose)``
    (the first few ops, then a count)."""
    items: list[str] = []
    for op in ops:
        match op:
            case AddElement():
                items.append(f"add {op.label or op.type}")
            case UpdateElement():
                what = ", ".join([*op.properties, *op.remove])
                items.append(f"update {label_of(op.id)}" + (f" ({what})" if what else ""))
            case Observe():
                items.append(f"observe {label_of(op.id)}.{op.property}")
            case RemoveElement():
                items.append(f"remove {label_of(op.id)}")
            case SetRelation() | UnsetRelation():
                sign = "+" if isinstance(op, SetRelation) else "-"
                items.append(f"{sign}{op.predicate}({label_of(op.subject)}, {label_of(op.object)})")
            case DefineClass():
                items.append(f"define class {op.cls.name}")
            case DefineTemplate():
                items.append(f"define template {op.template.name}")
    if len(items) > _MAX_ITEMS:
        items[_MAX_ITEMS:] = [f"{len(items) - _MAX_ITEMS} more ops"]
    return ", ".join(items) or "no op"


def entry_line(entry: LogEntry, label_of: LabelOf, call_text: CallText) -> tuple[str, str] | None:
    """``(text, level)`` of an entry, or None for what the task events already show
    (progress)."""
    match entry:
        case RunStartedEntry():
            call = call_text(entry.agent, entry.skill, entry.params)
            text = f"run {entry.run_id}: {call} started"
            text += " (queued)" if entry.queued else ""
            text += f" as a sub-run of {entry.parent}" if entry.parent else ""
            text += " [simulated]" if entry.simulated else ""
            if entry.resources:
                text += f"; locks {', '.join(label_of(r) for r in entry.resources)}"
            return text, "INFO"
        case ResultEntry(result=r):
            head = f"run {r.run_id}: {r.skill}"
            if not r.success:
                level = "ERROR" if r.reason == "error" else "WARN"
                return f"{head} {r.reason}" + (f": {r.message}" if r.message else ""), level
            text = f"{head} succeeded in {max(r.finished_at - r.started_at, 0.0):.2f} s"
            text += f", effects rev {r.effects_revision}" if r.effects_revision else ""
            if r.trusted_wm:
                text += f", trusted the world model for {', '.join(r.trusted_wm)}"
            return text, "INFO"
        case RefusedEntry():
            run = f" (run {entry.run_id})" if entry.run_id else ""
            return f"refused {entry.skill}{run}: {entry.code}: {entry.message}", "WARN"
        case WmWriteEntry():
            ops = describe_ops(entry.ops, label_of)
            return f"run {entry.run_id} wrote rev {entry.revision}: {ops}", "INFO"
    return None


class AgentEventLines:
    """Buffers the lines of the agents' entries and sends them in batches (see the module
    doc). ``sim_clock`` and ``wall_clock`` give the two timelines' times now."""

    def __init__(
        self,
        rec: rr.RecordingStream,
        *,
        sim_clock: Callable[[], float],
        wall_clock: Callable[[], float],
        label_of: LabelOf,
        call_text: CallText,
        flush_every: float = 0.5,
        max_lines: int = 256,
    ) -> None:
        self.rec = rec
        self.sim_clock, self.wall_clock = sim_clock, wall_clock
        self.label_of, self.call_text = label_of, call_text
        self.flush_every, self.max_lines = flush_every, max_lines
        self.agents: set[str] = set()
        self._lines: dict[str, list[tuple[float, float, str, str]]] = {}
        self._count = 0
        self._first = math.inf  # time.monotonic() of the oldest buffered line

    def add(self, entry: LogEntry) -> None:
        """Buffer ``entry``'s line (none for progress); sends when ``max_lines`` wait."""
        line = entry_line(entry, self.label_of, self.call_text)
        if line is None:
            return
        agent = entry_agent(entry)
        self.agents.add(agent)
        sim, wall = self.sim_clock(), self.wall_clock()
        self._lines.setdefault(agent, []).append((sim, wall, *line))
        self._count += 1
        self._first = min(self._first, time.monotonic())
        if self._count >= self.max_lines:
            self.flush()

    def due_in(self) -> float:
        """Seconds until the buffered lines are due (``inf``: nothing buffered)."""
        return max(self._first + self.flush_every - time.monotonic(), 0.0)

    def flush(self) -> None:
        """Send every buffered line: one ``send_columns`` per agent."""
        for agent, lines in self._lines.items():
            sims, walls, texts, levels = zip(*lines, strict=True)
            self.rec.send_columns(
                f"agents/{agent}/events",
                indexes=[
                    rr.TimeColumn("sim_time", duration=np.array(sims)),
                    rr.TimeColumn("wall_time", duration=np.array(walls)),
                ],
                columns=rr.TextLog.columns(text=texts, level=levels),
            )
        self._lines, self._count, self._first = {}, 0, math.inf

    def entities(self) -> list[str]:
        """The entity paths written so far."""
        return [f"agents/{agent}/events" for agent in sorted(self.agents)]


async def record_agent_events(
    mesh: Mesh,
    lines: AgentEventLines,
    *,
    task_status: TaskStatus[None] = anyio.TASK_STATUS_IGNORED,
) -> None:
    """Follow every agent's event log into ``lines`` until cancelled (``started`` once
    subscribed); on the way out, what already arrived is recorded and everything is sent."""
    async with EventFeed.open(mesh) as feed:
        task_status.started()
        try:
            while True:
                entry: LogEntry | None = None
                with anyio.move_on_after(lines.due_in()):
                    entry = await feed.receive()
                if entry is None:
                    lines.flush()
                else:
                    lines.add(entry)
        except anyio.EndOfStream:
            pass  # the session closed
        finally:
            _drain(feed, lines)
            lines.flush()


def _drain(feed: EventFeed, lines: AgentEventLines) -> None:
    while True:
        try:
            lines.add(feed.receive_nowait())
        except (anyio.WouldBlock, anyio.EndOfStream):
            return
