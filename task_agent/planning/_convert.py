"""A :class:`~task_agent.domain.PlanningTask` as a unified-planning problem, and plans back.

:func:`to_unified_planning` builds the ``Problem`` (in a given environment: a
:class:`~task_agent.planning.Planner` keeps its own), whose kind is derived from the task rather
than by walking every expression; :func:`plan_steps` maps an engine's plan to
:class:`~task_agent.planning.PlanStep` values and :func:`to_up_plan` maps steps back (for
unified-planning's validators). unified-planning is untyped: ``Any`` stays in this module.
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Sequence
from typing import Any

from unified_planning.environment import Environment
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

from ..domain import ROOT_TYPE, PlanningTask
from ._plan import PlanStep

__all__ = ["plan_steps", "to_unified_planning", "to_up_plan"]


class _Problem(Problem):  # type: ignore[misc]  # unified-planning is untyped
    """A problem built once and then only read. Its ``kind`` is the one :func:`_kind` derives
    from the task (unified-planning walks every expression for it, on every access: see
    docs/benchmarks.md, Planning: Performance problems found; a test checks both agree), and
    ``initial_values`` holds the explicit (true) facts only: every fluent is boolean with
    default false, so for the PDDL writer this is the same, without enumerating every ground
    fluent (quadratic)."""

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
    types: dict[str, Any] = {ROOT_TYPE: tm.UserType(ROOT_TYPE)}

    def utype(name: str) -> Any:
        if name not in types:
            types[name] = tm.UserType(name, utype(task.types[name]))
        return types[name]

    for name in task.types:
        utype(name)
    problem = _Problem(task.name, env)
    fluents: dict[str, Any] = {}
    for p in task.predicates.values():
        sig = OrderedDict((f"a{i}", types[ROOT_TYPE]) for i in range(p.arity))
        fluents[p.name] = Fluent(p.pddl, tm.BoolType(), sig, env)
        problem.add_fluent(fluents[p.name], default_initial_value=False)
    objects = {o: Object(o, utype(t), env) for o, t in task.objects.items()}
    problem.add_objects(objects.values())
    nodes = {o: em.ObjectExp(obj) for o, obj in objects.items()}

    def fact(pred: str, args: Sequence[Any]) -> Any:
        return em.FluentExp(fluents[pred], args)

    w = Variable("w", types[ROOT_TYPE], env)
    w_node = em.VariableExp(w)
    true, false = em.TRUE(), em.FALSE()
    for schema in task.actions.values():
        params = OrderedDict(
            (n, utype(t) if t != ROOT_TYPE else types[ROOT_TYPE]) for n, t in schema.params
        )
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


def plan_steps(task: PlanningTask, up_plan: Any) -> list[PlanStep]:
    """The steps of an engine's plan for ``task``'s problem (hardware parameters included)."""
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
