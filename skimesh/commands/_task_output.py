"""What ``skimesh task`` prints: one line per task event with a summary per robot
(:class:`ProgressPrinter`), a task's state, each goal fact checked in the world model and the
physics (:func:`check_lines`), verification problems, JSON lines."""

from __future__ import annotations

import sys
import time
from collections.abc import Mapping

import msgspec

from task_agent.protocol import (
    GoalCheck,
    PartialResult,
    Planned,
    PlannedStep,
    Replanning,
    SafeState,
    StepFinished,
    StepProgress,
    StepStarted,
    TaskEvent,
    TaskFinished,
    TaskInfo,
    TaskPaused,
    TaskResumed,
    TaskStarted,
    VerifyProblem,
)

from .._words import counted

__all__ = [
    "ProgressPrinter",
    "check_lines",
    "info_lines",
    "partial_lines",
    "pause_text",
    "planned_after",
    "planned_call",
    "print_json",
    "print_problems",
    "safe_state_text",
    "step_line",
]


def print_json(obj: object) -> None:
    sys.stdout.write(msgspec.json.encode(obj).decode() + "\n")
    sys.stdout.flush()


class ProgressPrinter:
    """One line per event (times from the task's start), then a summary per robot."""

    def __init__(self) -> None:
        self.t0: float | None = None
        self.skills: dict[int, str] = {}
        self.begun: dict[int, float] = {}
        self.busy: dict[str, float] = {}
        self.count: dict[str, int] = {}
        self.said: dict[int, str] = {}
        """The last progress text of each step: a line is printed when it changes, not at
        every update of the step's fraction."""

    def __call__(self, event: TaskEvent) -> None:
        for line in self.lines(event):
            print(line, flush=True)

    def lines(self, event: TaskEvent) -> list[str]:
        self.t0 = event.stamp if self.t0 is None else self.t0
        at = f"{event.stamp - self.t0:7.2f}s"
        match event:
            case TaskStarted():
                return [f"task {event.task_id}: {event.goal or event.name or '(unnamed)'}"]
            case Planned():
                return self._planned(event)
            case StepStarted():
                self.skills[event.step], self.begun[event.step] = event.skill, event.stamp
                return [step_line(at, event.agent, event.step, event.skill, "started")]
            case StepProgress():
                text = f"[{event.state}] {event.message}".rstrip()
                if self.said.get(event.step) == text:
                    return []
                self.said[event.step] = text
                skill = self.skills.get(event.step, "")
                return [step_line(at, event.agent, event.step, skill, text)]
            case StepFinished():
                return [step_line(at, event.agent, event.step, event.skill, self._end(event))]
            case Replanning():
                return [f"{at}  replanning (attempt {event.attempt}): {event.reason}"]
            case TaskPaused() | TaskResumed():
                return [f"{at}  {pause_text(event)}"]
            case SafeState():
                return [f"{at}  {safe_state_text(event)}"]
            case TaskFinished():
                return self._summary(event)

    def _planned(self, event: Planned) -> list[str]:
        who = ", ".join(sorted({s.agent or "any" for s in event.steps})) or "nobody"
        head = (
            f"plan {event.attempt} ({event.planner}, {event.plan_seconds:.2f} s): "
            f"{counted(len(event.steps), 'step')} on {who}; makespan {event.makespan:.1f} s "
            f"(sequential {event.sequential:.1f} s)"
        )
        rows = []
        for s in sorted(event.steps, key=lambda s: (s.start, s.index)):
            call, after = planned_call(s, event.names), planned_after(s)
            rows.append(f"  {s.index:3d}  {s.agent or 'any':<10} {call}  after {after}")
        return [head, *rows]

    def _end(self, event: StepFinished) -> str:
        began = self.begun.pop(event.step, None)
        if began is not None:
            self.busy[event.agent] = self.busy.get(event.agent, 0.0) + event.stamp - began
            self.count[event.agent] = self.count.get(event.agent, 0) + 1
        who = " by the operator" if event.by_operator else ""
        if event.success:
            return f"succeeded{who}"
        return f"FAILED{who} ({event.reason}): {event.message}"

    def _summary(self, event: TaskFinished) -> list[str]:
        lines = [
            f"task {event.task_id} {event.outcome} in {event.duration:.2f} s: "
            f"{counted(event.steps_run, 'step')} run, {counted(event.replans, 'replan')}"
        ]
        for agent in sorted(self.count):
            steps = counted(self.count[agent], "step")
            lines.append(f"  {agent}: {steps}, {self.busy[agent]:.2f} s busy")
        lines += makespan_lines(event.estimated_makespan, event.actual_makespan)
        if self.busy and event.actual_makespan:
            share = sum(self.busy.values()) / len(self.busy)
            lines.append(
                f"  balance: busy {share:.1f} s per robot on average ({len(self.busy)} robots) "
                f"in a makespan of {event.actual_makespan:.1f} s"
            )
        if event.message:
            lines.append(f"  {event.message}")
        return lines + partial_lines(event.partial) + check_lines(event.check)


def safe_state_text(event: SafeState) -> str:
    """``safe state r1: put down Gear-1`` / ``safe state r1: STILL HOLDS Gear-1: why``."""
    held = ", ".join(event.holding) or "nothing"
    if event.ok:
        return f"safe state {event.agent}: put down {held}"
    return f"safe state {event.agent}: STILL HOLDS {held}: {event.message}"


def partial_lines(partial: PartialResult | None) -> list[str]:
    """A task that lost an agent: the goal facts achieved, those lost and why, the agents
    lost (at which step)."""
    if partial is None:
        return []
    lines = ["  achieved: " + (", ".join(partial.achieved) or "none")]
    lines += [f"  lost:     {f.fact}: {f.why}" for f in partial.lost]
    for a in partial.lost_agents:
        where = f" at step {a.step} ({a.skill})" if a.step >= 0 else ""
        lines.append(f"  agent {a.agent} lost{where}: {a.message}")
    return lines


def pause_text(event: TaskPaused | TaskResumed) -> str:
    """``paused (why): no new step starts; runs paused: ...`` / ``resumed; runs resumed: ...``."""
    runs = ", ".join(event.runs) or "none"
    if isinstance(event, TaskPaused):
        why = f" ({event.reason})" if event.reason else ""
        return f"paused{why}: no new step starts; runs paused: {runs}"
    return f"resumed; runs resumed: {runs}"


def planned_call(step: PlannedStep, names: Mapping[str, str]) -> str:
    """``skill(param=value, ...)`` of a planned step, elements by their display ``names``."""
    args = ", ".join(
        f"{k}={names.get(v, v) if isinstance(v, str) else v}" for k, v in step.params.items()
    )
    return f"{step.skill}({args})"


def planned_after(step: PlannedStep) -> str:
    """The steps a planned step waits for (``-``: none)."""
    return ",".join(map(str, step.after)) or "-"


def step_line(at: str, agent: str, step: int, skill: str, text: str) -> str:
    return f"{at}  {agent:<10} step {step:<3} {skill:<10} {text}"


def info_lines(info: TaskInfo) -> list[str]:
    ended = f", ended {time.ctime(info.finished_at)}" if info.finished_at else ""
    state = f"{info.outcome} (paused)" if info.paused else info.outcome
    return [
        f"{info.task_id}  {state}  {info.goal or info.name}",
        f"  started {time.ctime(info.started_at)}{ended}; {counted(info.steps_run, 'step')} run, "
        f"{counted(info.replans, 'replan')}",
        *makespan_lines(info.estimated_makespan, info.actual_makespan),
        *([f"  {info.message}"] if info.message else []),
        *partial_lines(info.partial),
        *check_lines(info.check),
    ]


def makespan_lines(estimated: float | None, actual: float | None) -> list[str]:
    """``  makespan: estimated 29.0 s, actual 31.2 s (error -7%)`` (nothing before a plan)."""
    if estimated is None:
        return []
    if actual is None:
        return [f"  makespan: estimated {estimated:.1f} s"]
    error = f" (error {(estimated - actual) / actual:+.0%})" if actual > 0 else ""
    return [f"  makespan: estimated {estimated:.1f} s, actual {actual:.1f} s{error}"]


def _physics(physics: bool | None, detail: str) -> tuple[str, str]:
    if physics is None:
        why = detail.removeprefix("cannot tell: ") or "no such fact"
        return "cannot tell", f"({why})"
    return ("yes" if physics else "NO"), detail


def check_lines(check: GoalCheck | None) -> list[str]:
    """Each goal fact: whether the world model holds it and whether the physics agrees
    (``yes``, ``NO``, ``cannot tell (why)``), with the simulated time of the check."""
    if check is None:
        return []
    at = f" at simulated time {check.sim_time:.2f} s" if check.sim_time is not None else ""
    where = "world model and physics" if check.simulator else "world model"
    lines = [f"  goal check ({where}{at}):"]
    for f in check.facts:
        physics, detail = _physics(f.physics, f.detail)
        wm = "yes" if f.in_wm else "NO"
        lines.append(f"    {f.fact:<36} world model {wm:<3}  physics {physics:<11}  {detail}")
    if check.note:
        lines.append(f"  {check.note}")
    if wrong := check.contradicted:
        facts = ", ".join(f.fact for f in wrong)
        lines.append(f"  THE PHYSICS CONTRADICTS THE WORLD MODEL: {facts}")
    return lines


def print_problems(problems: list[VerifyProblem]) -> None:
    for p in problems:
        print(f"  {p.path or '-'}  [{p.kind}] {p.message}", file=sys.stderr)
