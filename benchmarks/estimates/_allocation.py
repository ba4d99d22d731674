"""Allocation with learned durations: one robot three times slower than the other, in the
in-process fleet of the task-layer tests (``tests.assets.task_fleet``: real agent cores in
simulated-outcome mode, each run taking its description's duration times the robot's time
scale), both robots at Station-1, four of its parts onto its tray. In two fresh fleets, the
same warm-up task runs (estimated from the descriptions, so both robots look alike), then the
same measured task: once planned with what the warm-up learned, once from the descriptions
(the same-run baseline). Per measured task: the steps and busy time of each robot, the actual
makespan, total busy / robots, and the estimate."""

from __future__ import annotations

import math

import msgspec

from task_agent import parse_goal
from task_agent.learning import DurationBook
from task_agent.protocol import StepFinished, StepStarted, TaskFinished
from tests.assets.task_fleet import Fleet, fleet

__all__ = ["Allocated", "allocation"]

SLOWER = 3.0
"""How much slower r1 runs than r2."""
TIME_SCALE = 0.02


class Allocated(msgspec.Struct, kw_only=True):
    durations: str
    """``learned`` or ``descriptions``."""
    steps: dict[str, int]
    busy: dict[str, float]
    estimated: float = math.nan
    actual: float = math.nan

    @property
    def busy_share(self) -> float:
        return sum(self.busy.values()) / len(self.busy) if self.busy else math.nan


def _goal(f: Fleet, parts: range) -> str:
    """Parts of ``parts`` onto the tray at their station (even: Station-1, odd: Station-2)."""
    return " and ".join(f"contain({f.trays[p % 2]}, {f.parts[p]})" for p in parts)


async def _measured(learn: bool) -> Allocated:
    async with fleet(robots=2, parts=16, time_scale=TIME_SCALE, start={"r1": 1, "r2": 1}) as f:
        simulated = f.cores["r1"].simulated
        assert simulated is not None
        simulated.time_scale = TIME_SCALE * SLOWER
        book = DurationBook()
        warm = f.executor("warm-up")
        warm.learning.book = book
        await warm.run_goal(parse_goal(_goal(f, range(0, 8, 2)), f.wm))
        executor = f.executor("measured")
        if learn:
            executor.learning.book = book
        seen = len(f.events)
        done = await executor.run_goal(parse_goal(_goal(f, range(8, 16, 2)), f.wm))
    began: dict[int, StepStarted] = {}
    busy: dict[str, float] = {}
    steps: dict[str, int] = {}
    for e in f.events[seen:]:
        if isinstance(e, StepStarted):
            began[e.step] = e
        elif isinstance(e, StepFinished) and e.step in began:
            busy[e.agent] = busy.get(e.agent, 0.0) + e.stamp - began[e.step].stamp
            steps[e.agent] = steps.get(e.agent, 0) + 1
    assert isinstance(done, TaskFinished) and done.outcome == "succeeded", done.message
    return Allocated(
        durations="learned" if learn else "descriptions",
        steps=steps,
        busy=busy,
        estimated=done.estimated_makespan or math.nan,
        actual=done.actual_makespan or math.nan,
    )


async def allocation() -> list[Allocated]:
    """The measured task with learned durations, then from the descriptions."""
    return [await _measured(True), await _measured(False)]
