"""What ``skimesh demo`` prints while the mission runs, and the figures of its summary.

One line per task event, per robot and per step, with the wall-clock and the simulated time
since the task began::

      wall     sim  robot      step
      0.9s    2.1s  r1         #0   navigate(goal=Station-1) started
      1.0s    4.3s  r1         #0   navigate: driving to Station-1
      1.1s    5.0s  r1         #0   navigate done (2.9 s)

A step's progress events are many (a motion reports every 2 %); a line is printed when its
message changes, not for every fraction (and not for the agent's "holds devices" lines).
Plans print as a table in start order with the partial order ("after": steps that must
finish first) and the estimated schedule. Elements are named as everywhere
(:func:`wm_store.display_name`: ``Gear-1``, or ``Pulley-4 (Gear-1)`` where the label and the
id differ), through the ``call_text`` the demo gives.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

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
from wm_store.protocol import Value

from .._words import counted
from ..recording import step_text

__all__ = ["MissionView", "RobotStats"]

Out = Callable[[str], None]
CallFormat = Callable[[str, str, Mapping[str, Value]], str]


def _plain(_agent: str, skill: str, params: Mapping[str, Value]) -> str:
    return step_text(skill, params, str)


@dataclass
class RobotStats:
    steps: int = 0
    failed: int = 0
    busy: float = 0.0
    """Simulated seconds spent in steps."""


@dataclass
class _Step:
    agent: str
    skill: str
    began: float
    last: str = ""


@dataclass
class MissionView:
    """Prints the task's events (see the module doc) and keeps the figures of the summary."""

    sim_clock: Callable[[], float]
    call_text: CallFormat = _plain
    """How a skill call is shown (:class:`skimesh.recording.CallText`)."""
    out: Out = print
    plans: list[Planned] = field(default_factory=list)
    robots: dict[str, RobotStats] = field(default_factory=dict)
    finished: TaskFinished | None = None
    sim_start: float | None = None
    sim_end: float | None = None
    wall_start: float | None = None
    wall_end: float | None = None
    _steps: dict[int, _Step] = field(default_factory=dict)

    def __call__(self, event: TaskEvent) -> None:
        sim, wall = self.sim_clock(), time.monotonic()
        if self.sim_start is None or self.wall_start is None:
            self.sim_start, self.wall_start = sim, wall
        prefix = f"{wall - self.wall_start:7.1f}s {sim - self.sim_start:7.1f}s  "
        for line in self._lines(event, sim):
            self.out(line if line.startswith("    ") else prefix + line)

    @property
    def sim_makespan(self) -> float:
        """Simulated seconds from the task's start to its end (0 while it runs)."""
        if self.sim_start is None or self.sim_end is None:
            return 0.0
        return self.sim_end - self.sim_start

    @property
    def wall_makespan(self) -> float:
        if self.wall_start is None or self.wall_end is None:
            return 0.0
        return self.wall_end - self.wall_start

    def header(self) -> str:
        return f"{'wall':>8} {'sim':>8}  {'robot':<10} step"

    def _lines(self, event: TaskEvent, sim: float) -> list[str]:
        match event:
            case TaskStarted():
                return [f"task {event.task_id} started: {event.goal or event.name}"]
            case Planned():
                self.plans.append(event)
                return ["plan ready", *self.plan_lines(event)]
            case StepStarted():
                call = self.call_text(event.agent, event.skill, event.params)
                self._steps[event.step] = _Step(event.agent, event.skill, sim)
                return [_row(event.agent, event.step, f"{call} started")]
            case StepProgress():
                step = self._steps.get(event.step)
                quiet = event.state == "pending" or not event.message  # "holds devices: ..."
                if step is None or quiet or event.message == step.last:
                    return []
                step.last = event.message
                return [_row(event.agent, event.step, f"{step.skill}: {event.message}")]
            case StepFinished():
                return [_row(event.agent, event.step, self._finished_step(event, sim))]
            case Replanning():
                return [f"replanning (attempt {event.attempt}): {event.reason}"]
            case TaskPaused() | TaskResumed():
                return [f"task {'paused' if isinstance(event, TaskPaused) else 'resumed'}"]
            case SafeState():
                held = ", ".join(event.holding)
                return [f"safe state {event.agent} ({held}): {event.message}"]
            case TaskFinished():
                self.finished = event
                self.sim_end, self.wall_end = sim, time.monotonic()
                tail = f": {event.message}" if event.message else ""
                return [f"task {event.task_id} {event.outcome}{tail}"]

    def _finished_step(self, event: StepFinished, sim: float) -> str:
        step = self._steps.pop(event.step, None)
        stats = self.robots.setdefault(event.agent, RobotStats())
        took = ""
        if step is not None:
            stats.busy += sim - step.began
            took = f" ({sim - step.began:.1f} s)"
        stats.steps += 1
        if event.success:
            who = " by the operator" if event.by_operator else ""
            return f"{event.skill} done{who}{took}"
        stats.failed += 1
        return f"{event.skill} FAILED ({event.reason}){took}: {event.message}"

    def plan_lines(self, plan: Planned) -> list[str]:
        """The plan as a table: start order, the partial order, the estimated schedule."""
        agents = sorted({s.agent for s in plan.steps})
        head = (
            f"    plan {plan.attempt} by {plan.planner or 'the planner'} in "
            f"{plan.plan_seconds:.2f} s: {counted(len(plan.steps), 'step')} on "
            f"{', '.join(agents)}; "
            f"estimated makespan {plan.makespan:.1f} s in parallel, {plan.sequential:.1f} s "
            "one step at a time"
        )
        rows = [head, f"    {'step':>4}  {'robot':<10} {'skill':<46} {'after':<9} estimated"]
        for s in sorted(plan.steps, key=lambda s: (s.start, s.index)):
            call = self.call_text(s.agent, s.skill, s.params)
            after = ",".join(map(str, s.after)) or "-"
            rows.append(
                f"    {s.index:>4}  {s.agent:<10} {_cut(call, 46):<46} {after:<9} "
                f"{s.start:5.1f}-{s.finish:5.1f} s"
            )
        return rows


def _row(agent: str, step: int, text: str) -> str:
    return f"{agent:<10} #{step:<3} {text}"


def _cut(text: str, width: int) -> str:
    return text if len(text) <= width else text[: width - 3] + "..."
