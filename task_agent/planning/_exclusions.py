"""Grounded steps a task must not plan again: :func:`exclude_steps`.

A step that failed on the robot (its agent, skill and parameters: a grounding of one action)
is excluded from the task's later plans by a static predicate per action,
``learned_failed_<action>(args...)``, true for each failed grounding and negated in the
action's preconditions. Its arguments are the parameters the action's effects name (what the
step changes: a place's object and container, not the location it stands at), so the same
change is not tried again by varying a parameter it does not depend on; an action whose
effects name none is banned over all its parameters. Every other grounding stays open (the
same skill on another object, or the same object on another robot). The planners, replay,
relevance and the unreachability diagnosis see it as any other static fact.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping

import msgspec

from ..domain import ActionSchema, GroundFact, Lit, PlanningTask, Predicate

__all__ = ["BANNED_PREFIX", "exclude_steps", "grounding"]

BANNED_PREFIX = "learned_failed_"
"""The predicates :func:`exclude_steps` adds start with this."""


def grounding(
    task: PlanningTask, agent: str, skill: str, params: Mapping[str, object]
) -> tuple[ActionSchema, tuple[str, ...]] | None:
    """The action and arguments of ``skill`` run on ``agent`` with ``params``, or None when
    the task has no such action or a parameter of it is missing (or no element id)."""
    for schema in task.actions.values():
        if schema.agent != agent or schema.skill != skill:
            continue
        args = tuple(params.get(name) for name, _ in schema.params)
        if all(isinstance(a, str) and a for a in args):
            return schema, tuple(str(a) for a in args)
    return None


def _changed(schema: ActionSchema) -> list[int]:
    """Positions of the parameters the action's effects name (all, if they name none)."""
    named = {a for lit in (*schema.add, *schema.delete) for a in lit.args}
    named |= {fd.fixed for fd in schema.forall_delete}
    keep = [i for i, (n, _) in enumerate(schema.params) if f"?{n}" in named]
    return keep or list(range(len(schema.params)))


def exclude_steps(
    task: PlanningTask, steps: Iterable[tuple[str, str, Mapping[str, object]]]
) -> PlanningTask:
    """``task`` without the groundings of ``steps`` ((agent, skill, parameters) each)."""
    banned: dict[str, set[tuple[str, ...]]] = {}
    for agent, skill, params in steps:
        found = grounding(task, agent, skill, params)
        if found is not None:
            banned.setdefault(found[0].name, set()).add(found[1])
    if not banned:
        return task
    predicates = dict(task.predicates)
    actions = dict(task.actions)
    init: set[GroundFact] = set(task.init)
    for name, groundings in sorted(banned.items()):
        schema = actions[name]
        keep = _changed(schema)
        pred = f"{BANNED_PREFIX}{name}"
        predicates[pred] = Predicate(pred, "opaque", len(keep), pred, static=True)
        variables = tuple(f"?{schema.params[i][0]}" for i in keep)
        actions[name] = msgspec.structs.replace(
            schema, pre=(*schema.pre, Lit(pred, variables, positive=False))
        )
        init |= {(pred, tuple(args[i] for i in keep)) for args in groundings}
    return msgspec.structs.replace(
        task, predicates=predicates, actions=actions, init=frozenset(init)
    )
