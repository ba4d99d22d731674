"""Planning through unified-planning: the task layer's only contact with planner libraries.

:class:`Planner` solves a :class:`~task_agent.domain.PlanningTask` with Kairos (default,
in-process) or Fast Downward (``engine="fast-downward"``, a child process per call), within a
time-out, and returns a :class:`Plan` of agent-tagged steps. ``solve`` is the blocking core;
``async plan`` builds the task on the caller's loop (it reads the world-model replica, which
only the loop may touch) and solves in a worker thread through ``anyio.to_thread.run_sync``
with the planner's capacity limiter (one solve at a time by default).

Before solving, the task is compressed to the objects the goal can touch
(:func:`~task_agent.reachability.relevant_objects`), unless the goal itself names most objects
(:data:`COMPRESS_BELOW`); the plan is replayed on the full task and, if that fails or the small
task has no plan, the full task is solved. A goal without a plan
raises :class:`~task_agent.errors.UnsolvableError` with the goal facts that can never hold
and why (:func:`~task_agent.reachability.diagnose`); running out of time raises
:class:`~task_agent.errors.PlannerTimeoutError`; any other engine failure
:class:`~task_agent.errors.PlanningError` with the engine's log.

unified-planning has process-wide defaults (``get_environment()`` and its engine factory);
this module never touches them. Each :class:`Planner` builds its problems in its own
``Environment``, used by one solve at a time (a lock) and replaced every
:data:`ENVIRONMENT_SOLVES` solves, since an environment caches every expression ever built.
Engines are instantiated directly (``KairosEngine``, ``FastDownwardPDDLPlanner``) and called
through unified-planning's engine API: the factory's engine lookup and credits printing inspect
the Python stack on every call (~12 ms each), and so does creating an environment.
unified-planning is untyped: ``Any`` stays in this module.
"""

from __future__ import annotations

import math
import threading
import time
from collections import OrderedDict
from collections.abc import Sequence
from pathlib import Path
from typing import Any, Literal

import anyio
import msgspec
from unified_planning.engines import PlanGenerationResultStatus as Status
from unified_planning.environment import Environment
from unified_planning.exceptions import UPException
from unified_planning.io import PDDLWriter
from unified_planning.model import (
    Fluent,
    InstantaneousAction,
    Object,
    Problem,
    ProblemKind,
    Variable,
)
from unified_planning.model.problem_kind_versioning import LATEST_PROBLEM_KIND_VERSION
from unified_planning.plans import ActionInstance, SequentialPlan
from up_fast_downward import FastDownwardPDDLPlanner
from up_kairos import KairosEngine

from skill_agent.conditions import ConditionRegistry
from skill_agent.skill import WorldView

from .discovery_model import AgentInfo
from .domain import ROOT, PlanningTask
from .errors import PlannerTimeoutError, PlanningError, UnsolvableError
from .goals import Goal
from .reachability import GroundStep, diagnose, relevant_objects, replay

__all__ = [
    "COMPRESS_BELOW",
    "ENVIRONMENT_SOLVES",
    "FD_SEARCH",
    "Engine",
    "Plan",
    "PlanStats",
    "PlanStep",
    "Planner",
    "to_unified_planning",
    "to_up_plan",
]

Engine = Literal["kairos", "fast-downward"]
ENVIRONMENT_SOLVES = 32
"""Solves per unified-planning environment before a planner starts a fresh one."""
COMPRESS_BELOW = 0.5
"""Compress only when the goal names fewer than this share of the task's objects: a goal
naming most of them keeps nearly all the others too, and the analysis costs 10-20 ms."""


class PlanStep(msgspec.Struct, frozen=True, kw_only=True):
    """One skill run: who, what, with which parameters (skill parameter -> element id,
    hardware included; parameters left out are inferred by the agent)."""

    index: int
    action: str
    agent: str
    skill: str
    args: tuple[str, ...]
    """The action's arguments, in the order of its parameters."""
    params: dict[str, str]
    duration: float

    @property
    def ground(self) -> GroundStep:
        return GroundStep(self.action, self.args)

    def __str__(self) -> str:
        args = ", ".join(f"{k}={v}" for k, v in self.params.items())
        return f"{self.agent}: {self.skill}({args})"


class PlanStats(msgspec.Struct, frozen=True, kw_only=True):
    engine: str
    objects: int
    """Objects of the full task."""
    objects_solved: int
    """Objects of the task the engine solved (fewer when compression applied)."""
    fallback: bool = False
    """The compressed task failed and the full task was solved."""
    convert_s: float = 0.0
    """Building the unified-planning problem."""
    solve_s: float = 0.0
    """The engine call through unified-planning (PDDL writing, parsing, search)."""
    engine_s: float = math.nan
    """The engine's own figure for its work, when it reports one."""
    total_s: float = 0.0


class Plan(msgspec.Struct, frozen=True, kw_only=True):
    steps: tuple[PlanStep, ...]
    task: PlanningTask
    stats: PlanStats

    @property
    def duration(self) -> float:
        """Estimated seconds when the steps run one after the other."""
        return sum(s.duration for s in self.steps)

    def __str__(self) -> str:
        return "\n".join(f"{s.index + 1:3d}. {s}" for s in self.steps) or "(empty plan)"


# --------------------------------------------------------------------------- conversion


class _Problem(Problem):  # type: ignore[misc]  # unified-planning is untyped
    """A problem built once and then only read. Its ``kind`` is the one :func:`_kind` derives
    from the task (unified-planning walks every expression for it, on every access: ~9
    times and ~12 ms per solve; a test checks both agree), and ``initial_values`` holds the
    explicit (true) facts only: every fluent is boolean with default false, so for the PDDL
    writer this is the same, without enumerating every ground fluent (quadratic)."""

    _kind_cache: Any = None

    @property
    def kind(self) -> Any:
        if self._kind_cache is None:
            self._kind_cache = Problem.kind.fget(self)
        return self._kind_cache

    @property
    def initial_values(self) -> Any:
        return dict(self.explicit_initial_values)


def _kind(task: PlanningTask) -> Any:
    """The unified-planning problem kind of ``task``'s problem, from what the generator
    emits: typing, negated, existential and disjunctive (``empty``) preconditions, and
    conditional ``forall`` deletes."""
    kind = ProblemKind(version=LATEST_PROBLEM_KIND_VERSION)
    kind.set_problem_class("ACTION_BASED")
    kind.set_typing("FLAT_TYPING")
    kind.set_typing("HIERARCHICAL_TYPING")
    actions = task.actions.values()
    negative = any(not lit.positive for a in actions for lit in a.pre)
    negative |= any(positive for a in actions for _, _, positive in a.empty_pre)
    negative |= any(not lit.positive for lit in task.goal)
    if negative:
        kind.set_conditions_kind("NEGATIVE_CONDITIONS")
    if any(a.empty_pre for a in actions):
        kind.set_conditions_kind("EXISTENTIAL_CONDITIONS")
    if any(len(preds) > 1 for a in actions for preds, _, _ in a.empty_pre):
        kind.set_conditions_kind("DISJUNCTIVE_CONDITIONS")
    if any(a.forall_delete for a in actions):
        kind.set_effects_kind("CONDITIONAL_EFFECTS")
        kind.set_effects_kind("FORALL_EFFECTS")
    return kind


def to_unified_planning(task: PlanningTask, environment: Any = None) -> Any:
    """``task`` as a unified-planning ``Problem`` in ``environment`` (default: a fresh one)."""
    env = environment if environment is not None else Environment()
    tm, em = env.type_manager, env.expression_manager
    types: dict[str, Any] = {ROOT: tm.UserType(ROOT)}

    def utype(name: str) -> Any:
        if name not in types:
            types[name] = tm.UserType(name, utype(task.types[name]))
        return types[name]

    for name in task.types:
        utype(name)
    problem = _Problem(task.name, env)
    fluents: dict[str, Any] = {}
    for p in task.predicates.values():
        sig = OrderedDict((f"a{i}", types[ROOT]) for i in range(p.arity))
        fluents[p.name] = Fluent(p.pddl, tm.BoolType(), sig, env)
        problem.add_fluent(fluents[p.name], default_initial_value=False)
    objects = {o: Object(o, utype(t), env) for o, t in task.objects.items()}
    problem.add_objects(objects.values())
    nodes = {o: em.ObjectExp(obj) for o, obj in objects.items()}

    def fact(pred: str, args: Sequence[Any]) -> Any:
        return em.FluentExp(fluents[pred], args)

    w = Variable("w", types[ROOT], env)
    w_node = em.VariableExp(w)
    true, false = em.TRUE(), em.FALSE()
    for schema in task.actions.values():
        params = OrderedDict((n, utype(t) if t != ROOT else types[ROOT]) for n, t in schema.params)
        action = InstantaneousAction(schema.name, params, env)
        scope = {f"?{p.name}": em.ParameterExp(p) for p in action.parameters}
        scope.update(nodes)

        def node(a: str, scope: dict[str, Any] = scope) -> Any:
            return scope[a]

        for lit in schema.pre:
            f = fact(lit.pred, [node(a) for a in lit.args])
            action.add_precondition(f if lit.positive else em.Not(f))
        for preds, arg, positive in schema.empty_pre:
            some = em.Exists(em.Or([fact(p, [node(arg), w_node]) for p in preds]), w)
            action.add_precondition(em.Not(some) if positive else some)
        for lit in schema.delete:
            action.add_effect(fact(lit.pred, [node(a) for a in lit.args]), false)
        for fd in schema.forall_delete:
            pair = [w_node, node(fd.fixed)] if fd.free_pos == 0 else [node(fd.fixed), w_node]
            action.add_effect(fact(fd.delete, pair), false, fact(fd.cond, pair), forall=[w])
        for lit in schema.add:
            action.add_effect(fact(lit.pred, [node(a) for a in lit.args]), true)
        problem.add_action(action)
    for pred, args in task.init:
        problem.set_initial_value(fact(pred, [nodes[a] for a in args]), true)
    for lit in task.goal:
        f = fact(lit.pred, [nodes[a] for a in lit.args])
        problem.add_goal(f if lit.positive else em.Not(f))
    problem._kind_cache = _kind(task)
    return problem


def to_up_plan(problem: Any, steps: Sequence[PlanStep]) -> Any:
    """Our steps as a unified-planning ``SequentialPlan`` of ``problem`` (for its validators)."""
    env = problem.environment
    return SequentialPlan(
        [
            ActionInstance(
                problem.action(s.action),
                [env.expression_manager.ObjectExp(problem.object(a)) for a in s.args],
            )
            for s in steps
        ],
        env,
    )


def _steps(task: PlanningTask, up_plan: Any) -> list[PlanStep]:
    out = []
    for i, instance in enumerate(up_plan.actions):
        schema = task.actions[instance.action.name]
        args = tuple(p.object().name for p in instance.actual_parameters)
        params = dict(schema.bound)
        params.update((name, a) for (name, _), a in zip(schema.params, args, strict=True))
        out.append(
            PlanStep(
                index=i,
                action=schema.name,
                agent=schema.agent,
                skill=schema.skill,
                args=args,
                params=params,
                duration=schema.duration,
            )
        )
    return out


class _Attempt(msgspec.Struct, kw_only=True):
    status: Any
    steps: list[PlanStep]
    log: str
    convert_s: float
    solve_s: float
    engine_s: float


# --------------------------------------------------------------------------- the planner

# lama-first (Fast Downward's default satisficing alias), except that its heuristics
# over-approximate negated derived facts: ``empty`` preconditions are negated existentials,
# which FD compiles into axioms, and computing their negations exactly multiplied the
# relaxed operators 2000-fold (131k unary operators and 1.4 s for 2 robots x 8 parts,
# 62 operators and 4 ms with this setting). Plans are still exact; only guidance changes.
# (No spaces: up-fast-downward splits the configuration on whitespace.)
FD_SEARCH = (
    "let(hlm,eval_modify_costs(landmark_sum(lm_factory=lm_reasonable_orders_hps(lm_rhw()),"
    "pref=false,axioms=approximate_negative),cost_type=one),"
    "let(hff,eval_modify_costs(ff(axioms=approximate_negative),cost_type=one),"
    "lazy_greedy([hff,hlm],preferred=[hff,hlm],cost_type=one,reopen_closed=false)))"
)


class _FastDownward(FastDownwardPDDLPlanner):  # type: ignore[misc]  # untyped
    """Fast Downward with two fixes to how unified-planning 1.3 runs it.

    - Its translator writes ``output.sas`` into the *caller's* working directory, so two
      solves at once from one directory (two planners in threads, two test processes)
      overwrite each other's file: one then fails or answers for the other problem. Here
      the file goes next to the plan file, in the solve's own temporary directory.
    - On a time-out unified-planning kills the process group but neither waits for it nor
      closes its pipes (a zombie and two unclosed files per time-out); :meth:`reap` does both.
    """

    def _base_cmd(self, plan_filename: str) -> list[str]:
        cmd: list[str] = super()._base_cmd(plan_filename)
        return [*cmd, "--sas-file", str(Path(plan_filename).with_name("output.sas"))]

    @property
    def _process(self) -> Any:
        return self.__dict__.get("_current")

    @_process.setter
    def _process(self, process: Any) -> None:
        self.__dict__["_current"] = process
        if process is not None:
            self.__dict__["_started"] = process

    def reap(self) -> None:
        process = self.__dict__.pop("_started", None)
        if process is None:
            return
        for stream in (process.stdout, process.stderr):
            if stream is not None:
                stream.close()
        process.wait(timeout=10)


_UNSOLVABLE = {Status.UNSOLVABLE_PROVEN, Status.UNSOLVABLE_INCOMPLETELY}
_SOLVED = {Status.SOLVED_SATISFICING, Status.SOLVED_OPTIMALLY}


class Planner:
    """Solves planning tasks with one engine.

    ``engine``: ``"kairos"`` (default) or ``"fast-downward"``. ``timeout``: seconds per
    :meth:`solve` (both attempts when the compressed task falls back to the full one).
    ``compress``: solve over the objects the goal can touch first. ``limiter``: bounds the
    concurrent solves of :meth:`plan` (default: one at a time, its own)."""

    def __init__(
        self,
        *,
        engine: Engine = "kairos",
        timeout: float = 30.0,
        compress: bool = True,
        limiter: anyio.CapacityLimiter | None = None,
    ) -> None:
        if engine not in ("kairos", "fast-downward"):
            raise ValueError(f"unknown engine {engine!r}; use 'kairos' or 'fast-downward'")
        self.engine: Engine = engine
        self.timeout = timeout
        self.compress = compress
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

    def _engine(self) -> Any:
        if self.engine == "kairos":
            return KairosEngine()
        return _FastDownward(fast_downward_search_config=FD_SEARCH)

    def _attempt(self, task: PlanningTask, timeout: float) -> _Attempt:
        t0 = time.perf_counter()
        problem = to_unified_planning(task, self._environment())
        t1 = time.perf_counter()
        with self._engine() as engine:
            try:
                result = engine.solve(problem, timeout=max(timeout, 0.001))
            except UPException as exc:
                raise PlanningError(f"{self.engine} failed: {exc}") from exc
            finally:
                if isinstance(engine, _FastDownward):
                    engine.reap()
        t2 = time.perf_counter()
        steps = _steps(task, result.plan) if result.status in _SOLVED else []
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

    def solve(self, task: PlanningTask) -> Plan:
        """A plan for ``task`` (blocking; see the module doc for the errors). Thread-safe:
        concurrent calls on one planner run one after the other."""
        with self._lock:
            return self._solve(task)

    def _solve(self, task: PlanningTask) -> Plan:
        start = time.perf_counter()
        deadline = start + self.timeout
        solved = task
        named = {a for lit in task.goal for a in lit.args}
        if self.compress and len(named) < COMPRESS_BELOW * len(task.objects):
            keep = relevant_objects(task)
            if len(keep) < len(task.objects):
                solved = task.restrict(keep)
        attempt = self._attempt(solved, self.timeout)
        fallback = False
        problem = "not solved"
        if attempt.status in _SOLVED:
            _, problem = replay(task, [s.ground for s in attempt.steps])
        if solved is not task and problem and attempt.status != Status.TIMEOUT:
            fallback, solved = True, task
            attempt = self._attempt(task, deadline - time.perf_counter())
            if attempt.status in _SOLVED:
                _, problem = replay(task, [s.ground for s in attempt.steps])
        self._raise_for(attempt, task)
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

    def _raise_for(self, attempt: _Attempt, task: PlanningTask) -> None:
        if attempt.status in _SOLVED:
            return
        if attempt.status == Status.TIMEOUT:
            raise PlannerTimeoutError(
                f"{self.engine} found no plan within {self.timeout} s ({len(task.objects)} "
                f"objects, {len(task.actions)} actions); give it more time or split the goal",
                timeout=self.timeout,
            )
        if attempt.status in _UNSOLVABLE:
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
    ) -> Plan:
        """Build the task from the agents and the world model, then :meth:`solve` it."""
        from .domain import build_task

        return self.solve(build_task(agents, view, goal, registry=registry))

    async def plan(
        self,
        agents: Sequence[AgentInfo],
        view: WorldView,
        goal: Goal,
        *,
        registry: ConditionRegistry | None = None,
    ) -> Plan:
        """:meth:`plan_sync` without blocking the loop: the task is built here (it reads
        ``view``), the solve runs in a worker thread under the limiter."""
        from .domain import build_task

        task = build_task(agents, view, goal, registry=registry)
        limiter = self._limiter or anyio.CapacityLimiter(1)
        self._limiter = limiter
        return await anyio.to_thread.run_sync(self.solve, task, limiter=limiter)

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
