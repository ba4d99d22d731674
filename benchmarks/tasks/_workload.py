"""One measured run: ``robots`` simulated-outcome agents (the task-layer test fleet,
``tests.assets.task_fleet``), one task service, a case's goals submitted all at once
(``concurrent``) or each after the one before ended (``sequential``).

Cases (every goal puts one gear into one robot's kit box, which only that robot carries):

- ``independent``: one goal per robot, each gear in a part box of its robot's own (one box per
  robot, added beside the fleet's two stations' boxes): the goals' claims share nothing;
- ``shared-boxes``: one goal per robot, the gears in the fleet's two part boxes (one per
  station): every task claims the box it picks from, so tasks picking from one box wait for
  each other;
- ``overlapping``: two goals for robot r1's kit box: both claim r1, the second waits;
- the preemption case (:func:`run_preemption`): a four-gear goal for r1's kit box runs; once
  its first step ended, a priority-5 goal for one more gear into that kit box is submitted.
  With preemption the long task gives way at a step boundary; the baseline submits the long
  task not preemptible, so the urgent one waits for its end.

Per run: each task's outcome, what it was seen waiting for (the service's ``TaskInfo.waiting``,
sampled), its planning time, the makespan (first submission to the last ``TaskFinished``) and
whether two tasks' steps ever overlapped on one robot.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence

import anyio
import msgspec

from task_agent.protocol import (
    Planned,
    StepFinished,
    StepStarted,
    SubmitGoal,
    TaskFinished,
    TaskOptions,
    TaskPaused,
)
from task_agent.service import TaskService
from tests.assets.task_fleet import Fleet, fleet
from wm_store.protocol import AddElement, Relation

__all__ = ["CASES", "MODES", "Preempted", "Run", "run_case", "run_preemption"]

CASES = ("independent", "shared-boxes", "overlapping")
MODES = ("sequential", "concurrent")
SAMPLE = 0.005
"""Seconds between two looks at the service's waiting tasks."""


class Run(msgspec.Struct, kw_only=True):
    case: str
    mode: str
    robots: int
    outcomes: dict[str, str]
    """Task id -> outcome, in submission order."""
    makespan: float = math.nan
    """First submission to the last ``TaskFinished``, seconds."""
    planning: float = 0.0
    """Seconds the tasks spent planning (``Planned.plan_seconds``, summed)."""
    waited: dict[str, str] = {}
    """Task id -> what it was first seen waiting for."""
    replans: int = 0
    """Replans of all the tasks together."""
    finish_order: list[str] = []
    interleaved: list[str] = []
    """Robots on which steps of two tasks overlapped in time (never, if claims work)."""

    @property
    def tasks(self) -> int:
        return len(self.outcomes)

    @property
    def per_minute(self) -> float:
        return self.tasks / self.makespan * 60.0 if self.makespan > 0 else math.nan

    @property
    def succeeded(self) -> bool:
        return all(o == "succeeded" for o in self.outcomes.values())


async def _own_boxes(f: Fleet) -> list[str]:
    """A part box with one gear per robot, at the stations in turn; the gears' ids."""
    gears = []
    for i in range(len(f.robots)):
        station = f.stations[i % len(f.stations)]
        ids = (
            await f.wm.transact(
                [
                    AddElement(
                        type="PartBox",
                        label=f"own-box-{i + 1}",
                        ref="$box",
                        relations=[Relation(station, "contain", "$"), Relation("$", "at", station)],
                    ),
                    AddElement(
                        type="Gear",
                        label=f"own-gear-{i + 1}",
                        ref="$gear",
                        properties={"mass": 0.1},
                        relations=[Relation("$box", "contain", "$")],
                    ),
                ]
            )
        ).ids
        gears.append(ids["$gear"])
    return gears


async def _goals(case: str, f: Fleet) -> list[str]:
    if case == "independent":
        gears = await _own_boxes(f)
        return [f"contain({kit}, {gear})" for kit, gear in zip(f.kits, gears, strict=True)]
    if case == "shared-boxes":
        return [f"contain({kit}, {f.parts[i]})" for i, kit in enumerate(f.kits)]
    if case == "overlapping":
        return [f"contain({f.kits[0]}, {f.parts[0]})", f"contain({f.kits[0]}, {f.parts[2]})"]
    raise ValueError(f"unknown case {case!r}; one of {', '.join(CASES)}")


async def _finished(f: Fleet, task_ids: Sequence[str]) -> None:
    while not set(task_ids) <= {e.task_id for e in f.of(TaskFinished)}:
        await f.changed.wait()


async def _watch_waiting(tasks: TaskService, waited: dict[str, str]) -> None:
    while True:
        for info in tasks.tasks(active_only=True):
            if info.waiting:
                waited.setdefault(info.task_id, info.waiting)
        await anyio.sleep(SAMPLE)


def _interleaved(f: Fleet) -> list[str]:
    """Robots on which steps of two different tasks overlapped in time."""
    began = {(e.task_id, e.step): e for e in f.of(StepStarted) if isinstance(e, StepStarted)}
    spans: dict[str, list[tuple[float, float, str]]] = {}
    for e in f.of(StepFinished):
        assert isinstance(e, StepFinished)
        start = began.get((e.task_id, e.step))
        if start is not None:
            spans.setdefault(e.agent, []).append((start.stamp, e.stamp, e.task_id))
    return sorted(
        agent
        for agent, runs in spans.items()
        if any(a[2] != b[2] and a[0] < b[1] and b[0] < a[1] for a in runs for b in runs)
    )


async def run_case(case: str, mode: str, robots: int, time_scale: float) -> Run:
    """One run of ``case`` in ``mode`` on a fresh fleet (see the module doc)."""
    async with fleet(robots=robots, parts=max(robots, 4), time_scale=time_scale) as f:
        goals = await _goals(case, f)
        ids = [f"{case}-{i + 1}" for i in range(len(goals))]
        tasks = f.service()
        waited: dict[str, str] = {}
        async with anyio.create_task_group() as tg:
            await tg.start(tasks.run)
            tg.start_soon(_watch_waiting, tasks, waited)
            began = time.time()
            for task_id, goal in zip(ids, goals, strict=True):
                await tasks.handle(SubmitGoal(goal=goal, task_id=task_id))
                if mode == "sequential":
                    await _finished(f, [task_id])
            await _finished(f, ids)
            tg.cancel_scope.cancel()
    ends = {e.task_id: e for e in f.of(TaskFinished) if isinstance(e, TaskFinished)}
    return Run(
        case=case,
        mode=mode,
        robots=robots,
        outcomes={t: ends[t].outcome for t in ids},
        makespan=max(e.stamp for e in ends.values()) - began,
        planning=sum(e.plan_seconds for e in f.of(Planned) if isinstance(e, Planned)),
        waited=waited,
        replans=sum(e.replans for e in ends.values()),
        finish_order=[e.task_id for e in sorted(ends.values(), key=lambda e: e.stamp)],
        interleaved=_interleaved(f),
    )


class Preempted(msgspec.Struct, kw_only=True):
    """One run of the preemption case: a long low-priority task on r1, then a high-priority
    goal for r1's kit, submitted once the low task's first step ended."""

    preemption: bool
    """The low task was submitted preemptible (else: the baseline, the high task waits)."""
    outcomes: dict[str, str]
    high_turnaround: float
    """The high task's submission to its end, seconds."""
    low_makespan: float
    """The low task's submission to its end, seconds."""
    makespan: float
    """The low task's submission to the last end, seconds."""
    high_first: bool
    gave_way: bool
    """The low task paused to give way (``TaskPaused``)."""
    interleaved: list[str] = []

    @property
    def succeeded(self) -> bool:
        return all(o == "succeeded" for o in self.outcomes.values())


async def run_preemption(preemption: bool, robots: int, time_scale: float) -> Preempted:
    """The preemption case once (see :class:`Preempted`), on a fresh fleet."""
    async with fleet(robots=robots, parts=8, time_scale=time_scale) as f:
        low = " and ".join(f"contain({f.kits[0]}, {f.parts[p]})" for p in (0, 2, 4, 6))
        high = f"contain({f.kits[0]}, {f.parts[1]})"
        tasks = f.service()
        async with anyio.create_task_group() as tg:
            await tg.start(tasks.run)
            began = time.time()
            low_options = TaskOptions(preemptible=preemption)
            await tasks.handle(SubmitGoal(goal=low, task_id="low", options=low_options))
            while not any(e.task_id == "low" for e in f.of(StepFinished)):
                await f.changed.wait()
            asked = time.time()
            high_options = TaskOptions(priority=5)
            await tasks.handle(SubmitGoal(goal=high, task_id="high", options=high_options))
            await _finished(f, ["low", "high"])
            tg.cancel_scope.cancel()
    ends = {e.task_id: e for e in f.of(TaskFinished) if isinstance(e, TaskFinished)}
    return Preempted(
        preemption=preemption,
        outcomes={t: ends[t].outcome for t in ("low", "high")},
        high_turnaround=ends["high"].stamp - asked,
        low_makespan=ends["low"].stamp - began,
        makespan=max(e.stamp for e in ends.values()) - began,
        high_first=ends["high"].stamp < ends["low"].stamp,
        gave_way=any(e.task_id == "low" for e in f.of(TaskPaused)),
        interleaved=_interleaved(f),
    )
