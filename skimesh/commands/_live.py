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
                    ended.phase = "idle" if event.success else f"failed: {event.reason}"
                    ended.skill, ended.fraction = "", -1.0
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

    def render(self, now: float | None = None) -> RenderableType:
        from rich.console import Group
        from rich.table import Table
        from rich.text import Text

        now = time.time() if now is None else now
        if self.finished is not None:
            now = self.finished.stamp
        elapsed = 0.0 if self.t0 is None else now - self.t0
        held = "  PAUSED" if self.paused else ""
        head = Text(f"{self.title}  ({elapsed:.1f} s){held}", style="bold")
        robots = Table(title="robots", title_justify="left", expand=False)
        for name in ("robot", "step", "skill", "phase", "done", "in step"):
            robots.add_column(name, overflow="fold")
        for agent, r in sorted(self.robots.items()):
            done = "" if r.fraction < 0 else _bar(r.fraction)
            step = "" if r.step < 0 else str(r.step)
            phase = f"{r.phase} {r.message}".strip()
            robots.add_row(agent, step, r.skill, phase, done, f"{now - r.since:.1f} s")
        plan = Table(title="plan", title_justify="left")
        for name in ("#", "robot", "call", "after", "status"):
            plan.add_column(name, overflow="fold")
        style = {"done": "green", "running": "yellow", "FAILED": "bold red"}
        for s in sorted(self.plan.values(), key=lambda s: s.index):
            plan.add_row(
                str(s.index),
                s.agent,
                s.call,
                s.after,
                Text(s.status, style=style.get(s.status, "")),
            )
        return Group(head, robots, plan, Text(self.note))


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
    with Live(get_renderable=view.render, console=console, refresh_per_second=4):
        async for event in events:
            if isinstance(event, TaskFinished):
                view.apply(event)
                break
            view.apply(event)
            if on_event is not None:
                on_event(event)
    return view.finished
