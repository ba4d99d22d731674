"""Planning: solving a :class:`~task_agent.domain.PlanningTask` through unified-planning, and
the plan as a partial order the robots can run in parallel.

:class:`Planner` solves a task with Kairos (default, in-process) or Fast Downward
(``engine="fast-downward"``, a child process per call), within a time-out, and returns a
:class:`Plan` of agent-tagged :class:`PlanStep` values (with :class:`PlanStats`). By default
it plans a task of :data:`DECOMPOSE_FROM` objects or more *by parts* (``decompose=True``):
the goal's independent parts are allocated to agents first (a least-cost assignment over
bids from the scene graph and the poses) and planned one after the other as small problems
over the elements near each part, widened until a plan holds on the full task (coupled
parts, such as two robots that need each other's spot, are planned together); when a part
has no plan at any width the whole task is solved (the monolithic path,
``decompose=False``, which alone may report a goal unsolvable). For a goal that needs few
agents, the task is built for the agents near it first. A replan passes what the last plan
has left to run (:meth:`Plan.remaining`): a part whose remaining steps still reach it is kept
as it was.

:func:`to_partial_order` relaxes the plan's sequence into a :class:`PartialOrderPlan`: the
:class:`Edge` values that must stay ordered (causal links, threats, conflicts, shared
hardware), a schedule of :class:`ScheduledStep` values (durations from a :class:`StepTiming`
when given: the learned ones) and, with ``balance=True``, steps moved between interchangeable
robots to shorten the makespan. :func:`exclude_steps` removes grounded steps that failed from
a task (``Planner.plan(..., exclude=...)``).

This sub-package is the task layer's only contact with planner libraries: importing it imports
unified-planning (see docs/benchmarks.md, Planning). The code: ``_plan`` (:class:`Plan` and its
steps, pure data), ``_convert`` (task to unified-planning problem, engine plan to steps),
``_engines`` (Kairos and Fast Downward), ``_planner`` (:class:`Planner`: environments,
compression, fallback, errors), ``_parts`` (goal parts, the fact graph), ``_allocate`` (who
takes which part), ``_decompose`` (the part-by-part solve), ``_exclusions`` (failed
groundings) and ``_partial_order``.
"""

from ._convert import to_unified_planning as to_unified_planning
from ._convert import to_up_plan as to_up_plan
from ._engines import FD_SEARCH as FD_SEARCH
from ._exclusions import exclude_steps as exclude_steps
from ._partial_order import Edge as Edge
from ._partial_order import EdgeReason as EdgeReason
from ._partial_order import PartialOrderPlan as PartialOrderPlan
from ._partial_order import ScheduledStep as ScheduledStep
from ._partial_order import StepTiming as StepTiming
from ._partial_order import to_partial_order as to_partial_order
from ._plan import Engine as Engine
from ._plan import Plan as Plan
from ._plan import PlanStats as PlanStats
from ._plan import PlanStep as PlanStep
from ._planner import COMPRESS_BELOW as COMPRESS_BELOW
from ._planner import DECOMPOSE_FROM as DECOMPOSE_FROM
from ._planner import ENVIRONMENT_SOLVES as ENVIRONMENT_SOLVES
from ._planner import Planner as Planner

__all__ = [
    "COMPRESS_BELOW",
    "DECOMPOSE_FROM",
    "ENVIRONMENT_SOLVES",
    "FD_SEARCH",
    "Edge",
    "EdgeReason",
    "Engine",
    "PartialOrderPlan",
    "Plan",
    "PlanStats",
    "PlanStep",
    "Planner",
    "ScheduledStep",
    "StepTiming",
    "exclude_steps",
    "to_partial_order",
    "to_unified_planning",
    "to_up_plan",
]
