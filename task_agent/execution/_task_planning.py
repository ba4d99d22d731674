"""Planning for one task (:class:`TaskPlanning`, used by :class:`~task_agent.execution.Executor`):
with the agents discovery offers now, around what other tasks hold, timed from what the task
agent learned, reusing what the last plan had left; each plan as its partial order and a
``Planned`` event, its steps numbered after the task's steps so far."""

from __future__ import annotations

import functools
import logging
import time
from collections.abc import Awaitable, Callable, Mapping, Sequence
from typing import Protocol

import anyio
import msgspec

from skill_agent import WorldView
from wm_store import display_name

from .._errors import DomainError, UnsolvableError
from .._goals import Goal
from ..discovery import AgentInfo, Discovery
from ..domain import Lit
from ..learning import TaskLearning
from ..planning import PartialOrderPlan, Plan, PlanStep, to_partial_order
from ..protocol import Planned
from ._claiming import TaskClaims, free_agents
from ._state import StepSpec, WorldModel, steps_from_plan
from ._steps import EventSink, StepScheduler

__all__ = ["PlanSource", "TaskPlanning"]

_log = logging.getLogger(__name__)


class PlanSource(Protocol):
    """What the executor needs of :class:`~task_agent.planning.Planner`."""

    @property
    def engine(self) -> str: ...

    async def plan(
        self,
        agents: Sequence[AgentInfo],
        view: WorldView,
        goal: Goal,
        *,
        exclude: Sequence[tuple[str, str, Mapping[str, object]]] = (),
        progress: Callable[[int, int], None] | None = None,
        previous: Sequence[tuple[Sequence[Lit], Sequence[PlanStep]]] = (),
    ) -> Plan: ...


class TaskPlanning:
    """The plans of one task (see the module doc). ``catch_up`` waits until the replica
    shows every finished step's effects; ``agent_wait``: seconds to wait for an agent when
    none is available (a router restart makes every liveliness token vanish for a while)."""

    def __init__(
        self,
        *,
        task_id: str,
        planner: PlanSource | None,
        wm: WorldModel,
        discovery: Discovery,
        learning: TaskLearning,
        claiming: TaskClaims,
        steps: StepScheduler,
        events: EventSink,
        catch_up: Callable[[], Awaitable[None]],
        agent_wait: float,
    ) -> None:
        self.task_id = task_id
        self.planner = planner
        self.wm = wm
        self.discovery = discovery
        self.learning = learning
        self.claiming = claiming
        self.steps = steps
        self.events = events
        self.catch_up = catch_up
        self.agent_wait = agent_wait
        self.progress = ""
        """While a long plan is made: how far it got (set from the planner's thread)."""
        self._last: tuple[Plan, PartialOrderPlan, int] | None = None
        """The last plan, its partial order and the index of its first step."""
        self._next_step = 0

    async def plan(
        self, goal: Goal, attempt: int, excluded: set[tuple[str, str]]
    ) -> list[StepSpec]:
        """Plan ``goal`` from the world model as it is (after the finished steps' effects,
        once agents out of reach are back or lost): first around the agents other tasks hold,
        then with them; without the skills in ``excluded`` first, then with them. Emits
        ``Planned``; returns the plan's steps, numbered after the task's steps so far.

        Raises:
            UnsolvableError, DomainError: no plan reaches the goal. PlanningError: the
                planner failed.
        """
        assert self.planner is not None
        await self.catch_up()
        await self.await_agents()
        started = time.perf_counter()
        failed = self.learning.excluded()
        busy = self.claiming.busy_agents()
        agents = self.agents(excluded)
        free = free_agents(agents, busy)
        plan_ = functools.partial(
            self.planner.plan, exclude=failed, progress=self.on_progress, previous=self.left()
        )
        around = free if busy and free else agents  # all busy: nothing to plan around with
        try:  # around what other tasks hold first, else with it (and wait for it: TaskClaims.claim)
            plan = await plan_(around, self.wm, goal)
        except (UnsolvableError, DomainError) as e:
            if around is not agents:
                _log.info(
                    "task %s: no plan without %s (busy); trying with them", self.task_id, busy
                )
                plan = await plan_(agents, self.wm, goal)
            elif excluded and isinstance(e, UnsolvableError):
                _log.info("task %s: no plan without %s; trying with them", self.task_id, excluded)
                plan = await plan_(self.agents(set()), self.wm, goal)
            else:
                raise
        finally:
            self.progress = ""
        timing = self.learning.timer(plan.task.objects)
        order = await anyio.to_thread.run_sync(
            functools.partial(to_partial_order, plan, timing=timing)
        )
        seconds = time.perf_counter() - started
        self._last = (plan, order, self._next_step)
        steps = self.steps_of(order)
        self.events.emit(
            Planned,
            steps=[s.planned() for s in steps],
            names=self.names(steps),
            attempt=attempt,
            planner=self.planner.engine,
            plan_seconds=seconds,
            makespan=order.makespan,
            sequential=order.sequential,
            parts=plan.stats.parts,
        )
        return steps

    def left(self) -> list[tuple[tuple[Lit, ...], list[PlanStep]]]:
        """What the last plan has left to run, by its blocks of goal parts (a replan keeps
        the parts a failure did not touch: :meth:`Planner.solve`'s ``previous``)."""
        if self._last is None:
            return []
        plan, order, first = self._last
        ran = {
            s.step.ground for i, s in enumerate(order.steps) if first + i in self.steps.succeeded
        }
        return plan.remaining(ran)

    def on_progress(self, done: int, parts: int) -> None:
        """The planner's progress (its worker thread): shown by ``task status`` / ``list``."""
        self.progress = f"planning: {done} of {parts} goal parts planned"

    async def await_agents(self) -> None:
        """Before planning: while agents are unknown (a lost router or a partition), until
        each is back or lost (the grace period bounds it); when none is available, up to
        ``agent_wait`` seconds for one."""
        with anyio.move_on_after(self.agent_wait):
            while not self.discovery.agents() and not self.discovery.unknown:
                await self.discovery.wait_changed()
        if self.discovery.unknown:
            _log.warning(
                "task %s: agents %s out of reach; waiting up to %g s before planning",
                self.task_id,
                ", ".join(sorted(self.discovery.unknown)),
                self.discovery.grace,
            )
        with anyio.move_on_after(self.discovery.grace + self.discovery.settle + 1.0):
            while self.discovery.unknown:
                await self.discovery.wait_changed()

    def agents(self, excluded: set[tuple[str, str]]) -> list[AgentInfo]:
        agents = self.discovery.agents()
        return [
            msgspec.structs.replace(
                a, skills=tuple(s for s in a.skills if (a.name, s.name) not in excluded)
            )
            for a in agents
        ]

    def names(self, steps: list[StepSpec]) -> dict[str, str]:
        """The display names of the elements the steps' parameters give by id."""
        names: dict[str, str] = {}
        for step in steps:
            for value in step.planned().params.values():
                element = self.wm.find_element(value) if isinstance(value, str) else None
                if element is not None:
                    names[element.id] = display_name(element)
        return names

    def steps_of(self, order: PartialOrderPlan) -> list[StepSpec]:
        """The plan's steps, numbered after the task's steps so far."""
        return self.number(steps_from_plan(order, self._next_step))

    def number(self, steps: list[StepSpec]) -> list[StepSpec]:
        self._next_step += len(steps)
        return steps
