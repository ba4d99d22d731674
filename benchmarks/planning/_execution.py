"""Measured makespan: one plan run on simulated-outcome agents, as its partial order and then
forced sequential (the planning benchmark's *executed* rows).

Scene: the in-process fleet of the task-layer tests (``tests.assets.task_fleet``): a real
in-memory world-model store, one :class:`~skill_agent.runtime.AgentCore` per robot in
simulated-outcome mode running the standard navigate / pick / place skills (each run checks its
pre-conditions in the world model, sleeps ``duration * time_scale`` and commits its effects),
robots at a depot, gears in a part box at each of two stations, a kit box on every robot. The
goals are the planning benchmark's: ``two`` parts into each robot's kit, or ``all``.

Per repetition the goal is planned once (Kairos, :func:`~task_agent.planning.to_partial_order`)
in a fresh fleet and that plan's steps run through the executor's
:class:`~task_agent.execution.StepScheduler`; then a second fresh fleet (same element ids) runs the
very same steps chained one after the other in the schedule's order. Both wall times, divided
by ``time_scale``, are in the skills' seconds, comparable with the estimated makespan; the
difference between the measured and the estimated sequential time is the execution overhead
(world-model transactions, events, scheduling), shown per step in wall milliseconds.
"""

from __future__ import annotations

import math
import statistics
import sys
import time
from collections.abc import Sequence

import anyio
import msgspec

from benchmarks.common import Row, fmt_num, format_grid
from task_agent import Goal, TaskError, parse_goal
from task_agent.execution import EventSink, StepScheduler, StepSpec, steps_from_plan, unmet_goal
from task_agent.planning import Planner, to_partial_order
from task_agent.protocol import TaskOptions
from tests.assets.task_fleet import Fleet, fleet

__all__ = [
    "TOLERANCE",
    "Executed",
    "execute_all",
    "executed_details",
    "executed_rows",
    "measure_execution",
]

TOLERANCE = 1.15
"""Target: the measured parallel / sequential ratio at most this much above the estimated."""


class Executed(msgspec.Struct, kw_only=True):
    """One robots x parts x goal case, medians over the repetitions (seconds of the skills)."""

    robots: int
    parts: int
    goal: str
    steps: int = 0
    estimated: float = math.nan
    estimated_sequential: float = math.nan
    parallel: float = math.nan
    sequential: float = math.nan
    ratio: float = math.nan
    """Median of the per-repetition measured parallel / sequential."""
    overhead_ms: float = math.nan
    """Wall milliseconds per step beyond the skills' durations (sequential run)."""
    time_scale: float = 0.0
    status: str = "ok"

    @property
    def name(self) -> str:
        return f"{self.robots}x{self.parts} {self.goal}"

    @property
    def estimated_ratio(self) -> float:
        return self.estimated / self.estimated_sequential


def _goal(f: Fleet, kind: str) -> Goal:
    robots = len(f.kits)
    parts = f.parts[: 2 * robots] if kind == "two" else f.parts
    text = " and ".join(f"contain({f.kits[i % robots]}, {p})" for i, p in enumerate(parts))
    return parse_goal(text, f.wm)


def _chained(steps: list[StepSpec]) -> list[StepSpec]:
    """The steps one after the other, in the schedule's start order (a linear extension)."""
    return [
        msgspec.structs.replace(s, after=(steps[i - 1].index,) if i else ())
        for i, s in enumerate(steps)
    ]


async def _run(f: Fleet, steps: list[StepSpec], goal_kind: str) -> float:
    """Wall seconds to run ``steps`` in ``f``; checks every step succeeded and the goal holds."""
    scheduler = StepScheduler(
        events=EventSink("bench", lambda _event: None),
        runner=f.runner,
        discovery=f.discovery,
        wm=f.wm,
        options=TaskOptions(),
    )
    start = time.perf_counter()
    failure = await scheduler.run(steps)
    elapsed = time.perf_counter() - start
    if failure is not None:
        raise RuntimeError(f"the plan failed in execution: {failure}")
    await f.wm.wait_for_revision(scheduler.effects_revision, timeout=10)
    if unmet := unmet_goal(_goal(f, goal_kind), f.wm):
        raise RuntimeError(f"the plan ran but the goal does not hold: {unmet}")
    return elapsed


async def _measure(
    robots: int, parts: int, goal_kind: str, *, time_scale: float, reps: int, planner: Planner
) -> Executed:
    case = Executed(robots=robots, parts=parts, goal=goal_kind, time_scale=time_scale)
    parallel, sequential, ratios = [], [], []
    for _ in range(reps):
        async with fleet(robots, parts, time_scale=time_scale) as f:
            plan = await planner.plan(f.discovery.agents(), f.wm, _goal(f, goal_kind))
            order = to_partial_order(plan)
            steps = steps_from_plan(order)
            ids = (f.kits, f.parts)
            limit = 30.0 + 3 * order.sequential * time_scale
            with anyio.fail_after(limit):
                par = await _run(f, steps, goal_kind)
        async with fleet(robots, parts, time_scale=time_scale) as f:
            assert (f.kits, f.parts) == ids, "fresh fleets differ: the plan would not apply"
            with anyio.fail_after(limit):
                seq = await _run(f, _chained(steps), goal_kind)
        parallel.append(par / time_scale)
        sequential.append(seq / time_scale)
        ratios.append(par / seq)
    case.steps = len(steps)
    case.estimated, case.estimated_sequential = order.makespan, order.sequential
    case.parallel, case.sequential = statistics.median(parallel), statistics.median(sequential)
    case.ratio = statistics.median(ratios)
    overhead = (case.sequential - case.estimated_sequential) * time_scale / len(steps)
    case.overhead_ms = overhead * 1000.0
    return case


def measure_execution(
    robots: int, parts: int, goal_kind: str, *, time_scale: float = 0.01, reps: int = 1
) -> Executed:
    """Plan ``goal_kind`` for ``robots`` x ``parts`` and run it both ways (module docstring)."""
    planner = Planner(engine="kairos")
    try:
        return anyio.run(
            lambda: _measure(
                robots, parts, goal_kind, time_scale=time_scale, reps=reps, planner=planner
            )
        )
    except (RuntimeError, TaskError) as e:
        return Executed(robots=robots, parts=parts, goal=goal_kind, status=str(e))
    except TimeoutError:
        return Executed(robots=robots, parts=parts, goal=goal_kind, status="timeout")


def execute_all(
    sizes: Sequence[tuple[int, int]], *, time_scale: float, reps: int
) -> list[Executed]:
    """Both goals for every robots x parts size (progress on stderr)."""
    cases = []
    for robots, parts in sizes:
        for goal in ("two", "all"):
            print(f"{robots}x{parts} {goal} executed ...", file=sys.stderr, flush=True)
            cases.append(measure_execution(robots, parts, goal, time_scale=time_scale, reps=reps))
    return cases


def executed_rows(cases: list[Executed]) -> list[Row]:
    out = []
    for c in cases:
        figure = f"executed {c.name}"
        if c.status != "ok":
            out.append(Row(figure=figure, value=math.nan, unit="s", note=c.status))
            continue
        out.append(
            Row(
                figure=figure,
                value=c.parallel,
                unit="s",
                baseline="measured sequential",
                baseline_value=c.sequential,
                target=f"<= {TOLERANCE:.2f} x est. {c.estimated_ratio:.2f}",
                met=c.ratio <= TOLERANCE * c.estimated_ratio,
                note=f"{c.ratio:.2f}x per-run",
            )
        )
    return out


def executed_details(cases: list[Executed]) -> str:
    head = (
        "case",
        "steps",
        "estimated makespan/seq",
        "measured parallel/seq",
        "overhead ms/step",
    )
    body = []
    for c in cases:
        if c.status != "ok":
            body.append((c.name, c.status, "-", "-", "-"))
            continue
        body.append(
            (
                c.name,
                str(c.steps),
                f"{c.estimated:.0f}/{c.estimated_sequential:.0f} = {c.estimated_ratio:.2f}",
                f"{c.parallel:.1f}/{c.sequential:.1f} = {c.ratio:.2f}",
                fmt_num(c.overhead_ms),
            )
        )
    return format_grid(head, body)
