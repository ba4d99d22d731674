"""The live view of a task on a terminal (``task submit`` / ``task watch`` when stdout is a
TTY): one view updated in place, with per robot the current step, skill, phase, completion and
time in the step, and the plan with each step done, running, waiting or failed. Times count
from the task's own start (its ``TaskStarted`` stamp): ``task watch`` replays the task's
history first, so a view opened late shows the plan, the steps already run and the task's
real clock.

:class:`TaskView` is the model (it takes every :data:`~task_agent.protocol.TaskEvent`) and
renders it with `rich <https://rich.readthedocs.io>`_ (tables wrap to the terminal's width);
:func:`follow_live` drives a ``rich.live.Live`` with it. Without a TTY the command prints one
line per event instead (:class:`~skimesh.commands._task_output.ProgressPrinter`).
"""

from __future__ import annotations

import re
import time
from collections.abc import AsyncIterator, Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from task_agent.protocol import (
    Planned,
    Replanning,
    SafeState,
    StepFinished,
    StepProgress,
    StepStarted,
    TaskEvent,
    TaskFinished,
    TaskPaused,
    TaskResumed,
    TaskStarted,
)

from ._task_output import pause_text, planned_after, planned_call, safe_state_text

if TYPE_CHECKING:  # rich loads when a view is shown, not for every command
    from rich.console import Console, RenderableType

__all__ = ["TaskView", "follow_live"]

_BAR = 12


@dataclass
class _Robot:
    step: int = -1
    skill: str = ""
    phase: str = ""
    message: str = ""
    fraction: float = -1.0
    since: float = 0.0
    ended: float | None = None
    """When its last step ended (None: a step is running): the time in the step stops there."""

    def finish(self, event: StepFinished) -> None:
        self.phase = "done" if event.success else f"FAILED: {event.reason}"
        self.message, self.ended = "", event.stamp
        self.fraction = 1.0 if event.success else -1.0


@dataclass
class _Step:
    index: int
    agent: str
    call: str
    after: str
    status: str = "waiting"


@dataclass
class TaskView:
    """What the live view shows, from the task's events (see the module doc)."""

    title: str = ""
    t0: float | None = None
    robots: dict[str, _Robot] = field(default_factory=dict)
    plan: dict[int, _Step] = field(default_factory=dict)
    note: str = ""
    paused: bool = False
    finished: TaskFinished | None = None

    def apply(self, event: TaskEvent) -> None:
        self.t0 = event.stamp if self.t0 is None else self.t0
        match event:
            case TaskStarted():
                self.title = f"task {event.task_id}: {event.goal or event.name or '(unnamed)'}"
            case Planned():
                for s in event.steps:
                    call, after = planned_call(s, event.names), planned_after(s)
                    self.plan[s.index] = _Step(s.index, s.agent or "any", call, after)
                self.note = f"plan {event.attempt}: {len(event.steps)} steps ({event.planner})"
            case StepStarted():
                self.robots[event.agent] = _Robot(
                    event.step, event.skill, "started", "", -1.0, event.stamp
                )
                self._status(event.step, "running")
            case StepProgress():
                robot = self.robots.setdefault(event.agent, _Robot(since=event.stamp))
                robot.phase, robot.message = event.state, event.message
                robot.fraction = event.fraction if event.fraction >= 0 else robot.fraction
            case StepFinished():
                self._status(event.step, "done" if event.success else "FAILED")
                ended = self.robots.get(event.agent)
                if ended is not None and ended.step == event.step:
                    ended.finish(event)
            case Replanning():
                self.note = f"replanning (attempt {event.attempt}): {event.reason}"
            case TaskPaused() | TaskResumed():
                self.paused = isinstance(event, TaskPaused)
                self.note = pause_text(event)
            case SafeState():
                self.note = safe_state_text(event)
            case TaskFinished():
                self.finished, self.paused = event, False

    def _status(self, step: int, status: str) -> None:
        if step in self.plan:
            self.plan[step].status = status

    def render(
        self, now: float | None = None, height: int | None = None, width: int | None = None
    ) -> RenderableType:
        """The view at ``now``. With ``height`` (the terminal's lines), the rows that matter
        most where not all fit: robots in a step first, then the plan's failed and running
        steps and the next waiting ones, the count of the others below; with ``width`` too,
        counting the lines each plan row takes there (a long call wraps)."""
        now = time.time() if now is None else now
        if self.finished is not None:
            now = self.finished.stamp
        robots_room, plan_room = _room(height, len(self.robots), len(self.plan))
        if height is not None and width is not None:
            head = -(-(len(self.title) + 20) // max(1, width))  # a long goal wraps
            free = height - robots_room - _CHROME - (head - 1)
            ranked = sorted(self.plan.values(), key=lambda s: (_RANK[s.status], s.index))
            plan_room = _rows_that_fit([s.call for s in ranked], width - _BESIDE_CALL, free)
        return self._frame(now, robots_room, plan_room)

    def _frame(self, now: float, robots_room: int, plan_room: int) -> RenderableType:
        from rich.console import Group
        from rich.table import Table
        from rich.text import Text

        elapsed = 0.0 if self.t0 is None else now - self.t0
        held = "  PAUSED" if self.paused else ""
        head = Text(f"{self.title}  ({elapsed:.1f} s){held}", style="bold")
        robots = Table(title="robots", title_justify="left", expand=False)
        for name in ("robot", "step", "skill", "phase", "done", "in step"):
            robots.add_column(name, overflow="fold")
        shown_robots = sorted(self.robots.items(), key=_robot_rank)
        for agent, r in shown_robots[:robots_room]:
            done = "" if r.fraction < 0 else _bar(r.fraction)
            step = "" if r.step < 0 else str(r.step)
            phase = Text(f"{r.phase} {r.message}".strip(), style=_STYLE.get(r.phase[:6], ""))
            took = (now if r.ended is None else r.ended) - r.since
            robots.add_row(agent, step, r.skill, phase, done, f"{took:.1f} s")
        plan = Table(title="plan", title_justify="left")
        for name in ("#", "robot", "call", "after", "status"):
            plan.add_column(name, overflow="fold")
        steps = sorted(self.plan.values(), key=lambda s: (_RANK[s.status], s.index))
        for s in sorted(steps[:plan_room], key=lambda s: s.index):
            plan.add_row(
                str(s.index),
                s.agent,
                s.call,
                s.after,
                Text(s.status, style=_STYLE.get(s.status, "")),
            )
        hidden = _hidden(shown_robots[robots_room:], steps[plan_room:])
        return Group(head, robots, plan, Text(" ".join(filter(None, (hidden, self.note)))))


_STYLE = {"done": "green", "running": "yellow", "FAILED": "bold red"}
_RANK = {"FAILED": 0, "running": 1, "waiting": 2, "done": 3}
"""Which plan rows to keep when not all fit: failed and running first, then the next
waiting steps, the steps done last."""


def _robot_rank(item: tuple[str, _Robot]) -> tuple[int, list[str | int]]:
    """Robots in a step first, then those whose last step failed, then by name (r2 < r10)."""
    name, robot = item
    rank = 0 if robot.ended is None else 1 if robot.phase.startswith("FAILED") else 2
    return rank, [int(p) if p.isdigit() else p for p in re.split(r"(\d+)", name)]


_CHROME = 13
"""Lines of the view besides its robot and plan rows: the head, each table's title, borders
and header, the line below, and one to spare."""
_BESIDE_CALL = 36
"""Columns of a plan row besides its call: the step, robot, after and status columns and
the borders."""


def _rows_that_fit(calls: list[str], width: int, lines: int) -> int:
    """How many of ``calls`` (in the order kept) fit in ``lines`` when each wraps at
    ``width`` columns; at least one."""
    width, used = max(20, width), 0
    for shown, call in enumerate(calls):
        used += max(1, -(-len(call) // width))
        if used > lines:
            return max(1, shown)
    return max(1, len(calls))


def _room(height: int | None, robots: int, steps: int) -> tuple[int, int]:
    """How many robot rows and plan rows fit in ``height`` lines (each table takes 5 lines
    besides its rows; a plan row may wrap to two); everything when the height is unknown."""
    if height is None:
        return robots, steps
    free = max(0, height - 14)
    robots_room = max(3, min(robots, free // 3))
    return robots_room, max(3, (free - robots_room) // 2)


def _hidden(robots: list[tuple[str, _Robot]], steps: list[_Step]) -> str:
    """What did not fit, counted: '(+2 robots not shown; +40 steps not shown: 30 done,
    10 waiting)'."""
    parts = []
    if robots:
        parts.append(f"+{len(robots)} robots not shown")
    if steps:
        counts: dict[str, int] = {}
        for s in steps:
            counts[s.status] = counts.get(s.status, 0) + 1
        kinds = ", ".join(f"{n} {status}" for status, n in sorted(counts.items()))
        parts.append(f"+{len(steps)} steps not shown: {kinds}")
    return f"({'; '.join(parts)})" if parts else ""


def _bar(fraction: float) -> str:
    filled = round(max(0.0, min(1.0, fraction)) * _BAR)
    return "█" * filled + "░" * (_BAR - filled) + f" {fraction:4.0%}"


async def follow_live(
    events: AsyncIterator[TaskEvent],
    console: Console,
    on_event: Callable[[TaskEvent], object] | None = None,
) -> TaskFinished | None:
    """Show ``events`` in a live view (redrawn 4 times a second, so times tick) until the
    task finishes; ``on_event`` sees every event before its ``TaskFinished``. Returns that
    last event (None: the stream ended without it)."""
    from rich.live import Live

    view = TaskView()

    def frame() -> RenderableType:
        return view.render(height=console.size.height, width=console.size.width)

    with Live(get_renderable=frame, console=console, refresh_per_second=4):
        async for event in events:
            if isinstance(event, TaskFinished):
                view.apply(event)
                break
            view.apply(event)
            if on_event is not None:
                on_event(event)
    return view.finished
