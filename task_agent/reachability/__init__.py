"""Analyses of a :class:`~task_agent.domain.PlanningTask` that need no planner (pure).

``State`` / :func:`apply` / :func:`replay`
    The action semantics of the generated domain, step by step (what a PDDL validator does):
    the partial order reads each step's ground reads and writes from here, and a plan found
    on a compressed task is re-checked on the full one.
:func:`relevant_objects`
    Problem compression: a backward relevance closure from the goal over the actions'
    effects and preconditions, lifted (unbound parameters are wildcards). Objects not named by
    a relevant pattern nor by an initial fact matching one are left out of the task given to
    the engine. A plan for the smaller task is replayed on the full one; if that fails, or the
    smaller task has no plan, the planner solves the full task.
:func:`diagnose`
    Why a goal cannot be reached: delete-relaxed forward reachability from the initial facts,
    then, for each goal fact never reached, the achieving actions and their unreachable
    preconditions, two levels deep.

The code: ``_replay`` (the action semantics), ``_relevance`` (compression) and
``_diagnose`` (why a goal is unreachable).
"""

from ._diagnose import diagnose as diagnose
from ._relevance import Typing as Typing
from ._relevance import Writers as Writers
from ._relevance import relevant_objects as relevant_objects
from ._relevance import unify as unify
from ._replay import GroundStep as GroundStep
from ._replay import State as State
from ._replay import StepEffects as StepEffects
from ._replay import apply as apply
from ._replay import fact_text as fact_text
from ._replay import replay as replay
from ._replay import unmet as unmet
from ._replay import unmet_goals as unmet_goals

__all__ = [
    "GroundStep",
    "State",
    "StepEffects",
    "Typing",
    "Writers",
    "apply",
    "diagnose",
    "fact_text",
    "relevant_objects",
    "replay",
    "unify",
    "unmet",
    "unmet_goals",
]
