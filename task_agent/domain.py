"""A planning task from the discovered agents' skill descriptions and the current world model.

Pure data, no planner imports: :mod:`task_agent.planner` turns a :class:`PlanningTask` into a
unified-planning problem (and PDDL). The mapping:

**Actions.** One per (available agent, skill): ``pick__robot1``, ``pick__robot2``, so skills of
the same name on two robots never collide and the planner chooses who acts. Hardware
parameters are bound to the agent's own machine (its robot and the devices reached through
``hasA``): one fitting device becomes a constant of the action; several stay a parameter
restricted by the static fact ``owns(robot, device)``; none leaves the skill out (in
``skipped``, with the reason). Other element parameters that appear in a symbolic condition
become action parameters typed by their class; the rest are left to the agent's inference at
run time. A skill needing a non-element value without a default is left out.

**Conditions.** ``skill_agent.conditions.symbolic`` gives each condition's atoms over
parameter names. Pre- and hold-conditions become preconditions, post-conditions effects
(positive atoms add, negative atoms delete). A condition without a symbolic face (numeric
comparisons, ``full``, unregistered custom conditions) is run-time only: the planner ignores
it and the action records it in ``runtime_only``. Effects also carry what the world model does
implicitly:

- a spatial relation ``contain(g, x)`` re-parents ``x``: every modeled spatial fact
  ``r(?w, x)`` is deleted (``forall ?w: when r(?w, x) then not r(?w, x)``) before the new one
  is added (PDDL applies adds after deletes, so ``contain(g, x)`` stays if it held);
- a relation fact implies its modeled super-properties (``contain`` -> ``spatialRelation``);
  deleting one deletes its sub-properties too (as an abstract unset does);
- ``q=v(x)`` deletes every other modeled value ``q=w(x)`` (a property has one value) and adds
  ``has_q(x)``;
- ``empty_p(x)`` is derived, not stored: as a precondition it is ``not exists ?w: p(x, ?w)``
  (over ``p`` and its sub-properties); as an effect it deletes every ``p(x, ?w)``; a negated
  ``empty`` effect is implied by others and ignored;
- ``is_C(x)`` and ``owns`` are static facts computed from the ontology and registrations.

**Types.** The ontology classes of the action parameters form the type tree (each class under
its nearest relevant superclass, the root is ``thing``); objects are the world-model elements
of those classes, those in facts of modeled relations, the goal's elements and the agents'
hardware. A class the tree cannot express (an object belongs to two relevant classes on
different branches) types its parameters as ``thing`` plus a static ``is_C`` precondition.

The code: :mod:`~task_agent.domain_model` (the task as data), :mod:`~task_agent.domain_skills`
(which skills become actions, their variables and atoms), :mod:`~task_agent.domain_vocabulary`
(predicates, types, objects, initial facts) and :mod:`~task_agent.domain_actions` (actions'
preconditions and effects); :func:`build_task` here puts them together.
"""

from __future__ import annotations

from collections.abc import Sequence

from skill_agent.conditions import ConditionRegistry
from skill_agent.conditions_model import value_text
from skill_agent.skill import WorldView

from .discovery_model import AgentInfo
from .domain_actions import action_schema
from .domain_model import (
    ROOT,
    ActionSchema,
    Fact,
    ForallDelete,
    Lit,
    PlanningTask,
    Predicate,
)
from .domain_model import PredicateKind as PredicateKind
from .domain_skills import Draft, action_names, draft
from .domain_vocabulary import Vocabulary
from .errors import DomainError
from .goals import Goal, literal_atom

__all__ = [
    "ROOT",
    "ActionSchema",
    "Fact",
    "ForallDelete",
    "Lit",
    "PlanningTask",
    "Predicate",
    "build_task",
    "value_text",
]


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
