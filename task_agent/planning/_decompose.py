"""Planning that follows the goal: :func:`solve_in_parts`.

The goal is split into independent :func:`~._parts.parts`; :func:`~._allocate.allocate`
ranks the agents for each part before any search. The parts are then planned one after the
other, each from the state the previous parts' plans leave (so a robot's later part starts
where its earlier one ended, and a part sees the station another robot now occupies), as a
*small problem*: the part's literals as the goal, the actions of a *team* only, and the
elements near the part and the team in the :class:`~._parts.FactGraph` of that state. A
small problem is widened step by step until one has a plan (:data:`LEVELS`):

1. the part's ranked agents, one at a time (the first :data:`TRIES`), each alone over the
   elements within 3 hops;
2. *coupled*: the same agents with the helpers and every agent whose hardware is within 5
   hops (a robot standing on the spot it needs, a hand-over partner); a pending part
   assigned to one of those agents joins the problem, its elements widen the focus in turn,
   until nothing more joins; the parts are then planned together as one problem;
3. every agent, over the objects the lifted relevance analysis keeps
   (:func:`~task_agent.reachability.relevant_objects`).

Every small plan is replayed on the *full* task from that state before it is kept, so a plan
that leans on a fact the small problem left out (a gripper that is not empty after all) is
refused and the problem widened. The kept plans, in part order, form one sequential plan
that is valid on the full task by construction; the partial order
(:func:`~task_agent.planning.to_partial_order`) then runs the parts' steps in parallel
wherever no fact, robot or device orders them (shared spots, shared objects and a robot's
own parts stay ordered). When a part has no plan at any level, :func:`solve_in_parts` says so
(:class:`Stuck`) and the planner solves the whole task in the time left (the monolithic
path, which alone may report a goal unsolvable); when the time given runs out it says how
many parts were planned. Pure but for the engine calls.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import Literal

import msgspec

from ..domain import Lit, PlanningTask
from ..reachability import GroundStep, State, apply, fact_text, relevant_objects
from ._allocate import Allocation, Point, allocate, hardware
from ._parts import FactGraph, parts
from ._plan import PlanStep

__all__ = ["LEVELS", "TRIES", "Block", "Decomposition", "Progress", "Stuck", "solve_in_parts"]

LEVELS = ((3, 6), (5, 24))
"""(hops, hub) of the focus of the first two levels (see the module doc)."""
TRIES = 2
"""Ranked agents tried per part at each of the first two levels."""

Attempt = Callable[[PlanningTask, float], "tuple[bool, list[PlanStep]]"]
"""Solve a small problem within seconds: (solved, steps)."""


Progress = Callable[[int, int], None]
"""Told (parts planned, parts) as a decomposed solve goes."""


class Stuck(msgspec.Struct, kw_only=True):
    """Why a decomposed solve gave up: ``time`` ran out, or ``part`` had no plan at any
    level; ``done`` of ``parts`` were planned by then."""

    reason: Literal["time", "part"]
    part: str
    done: int
    parts: int

    def __str__(self) -> str:
        if self.reason == "time":
            return f"planning by parts planned {self.done} of {self.parts} goal parts in time"
        return f"planning by parts found no plan for {self.part} with any team of agents"


class Decomposition(msgspec.Struct, kw_only=True):
    """How a decomposed solve went."""

    steps: list[PlanStep]
    parts: int
    """Parts of the goal planned apart."""
    solves: int
    """Engine calls made."""
    widened: int
    """Parts that needed more than the first small problem."""
    objects: int
    """Objects of the largest small problem solved."""
    blocks: list[tuple[tuple[Lit, ...], list[int]]] = []
    """Each group of parts planned together: its literals and its steps' indices."""
    reused: int = 0
    """Parts whose steps were taken over from the previous plan (``previous``)."""


Block = tuple[Sequence[Lit], Sequence[PlanStep]]
"""A group of parts of an earlier plan of the same task: its literals and the steps of it
that have not run yet."""


def _reuse(
    task: PlanningTask,
    state: State,
    index: int,
    goal_parts: Sequence[Sequence[Lit]],
    pending: set[int],
    previous: Sequence[Block],
) -> tuple[list[PlanStep], set[int]] | None:
    """The earlier plan's remaining steps for part ``index`` and the pending parts planned
    with it, if they are exactly the parts of one earlier block and still reach them from
    ``state`` on the full task (a replan leaves the parts a failure did not touch as they
    were)."""
    mine = set(goal_parts[index])
    for lits, remaining in previous:
        block = set(lits)
        if not mine <= block:
            continue
        covered = {j for j in pending if set(goal_parts[j]) <= block}
        if set().union(*(set(goal_parts[j]) for j in covered)) != block:
            return None
        goal = [lit for j in sorted(covered) for lit in goal_parts[j]]
        if any(s.action not in task.actions for s in remaining):  # its agent is left out now
            return None
        if not _reaches(task, state, remaining, goal):
            return None
        return list(remaining), covered
    return None


def _holds(part: Sequence[Lit], state: State) -> bool:
    return all(((lit.pred, lit.args) in state) == lit.positive for lit in part)


def _reaches(
    task: PlanningTask, state: State, steps: Sequence[PlanStep], part: Sequence[Lit]
) -> bool:
    """Whether ``steps``, run from ``state`` on the full task, find every precondition true
    and leave the part holding (stops at the first false precondition: the loop of
    :func:`~task_agent.reachability.replay`, from a state of the solve)."""
    after = state.copy()
    for step in steps:
        failed, _ = apply(task, GroundStep(step.action, step.args), after)
        if failed:
            return False
    return _holds(part, after)


class _Parts:
    """The state of one decomposed solve."""

    def __init__(
        self,
        task: PlanningTask,
        attempt: Attempt,
        deadline: float,
        goal_parts: Sequence[Sequence[Lit]],
        allocation: Allocation,
    ) -> None:
        self.task = task
        self.goal_parts = goal_parts
        self.allocation = allocation
        self.attempt = attempt
        self.deadline = deadline
        self.kit = hardware(task)
        self.constants: dict[str, set[str]] = {}
        for schema in task.actions.values():
            mine = self.constants.setdefault(schema.agent, set())
            mine.update(a for lit in schema.pre for a in lit.args if a[0] != "?")
        self.solves = 0
        self.largest = 0

    def small(
        self, state: State, part: Sequence[Lit], team: Iterable[str], keep: set[str]
    ) -> PlanningTask:
        members = set(team)
        actions = {n: s for n, s in self.task.actions.items() if s.agent in members}
        for agent in members:
            keep |= self.kit.get(agent, set()) | self.constants.get(agent, set())
        keep |= {a for lit in part for a in lit.args}
        objects = {o: t for o, t in self.task.objects.items() if o in keep}
        init = frozenset(f for f in state.facts if all(a in objects for a in f[1]))
        return msgspec.structs.replace(
            self.task,
            name=f"{self.task.name}-part",
            actions=actions,
            objects=objects,
            init=init,
            goal=tuple(part),
        )

    def solve(
        self, state: State, part: Sequence[Lit], team: Iterable[str], keep: set[str]
    ) -> list[PlanStep] | None:
        remaining = self.deadline - time.perf_counter()
        if remaining <= 0:
            raise TimeoutError
        sub = self.small(state, part, team, keep)
        self.solves += 1
        solved, steps = self.attempt(sub, remaining)
        if not solved:
            return None
        self.largest = max(self.largest, len(sub.objects))
        return steps if _reaches(self.task, state, steps, part) else None

    def plan_part(
        self, state: State, graph: FactGraph, index: int, pending: set[int]
    ) -> tuple[list[PlanStep], int, set[int]] | None:
        """Part ``index``'s steps from ``state`` (``graph``: its facts' links), the level
        that found them (0 first) and the parts they achieve (``index`` and the pending
        parts coupled to it)."""
        part, ranked = self.goal_parts[index], self.allocation.ranking[index]
        seeds = {a for lit in part for a in lit.args}
        depth, hub = LEVELS[0]
        for agent in ranked[:TRIES]:
            focus = graph.focus(seeds | self.kit.get(agent, set()), depth=depth, hub=hub)
            found = self.solve(state, part, [agent], focus)
            if found is not None:
                return found, 0, {index}
        for agent in ranked[:TRIES]:
            merged, team, focus = self.couple(graph, index, agent, pending)
            goal = [lit for j in sorted(merged) for lit in self.goal_parts[j]]
            found = self.solve(state, goal, team, focus)
            if found is not None:
                return found, 1, merged
        whole = self.small(state, part, self.kit, set(self.task.objects))
        found = self.solve(state, part, self.kit, relevant_objects(whole))
        return (found, 2, {index}) if found is not None else None

    def couple(
        self, graph: FactGraph, index: int, agent: str, pending: set[int]
    ) -> tuple[set[int], set[str], set[str]]:
        """The second level's problem for part ``index`` given to ``agent``: (the parts
        planned together, the team, the focus). The team takes in the helpers and every
        agent whose hardware is in the focus; a pending part assigned to one of them joins
        (its elements widen the focus in turn), until nothing more joins."""
        depth, hub = LEVELS[1]
        ranking = self.allocation.ranking
        merged, team = {index}, {agent, *self.allocation.helpers}
        while True:
            seeds = {a for j in merged for lit in self.goal_parts[j] for a in lit.args}
            for member in team:
                seeds |= self.kit.get(member, set())
            focus = graph.focus(seeds, depth=depth, hub=hub)
            near = {a for a, kit in self.kit.items() if kit & focus}
            joining = {j for j in pending - merged if ranking[j] and ranking[j][0] in near}
            if near <= team and not joining:
                return merged, team, focus
            team |= near | {ranking[j][0] for j in joining}
            merged |= joining


def solve_in_parts(
    task: PlanningTask,
    attempt: Attempt,
    *,
    seconds: float,
    where: Mapping[str, Point] | None = None,
    progress: Progress | None = None,
    previous: Sequence[Block] = (),
) -> Decomposition | Stuck:
    """A plan for ``task`` made part by part (see the module doc), or why not: a part has no
    plan at any level (the caller then solves the whole task) or ``seconds`` ran out.
    ``progress(done, parts)`` is called after each part is planned. ``previous``: the blocks
    of an earlier plan of the same goal (a replan): a part whose block's remaining steps
    still reach it is not planned again."""
    goal_parts = parts(task.goal)
    state = State(task.init)
    graph = FactGraph(state.facts, task.objects)
    allocation = allocate(task, goal_parts, graph, where)
    run = _Parts(task, attempt, time.perf_counter() + seconds, goal_parts, allocation)
    steps: list[PlanStep] = []
    blocks: list[tuple[tuple[Lit, ...], list[int]]] = []
    widened = reused = 0
    pending = set(range(len(goal_parts)))
    try:
        for index, part in enumerate(goal_parts):
            if index not in pending:
                continue
            if _holds(part, state):
                pending.discard(index)
                continue
            kept = _reuse(task, state, index, goal_parts, pending, previous)
            found = (kept[0], 0, kept[1]) if kept else run.plan_part(state, graph, index, pending)
            if found is None:
                text = " and ".join(fact_text(lit.pred, lit.args) for lit in part)
                planned = len(goal_parts) - len(pending)
                return Stuck(reason="part", part=text, done=planned, parts=len(goal_parts))
            part_steps, level, achieved = found
            widened += level > 0
            reused += len(achieved) if kept else 0
            pending -= achieved
            if progress is not None:
                progress(len(goal_parts) - len(pending), len(goal_parts))
            lits = tuple(lit for j in sorted(achieved) for lit in goal_parts[j])
            blocks.append((lits, list(range(len(steps), len(steps) + len(part_steps)))))
            for step in part_steps:
                _, effects = apply(task, GroundStep(step.action, step.args), state)
                graph.add(effects.adds)
                steps.append(msgspec.structs.replace(step, index=len(steps)))
    except TimeoutError:
        planned = len(goal_parts) - len(pending)
        return Stuck(reason="time", part="", done=planned, parts=len(goal_parts))
    return Decomposition(
        steps=steps,
        parts=len(goal_parts),
        solves=run.solves,
        widened=widened,
        objects=run.largest,
        blocks=blocks,
        reused=reused,
    )
