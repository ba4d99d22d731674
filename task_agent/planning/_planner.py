"""The planner: :class:`Planner` solves a :class:`~task_agent.domain.PlanningTask` through
unified-planning and returns a :class:`~task_agent.planning.Plan`.

``solve`` is the blocking core; ``async plan`` builds the task on the caller's loop (it reads
the world-model replica, which only the loop may touch) and solves in a worker thread through
``anyio.to_thread.run_sync`` with the planner's capacity limiter (one solve at a time by
default).

A large task, or one whose goal has parts for several agents, is first planned by parts
(:mod:`._decompose`); when a part has no plan at any width the whole task is solved in the
time left, by the path the rest of this paragraph describes. Before
solving, the task is compressed to the objects the goal can touch
(:func:`~task_agent.reachability.relevant_objects`), unless the goal itself names most objects
(:data:`COMPRESS_BELOW`); the plan is replayed on the full task and, if that fails or the small
task has no plan, the full task is solved. A goal without a plan
raises :class:`~task_agent.UnsolvableError` with the goal facts that can never hold
and why (:func:`~task_agent.reachability.diagnose`); running out of time raises
:class:`~task_agent.PlannerTimeoutError`; any other engine failure
:class:`~task_agent.PlanningError` with the engine's log.

unified-planning has process-wide defaults (``get_environment()`` and its engine factory);
these modules never touch them. Each :class:`Planner` builds its problems in its own
``Environment``, used by one solve at a time (a lock) and replaced every
:data:`ENVIRONMENT_SOLVES` solves, since an environment caches every expression ever built.
Creating an environment inspects the Python stack, as the engine factory would on every call
(``_engines`` instantiates engines directly; see docs/benchmarks.md, Planning: Performance
problems found). unified-planning is untyped: ``Any`` stays in the planner modules.
"""

from __future__ import annotations

import functools
import logging
import math
import threading
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import anyio
import msgspec
from unified_planning.engines import PlanGenerationResultStatus as Status
from unified_planning.environment import Environment
from unified_planning.io import PDDLWriter

from skill_agent import WorldView
from skill_agent.conditions import ConditionRegistry

from .._errors import PlannerTimeoutError, PlanningError, UnsolvableError
from .._goals import Goal
from ..discovery import AgentInfo
from ..domain import PlanningTask
from ..learning import positions
from ..reachability import diagnose, relevant_objects, replay
from ._allocate import Point, hardware
from ._convert import plan_steps, to_unified_planning
from ._decompose import Block, Progress, Stuck, solve_in_parts
from ._engines import SOLVED, UNSOLVABLE, solve_problem
from ._exclusions import exclude_steps
from ._nearby import nearby_agents
from ._parts import parts
from ._plan import Engine, Plan, PlanStats, PlanStep

__all__ = ["COMPRESS_BELOW", "DECOMPOSE_FROM", "ENVIRONMENT_SOLVES", "PROGRESS_EVERY", "Planner"]

_log = logging.getLogger(__name__)
DECOMPOSE_FROM = 100
"""Objects from which a task is planned by parts: a smaller one is solved whole faster than
its parts one by one (see docs/benchmarks.md, Planning at fleet scale)."""
PROGRESS_EVERY = 1.0
"""Seconds between the default progress log lines of a long decomposed solve."""

ENVIRONMENT_SOLVES = 32
"""Solves per unified-planning environment before a planner starts a fresh one."""
COMPRESS_BELOW = 0.5
"""Compress only when the goal names fewer than this share of the task's objects: a goal
naming most of them keeps nearly all the others too, and the analysis has a cost (see
docs/benchmarks.md, Planning: Performance problems found)."""


class _Attempt(msgspec.Struct, kw_only=True):
    status: Any
    steps: list[PlanStep]
    log: str
    convert_s: float
    solve_s: float
    engine_s: float


class _Logged:
    """Progress once planning has taken :data:`PROGRESS_EVERY` s, then at that pace: an
    INFO line, and the caller's ``progress`` if given."""

    def __init__(self, start: float, progress: Progress | None) -> None:
        self.next = start + PROGRESS_EVERY
        self.progress = progress

    def __call__(self, done: int, parts: int) -> None:
        now = time.perf_counter()
        if now >= self.next and done < parts:
            self.next = now + PROGRESS_EVERY
            _log.info("planning: %d of %d goal parts planned", done, parts)
            if self.progress is not None:
                self.progress(done, parts)


class Planner:
    """Solves planning tasks with one engine.

    ``engine``: ``"kairos"`` (default) or ``"fast-downward"``. ``timeout``: seconds per
    :meth:`solve` (both attempts when the compressed task falls back to the full one).
    ``compress``: solve over the objects the goal can touch first. ``decompose``: plan
    a task of ``decompose_from`` objects or more by parts (:mod:`._decompose`).
    ``limiter``: bounds the concurrent solves of :meth:`plan` (default: one at a time,
    its own)."""

    def __init__(
        self,
        *,
        engine: Engine = "kairos",
        timeout: float = 30.0,
        compress: bool = True,
        decompose: bool = True,
        decompose_from: int = DECOMPOSE_FROM,
        limiter: anyio.CapacityLimiter | None = None,
    ) -> None:
        if engine not in ("kairos", "fast-downward"):
            raise ValueError(f"unknown engine {engine!r}; use 'kairos' or 'fast-downward'")
        self.engine: Engine = engine
        self.timeout = timeout
        self.compress = compress
        self.decompose = decompose
        self.decompose_from = decompose_from
        self._limiter = limiter
        self._lock = threading.Lock()
        self._env: Any = None
        self._env_solves = 0

    # ------------------------------------------------------------------ engine calls

    def _environment(self) -> Any:
        """This planner's environment (call with the lock held)."""
        if self._env is None or self._env_solves >= ENVIRONMENT_SOLVES:
            self._env = Environment()
            self._env.credits_stream = None
            self._env_solves = 0
        self._env_solves += 1
        return self._env

    def _attempt(self, task: PlanningTask, timeout: float) -> _Attempt:
        t0 = time.perf_counter()
        problem = to_unified_planning(task, self._environment())
        t1 = time.perf_counter()
        result = solve_problem(self.engine, problem, timeout)
        t2 = time.perf_counter()
        steps = plan_steps(task, result.plan) if result.status in SOLVED else []
        log = "; ".join(str(m.message) for m in result.log_messages or ())
        engine_s = float(result.metrics.get("engine_internal_time", math.nan))
        return _Attempt(
            status=result.status,
            steps=steps,
            log=log,
            convert_s=t1 - t0,
            solve_s=t2 - t1,
            engine_s=engine_s,
        )

    # ------------------------------------------------------------------ public API

    def solve(
        self,
        task: PlanningTask,
        *,
        where: Mapping[str, Point] | None = None,
        progress: Progress | None = None,
        previous: Sequence[Block] = (),
    ) -> Plan:
        """A plan for ``task`` (blocking; see the module doc for the errors). ``previous``:
        what an earlier plan of the goal has left to run (:meth:`Plan.remaining`): planning
        by parts, a part whose steps there still reach it is not planned again. ``where``: the
        (x, y) of elements that have a pose, for the allocation's bids. ``progress(done,
        parts)``: told how many of the goal's parts are planned, every
        :data:`PROGRESS_EVERY` seconds once planning has taken that long (a log line too).
        Thread-safe: concurrent calls on one planner run one after the other."""
        with self._lock:
            start = time.perf_counter()
            stuck: Stuck | None = None
            if self.decompose and self._by_parts(task):
                told = _Logged(start, progress)
                found = self._solve_in_parts(task, start, where, told, previous)
                if isinstance(found, Plan):
                    return found
                stuck = found
                if found.reason == "time":
                    raise PlannerTimeoutError(
                        f"{found} ({self.timeout} s for {len(task.objects)} objects, "
                        f"{len(task.actions)} actions); give it more time",
                        timeout=self.timeout,
                    )
            return self._solve(task, start, stuck)

    def _by_parts(self, task: PlanningTask) -> bool:
        """Plan ``task`` by parts: it is large, or its goal has parts for several agents."""
        if len(task.objects) >= self.decompose_from:
            return True
        agents = {s.agent for s in task.actions.values()}
        return len(agents) > 1 and len(parts(task.goal)) > 1

    def _solve_in_parts(
        self,
        task: PlanningTask,
        start: float,
        where: Mapping[str, Point] | None,
        progress: Progress,
        previous: Sequence[Block],
    ) -> Plan | Stuck:
        """The decomposed path (:mod:`._decompose`), within the time-out."""

        def attempt(sub: PlanningTask, seconds: float) -> tuple[bool, list[PlanStep]]:
            result = self._attempt(sub, seconds)
            return result.status in SOLVED, result.steps

        found = solve_in_parts(
            task, attempt, seconds=self.timeout, where=where, progress=progress, previous=previous
        )
        if isinstance(found, Stuck):
            return found
        problem = replay(task, [s.ground for s in found.steps])[1]
        if problem:  # cannot happen: each part was replayed on the full task
            raise PlanningError(f"the plan made by parts does not replay ({problem}): a bug")
        stats = PlanStats(
            engine=self.engine,
            objects=len(task.objects),
            objects_solved=found.objects,
            parts=found.parts,
            part_solves=found.solves,
            widened=found.widened,
            reused=found.reused,
            total_s=time.perf_counter() - start,
        )
        blocks = tuple((lits, tuple(indices)) for lits, indices in found.blocks)
        return Plan(steps=tuple(found.steps), task=task, stats=stats, blocks=blocks)

    def _solve(self, task: PlanningTask, start: float, stuck: Stuck | None = None) -> Plan:
        deadline = start + self.timeout
        solved = task
        named = {a for lit in task.goal for a in lit.args}
        if self.compress and len(named) < COMPRESS_BELOW * len(task.objects):
            keep = relevant_objects(task)
            if len(keep) < len(task.objects):
                solved = task.restrict(keep)
        attempt = self._attempt(solved, max(deadline - time.perf_counter(), 0.001))
        fallback = False
        problem = "not solved"
        if attempt.status in SOLVED:
            _, problem = replay(task, [s.ground for s in attempt.steps])
        if solved is not task and problem and attempt.status != Status.TIMEOUT:
            fallback, solved = True, task
            attempt = self._attempt(task, deadline - time.perf_counter())
            if attempt.status in SOLVED:
                _, problem = replay(task, [s.ground for s in attempt.steps])
        self._raise_for(attempt, task, stuck)
        if problem:
            raise PlanningError(
                f"the {self.engine} plan does not replay on the task ({problem}); this is a "
                "bug in the domain generation, please report it with emit_pddl's files"
            )
        stats = PlanStats(
            engine=self.engine,
            objects=len(task.objects),
            objects_solved=len(solved.objects),
            fallback=fallback,
            convert_s=attempt.convert_s,
            solve_s=attempt.solve_s,
            engine_s=attempt.engine_s,
            total_s=time.perf_counter() - start,
        )
        return Plan(steps=tuple(attempt.steps), task=task, stats=stats)

    def _raise_for(self, attempt: _Attempt, task: PlanningTask, stuck: Stuck | None) -> None:
        if attempt.status in SOLVED:
            return
        if attempt.status == Status.TIMEOUT:
            before = f"{stuck}; then " if stuck is not None else ""
            raise PlannerTimeoutError(
                f"{before}{self.engine} found no plan for the whole task within "
                f"{self.timeout} s ({len(task.objects)} objects, {len(task.actions)} actions); "
                "give it more time",
                timeout=self.timeout,
            )
        if attempt.status in UNSOLVABLE:
            reason, unreachable = diagnose(task)
            proven = attempt.status == Status.UNSOLVABLE_PROVEN
            raise UnsolvableError(
                f"no plan reaches the goal{' (proven)' if proven else ''}: {reason}",
                unreachable=unreachable,
                proven=proven,
            )
        raise PlanningError(
            f"{self.engine} failed ({attempt.status.name}): {attempt.log or 'no message'}"
        )

    def plan_sync(
        self,
        agents: Sequence[AgentInfo],
        view: WorldView,
        goal: Goal,
        *,
        registry: ConditionRegistry | None = None,
        exclude: Sequence[tuple[str, str, Mapping[str, object]]] = (),
    ) -> Plan:
        """Build the task from the agents and the world model, then :meth:`solve` it.
        ``exclude``: grounded steps (agent, skill, parameters) the plan must not contain
        (:func:`~task_agent.planning.exclude_steps`). Planning by parts, the task is built
        for the agents near the goal first (:func:`~._nearby.nearby_agents`), then for all
        of them if those have no plan."""
        for chosen in self._agent_sets(agents, view, goal):
            task, where = self._build(chosen, view, goal, registry, exclude)
            try:
                return self.solve(task, where=where)
            except (UnsolvableError, PlannerTimeoutError):
                if chosen is agents:
                    raise
        raise AssertionError("unreachable: the last agent set is every agent")

    async def plan(
        self,
        agents: Sequence[AgentInfo],
        view: WorldView,
        goal: Goal,
        *,
        registry: ConditionRegistry | None = None,
        exclude: Sequence[tuple[str, str, Mapping[str, object]]] = (),
        progress: Progress | None = None,
        previous: Sequence[Block] = (),
    ) -> Plan:
        """:meth:`plan_sync` without blocking the loop: each task is built here (it reads
        ``view``), the solve runs in a worker thread under the limiter (``progress`` and
        ``previous``: see :meth:`solve`; ``progress`` is called from that thread)."""
        limiter = self._limiter or anyio.CapacityLimiter(1)
        self._limiter = limiter
        for chosen in self._agent_sets(agents, view, goal):
            task, where = self._build(chosen, view, goal, registry, exclude)
            solve = functools.partial(
                self.solve, task, where=where, progress=progress, previous=previous
            )
            try:
                return await anyio.to_thread.run_sync(solve, limiter=limiter)
            except (UnsolvableError, PlannerTimeoutError):
                if chosen is agents:
                    raise
                _log.debug("no plan with the %d agents near the goal; with all", len(chosen))
        raise AssertionError("unreachable: the last agent set is every agent")

    def _agent_sets(
        self, agents: Sequence[AgentInfo], view: WorldView, goal: Goal
    ) -> list[Sequence[AgentInfo]]:
        near = nearby_agents(agents, view, goal) if self.decompose else None
        return [agents] if near is None else [near, agents]

    def _build(
        self,
        agents: Sequence[AgentInfo],
        view: WorldView,
        goal: Goal,
        registry: ConditionRegistry | None,
        exclude: Sequence[tuple[str, str, Mapping[str, object]]],
    ) -> tuple[PlanningTask, dict[str, Point] | None]:
        from ..domain import build_task

        task = exclude_steps(build_task(agents, view, goal, registry=registry), exclude)
        return task, _where(task, view) if self.decompose else None

    def emit_pddl(
        self, task: PlanningTask, directory: Path | str, *, compressed: bool = False
    ) -> tuple[Path, Path]:
        """Write ``domain.pddl`` and ``problem.pddl`` for ``task`` (or its compressed form)
        into ``directory``; returns their paths."""
        if compressed:
            task = task.restrict(relevant_objects(task))
        with self._lock:
            writer = PDDLWriter(to_unified_planning(task, self._environment()))
            text = writer.get_domain(), writer.get_problem()
        out = Path(directory)
        out.mkdir(parents=True, exist_ok=True)
        domain, problem = out / "domain.pddl", out / "problem.pddl"
        domain.write_text(text[0])
        problem.write_text(text[1])
        return domain, problem


def _where(task: PlanningTask, view: WorldView) -> dict[str, Point]:
    """The poses the allocation's bids use: the agents' hardware and the goal's elements."""
    ids = {a for lit in task.goal for a in lit.args}
    for kit in hardware(task).values():
        ids |= kit
    return positions(view, ids)
