"""The planning domain: a planning task from the discovered agents' skill descriptions and
the current world model.

Pure data, no planner imports: :mod:`task_agent.planning` turns a :class:`PlanningTask` into a
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

The code: ``_model`` (the task as data), ``_skills`` (which skills become actions, their
variables and atoms), ``_vocabulary`` (predicates, types, objects, initial facts), ``_actions``
(actions' preconditions and effects) and ``_build`` (:func:`build_task`, which puts them
together). :mod:`task_agent.reachability` analyses a task without a planner.
"""

from ._build import build_task as build_task
from ._model import ROOT_TYPE as ROOT_TYPE
from ._model import ActionSchema as ActionSchema
from ._model import ForallDelete as ForallDelete
from ._model import GroundFact as GroundFact
from ._model import Lit as Lit
from ._model import PlanningTask as PlanningTask
from ._model import Predicate as Predicate
from ._model import PredicateKind as PredicateKind

__all__ = [
    "ROOT_TYPE",
    "ActionSchema",
    "ForallDelete",
    "GroundFact",
    "Lit",
    "PlanningTask",
    "Predicate",
    "PredicateKind",
    "build_task",
]
