"""What a task claims of the site before its steps run (:func:`claim_of`), planning around what
other tasks hold (:func:`free_agents`), and one task's side of the claim book
(:class:`TaskClaims`: claiming, waiting, giving way when preempted).

A task claims the agents its steps are given to and the objects they act on: every element a
step names by id that is no place (a station, a shelf, a parking spot: places are kept by the
reservations robots take as they drive, ``skill_agent.skills`` navigate) and no agent's own
machine (a robot, its devices). Steps of a task file that leave the agent open claim none
(the step scheduler picks a free one when they start).

Giving way (a preemptible task asked by one of higher priority, :mod:`task_agent.claims`):
:meth:`TaskClaims.run` makes the step scheduler stop at its next step boundary
(:meth:`~task_agent.execution.StepScheduler.give_way`): the steps in flight finish, and then
only the ready steps of robots of the task that hold something start (they put down what they
carry: no robot is handed to another task holding a part; when none of those is ready and no
step runs, every ready step may start). :meth:`TaskClaims.give_way` then gives the claim back
(``TaskPaused`` "preempted by task X (priority N) at a step boundary"), waits for it and holds
it again (``TaskResumed``); the executor plans again from the world model as it is.
"""

from __future__ import annotations

import logging
from collections.abc import Awaitable, Callable, Iterable, Sequence

import anyio

from skill_agent import WorldView

from ..claims import ClaimBook
from ..discovery import AgentInfo, Discovery
from ..protocol import TaskPaused, TaskResumed
from ._safe_state import held_by
from ._state import StepSpec, WorldModel
from ._steps import EventSink, StepOutcome, StepScheduler

__all__ = ["TaskClaims", "claim_of", "free_agents"]

_log = logging.getLogger(__name__)

_NOT_OBJECTS = ("Location", "Agent", "Robot", "Device")


def claim_of(
    steps: Iterable[StepSpec], agents: Sequence[AgentInfo], view: WorldView
) -> tuple[set[str], set[str]]:
    """(agents, objects) the ``steps`` need for themselves (see the module doc)."""
    steps = list(steps)
    names = {s.agent for s in steps if s.agent}
    machines = {m for a in agents for m in (a.robot, a.id, *a.devices) if m}
    onto = view.ontology
    kinds = {c: onto.subclasses(c) for c in _NOT_OBJECTS if c in onto.classes}
    objects: set[str] = set()
    for step in steps:
        for value in step.params.values():
            if not isinstance(value, str) or value in machines:
                continue
            element = view.find_element(value)
            if element is None or any(element.type in k for k in kinds.values()):
                continue
            objects.add(element.id)
    return names, objects


def free_agents(agents: Sequence[AgentInfo], busy: Iterable[str]) -> list[AgentInfo]:
    """``agents`` but those ``busy`` (held by other tasks)."""
    held = set(busy)
    return [a for a in agents if a.name not in held]


class TaskClaims:
    """One task's side of the service's :class:`~task_agent.claims.ClaimBook` (``book``; None:
    no other task shares the site). ``catch_up`` waits until the world model shows the task's
    finished steps."""

    def __init__(
        self,
        *,
        book: ClaimBook | None,
        steps: StepScheduler,
        events: EventSink,
        discovery: Discovery,
        wm: WorldModel,
        priority: int,
        preemptible: bool,
        catch_up: Callable[[], Awaitable[None]],
    ) -> None:
        self.book = book
        self.task_id = events.task_id
        self.steps = steps
        self.events = events
        self.discovery = discovery
        self.wm = wm
        self.priority = priority
        self.preemptible = book is not None and preemptible
        """A task of higher priority may take this task's claim at a step boundary."""
        self.catch_up = catch_up
        self.waiting = ""
        """What the task waits for before its steps can start ("" when it waits for none)."""

    def held(self) -> set[str]:
        claim = self.book.claim_of(self.task_id) if self.book is not None else None
        return set() if claim is None else set(claim.agents) | set(claim.objects)

    def busy_agents(self) -> frozenset[str]:
        """The agents other tasks hold."""
        return self.book.busy(self.task_id)[0] if self.book is not None else frozenset()

    def release(self) -> None:
        if self.book is not None:
            self.book.release(self.task_id)

    async def claim(self, steps: list[StepSpec], *, preemptible: bool = False) -> bool:
        """Hold what ``steps`` need before they run, waiting (``waiting`` says for what) while
        other tasks hold any of it; ``preemptible``: if this task may be preempted at all.
        True if it had to wait (the world may have changed meanwhile)."""
        if self.book is None:
            return False
        agents, objects = claim_of(steps, self.discovery.agents(include_unavailable=True), self.wm)
        held_agents, held_objects = self.book.busy(self.task_id)
        blocked = sorted((agents & held_agents) | (objects & held_objects))
        if blocked:
            self.waiting = f"{', '.join(blocked)} (held by another task)"
            _log.info("task %s waits for %s", self.task_id, self.waiting)
        try:
            claim = await self.book.acquire(
                self.task_id,
                agents,
                objects,
                priority=self.priority,
                preemptible=preemptible and self.preemptible,
            )
        finally:
            self.waiting = ""
        return claim.waited

    async def run(self, steps: list[StepSpec]) -> StepOutcome | None:
        """:meth:`StepScheduler.run`, stopping at a step boundary when a task of higher
        priority asks for the claim (:attr:`StepScheduler.gave_way` then says so)."""
        if not self.preemptible:
            return await self.steps.run(steps)
        async with anyio.create_task_group() as tg:
            tg.start_soon(self._watch)
            failure = await self.steps.run(steps)
            tg.cancel_scope.cancel()
        return failure

    async def _watch(self) -> None:
        assert self.book is not None
        by = await self.book.preempted(self.task_id)
        _log.info("task %s gives way to task %s at its next step boundary", self.task_id, by)
        self.steps.give_way(self._boundary)

    async def _boundary(self, ready: list[StepSpec], running: bool) -> list[StepSpec]:
        """While giving way: which ready steps still start (see the module doc)."""
        await self.catch_up()
        agents = self.discovery.agents(include_unavailable=True)
        holding = {a.name for a in agents if a.name in self.steps.used and held_by(a, self.wm)}
        finishing = [s for s in ready if s.agent in holding]
        if finishing or running or not holding:
            return finishing
        return ready

    async def give_way(self) -> None:
        """Preempted at a step boundary: give the claim back, wait until the task that asked
        for it (and any other of higher priority) is done with it, hold it again."""
        held = self.book.claim_of(self.task_id) if self.book is not None else None
        if self.book is None or held is None:
            return
        by = self.book.asked_by(self.task_id)
        priority = next((c.priority for c in self.book.waiting() if c.task_id == by), None)
        of = f" (priority {priority})" if priority is not None else ""
        reason = f"preempted by task {by}{of} at a step boundary"
        self.events.emit(TaskPaused, reason=reason, runs=[])
        things = ", ".join(sorted(held.agents or held.objects))
        self.waiting = f"{things} (preempted by task {by}{of})"
        _log.info("task %s: %s; waits for %s", self.task_id, reason, things)
        try:
            await self.book.acquire(
                self.task_id, held.agents, held.objects, priority=self.priority, preemptible=True
            )
        finally:
            self.waiting = ""
        self.events.emit(TaskResumed, runs=[])
