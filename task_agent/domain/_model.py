"""A planning task as data: actions, predicates, types, objects, facts and the goal.

:func:`~task_agent.domain.build_task` makes a :class:`PlanningTask` from the agents' skills
and the world model (the mapping is in :mod:`task_agent.domain`, the public entry point);
:mod:`task_agent.planning` turns it into a unified-planning problem and
:mod:`task_agent.reachability` analyses it. Pure data, no planner imports.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Literal, NamedTuple

import msgspec

__all__ = [
    "ROOT_TYPE",
    "ActionSchema",
    "ForallDelete",
    "GroundFact",
    "Lit",
    "PlanningTask",
    "Predicate",
    "PredicateKind",
]

ROOT_TYPE = "thing"
"""The root of the PDDL type tree."""
GroundFact = tuple[str, tuple[str, ...]]
"""A ground fact: predicate (atom name) and element ids."""
PredicateKind = Literal["relation", "value", "has", "type", "owns", "opaque"]


class Lit(NamedTuple):
    """An atom over variables (``?name``) and element ids, with its sign."""

    pred: str
    args: tuple[str, ...]
    positive: bool = True


class ForallDelete(NamedTuple):
    """``forall ?w: when cond(args) then not delete(args)``, with ``?w`` at ``free_pos`` of the
    two arguments and ``fixed`` (a variable or an element id) at the other."""

    cond: str
    delete: str
    fixed: str
    free_pos: int


class Predicate(msgspec.Struct, frozen=True):
    name: str
    kind: PredicateKind
    arity: int
    pddl: str
    static: bool = False


class ActionSchema(msgspec.Struct, frozen=True, kw_only=True):
    """One skill of one agent as a planning action. Variables are named after the skill's
    parameters; ``bound`` holds the parameters fixed to this agent's hardware."""

    name: str
    agent: str
    skill: str
    family: str
    duration: float
    params: tuple[tuple[str, str], ...]
    """(parameter name, type) of the action's variables, in order."""
    bound: dict[str, str]
    pre: tuple[Lit, ...] = ()
    empty_pre: tuple[tuple[tuple[str, ...], str, bool], ...] = ()
    """(relations, argument, positive): ``positive`` means no ``r(arg, ?w)`` for any r."""
    add: tuple[Lit, ...] = ()
    delete: tuple[Lit, ...] = ()
    forall_delete: tuple[ForallDelete, ...] = ()
    runtime_only: tuple[str, ...] = ()
    shared: tuple[str, ...] = ()
    """Bound devices the agent's configuration binds that are not its robot's own (a fixed
    camera several robots use): an agent locks a device for its own runs only, so these order
    no step of another agent."""


class PlanningTask(msgspec.Struct, frozen=True, kw_only=True):
    name: str
    types: dict[str, str]
    """PDDL type -> parent type (``ROOT_TYPE`` at the top)."""
    objects: dict[str, str]
    """Element id -> PDDL type."""
    predicates: dict[str, Predicate]
    init: frozenset[GroundFact]
    goal: tuple[Lit, ...]
    actions: dict[str, ActionSchema]
    skipped: tuple[str, ...] = ()
    """Skills left out of the domain, with the reason."""

    def restrict(self, keep: Iterable[str]) -> PlanningTask:
        """The same task over the objects in ``keep`` only (facts naming others dropped)."""
        objects = {o: t for o, t in self.objects.items() if o in set(keep)}
        init = frozenset(f for f in self.init if all(a in objects for a in f[1]))
        return msgspec.structs.replace(self, objects=objects, init=init)
