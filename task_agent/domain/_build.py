"""build_task: the skills' drafts, the vocabulary and the actions put together into a
:class:`~task_agent.domain.PlanningTask` (the mapping is in :mod:`task_agent.domain`)."""

from __future__ import annotations

from collections.abc import Sequence

from skill_agent import WorldView
from skill_agent.conditions import ConditionRegistry

from .._errors import DomainError
from .._goals import Goal, literal_atom
from ..discovery import AgentInfo
from ._actions import action_schema
from ._model import (
    Lit,
    PlanningTask,
)
from ._skills import Draft, action_names, draft
from ._spots import room_for_robots
from ._vocabulary import Vocabulary

__all__ = ["build_task"]


def build_task(
    agents: Sequence[AgentInfo],
    view: WorldView,
    goal: Goal,
    *,
    registry: ConditionRegistry | None = None,
    name: str = "skimesh",
) -> PlanningTask:
    """The planning task for ``goal`` with the skills of the available ``agents`` over the
    world model in ``view`` (see the module doc). DomainError if no skill is usable."""
    drafts: list[Draft] = []
    skipped: list[str] = []
    for agent in agents:
        if not agent.available:
            continue
        for desc in agent.skills:
            found = draft(agent, desc, view, registry)
            if isinstance(found, str):
                skipped.append(f"{desc.name} on {agent.name}: {found}")
            else:
                drafts.append(found)
    if not drafts:
        why = "; ".join(skipped) if skipped else "no available agent offers a skill"
        raise DomainError(f"no skill can be planned with: {why}")
    vocab = Vocabulary(view, drafts, [literal_atom(lit) for lit in goal.literals])
    vocab.predicates()
    hardware = {h for d in drafts for h in (*d.bound.values(), *d.agent.hardware)}
    vocab.types(goal.elements() | hardware)
    init = vocab.init()
    names = action_names(drafts)
    actions = {n: action_schema(vocab, d, n) for d, n in zip(drafts, names, strict=True)}
    robots = {n: d.agent.robot or "" for d, n in zip(drafts, names, strict=True)}
    actions, spot_facts = room_for_robots(vocab, actions, robots)
    init |= spot_facts
    goal_lits = tuple(Lit(a.predicate, a.args, a.positive) for a in vocab.goal_atoms)
    return PlanningTask(
        name=name,
        types=dict(vocab.tree),
        objects=vocab.objects,
        predicates=vocab.names.predicates,
        init=frozenset(init),
        goal=goal_lits,
        actions=actions,
        skipped=tuple(skipped),
    )
